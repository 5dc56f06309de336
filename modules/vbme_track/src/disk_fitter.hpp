// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Hill-climbing disk fit on per-row prefix sums of votes (private to vbme_track).
#ifndef VBME_TRACK_DISK_FITTER_HPP
#define VBME_TRACK_DISK_FITTER_HPP

#include "opencv2/vbme/track/disk.hpp"

namespace cv {
namespace vbme {
namespace detail {

/** Fits disks to a vote image (+1 object, −1 background, 0 unknown). setVotes() builds
per-row prefix sums once (O(pixels)); sumInside() then costs O(r). Buffers are reused across
frames of equal or smaller size. */
class DiskFitter {
public:
    /** votes: CV_8S (+1/−1/0) or CV_8U binary (non-zero → +1, zero → −1). */
    void setVotes(const Mat& votes);
    /** Σ votes over pixels inside the disk (pixels outside the image count 0). */
    int sumInside(float cx, float cy, float r) const;
    /** Σ votes over the whole image. */
    int total() const { return total_; }
    /** Eq. 4.6: agreements − disagreements = 2·sumInside − total. */
    double quality(const Disk& d) const {
        return 2.0 * sumInside(d.center.x, d.center.y, d.radius) - total_;
    }
    /** Steepest-ascent hill climbing from init over (x±s, y±s, r±s), s halving to min_step. */
    Disk fit(const Disk& init, const DiskFitParams& p) const;
    /** Thesis initialisation from the positive votes; radius 0 if there are none. */
    Disk initial() const;
    Size size() const { return size_; }

private:
    Size size_;
    Mat prefix_;                              // CV_32S, rows × (cols + 1)
    std::vector<int> row_count_, col_count_;  // positive votes per row / column
    int total_ = 0;
};

}  // namespace detail
}  // namespace vbme
}  // namespace cv

#endif
