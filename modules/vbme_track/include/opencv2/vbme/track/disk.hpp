// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_TRACK_DISK_HPP
#define OPENCV_VBME_TRACK_DISK_HPP

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_track
//! @{

/** @brief A disk in image coordinates (pixel centres at integers). A pixel (x, y) is inside
when (x − cx)² + (y − cy)² ≤ r². */
struct CV_EXPORTS Disk {
    Point2f center;    //!< centre (pixels)
    float radius = 0;  //!< radius (pixels)
    Disk() = default;
    Disk(Point2f c, float r) : center(c), radius(r) {}
    /** @brief Whether pixel centre @p p lies inside. */
    bool contains(Point2f p) const {
        const float dx = p.x - center.x, dy = p.y - center.y;
        return dx * dx + dy * dy <= radius * radius;
    }
};

/** @brief Draws the disk as a binary mask (255 inside, 0 outside) of size @p size. */
CV_EXPORTS void diskMask(Size size, const Disk& d, OutputArray mask);

/** @brief Intersection over union of two binary masks (non-zero = set); 1 when both are
empty. */
CV_EXPORTS double maskIoU(InputArray a, InputArray b);

/** @brief The quality of Eq. 4.6 (thesis §4.1), computed pixel by pixel (reference).

Every pixel agreeing with the disk scores +1 (object inside, background outside), every
disagreeing pixel −1. With @p votes instead of a binary mask (CV_8S: +1 object, −1
background, 0 unknown) unknown pixels score 0.
@param mask CV_8U binary mask (non-zero = object) or CV_8S votes.
@param d the disk. */
CV_EXPORTS double diskQuality(InputArray mask, const Disk& d);

/** @brief Parameters of fitDisk(). */
struct CV_EXPORTS DiskFitParams {
    float min_step = 0.25f;      //!< finest step of the hill climbing (pixels); 1 for integers only
    int max_iterations = 10000;  //!< safety bound on moves
    float min_radius = 2.f;      //!< smallest radius considered
    float max_radius = 0.f;      //!< largest radius considered; 0 = no bound

    /** @brief Reads the fields present in the map @p fn (others keep their value); an unknown
    key or a value check() refuses is an error. */
    void read(const FileNode& fn);
    /** @brief Writes every field as `name: value` into the open map of @p fs. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief Fits a disk to a mask by hill climbing on the quality of Eq. 4.6.

Starts from @p init if given, else from the median of the mask pixels with diameter the mean
of the mask's width and height (the thesis's initialisation), and moves the centre by ±step in
x or y or the radius by ±step while the quality grows; the step then halves down to
DiskFitParams::min_step. The quality of a candidate is evaluated in O(r) from per-row prefix
sums of the votes (one pass over the image), not by visiting the disk's pixels, so a whole fit
costs little more than the prefix sums.
@param mask CV_8U binary mask (non-zero = object) or CV_8S votes (+1 / −1 / 0 unknown).
@param init starting disk, or nullptr.
@param params hill-climbing settings.
@return the fitted disk; radius 0 if the mask holds no object pixel. */
CV_EXPORTS Disk fitDisk(InputArray mask, const Disk* init = nullptr,
                        const DiskFitParams& params = DiskFitParams());

/** @brief The thesis's initial disk: median of the object pixels, diameter the mean of their
bounding box's width and height. Radius 0 for an empty mask. */
CV_EXPORTS Disk initialDisk(InputArray mask);

/** @brief Sub-pixel refinement of a disk against the background behind it.

Along 64 rays from the centre, the coverage `α = (I − B)·(F − B)/|F − B|²` (I the frame, B the
background, F the frame 1.25 px inside the rim) falls through ½ at the edge, located by linear
interpolation between samples 0.25 px apart from r − 1 to r + 2.5; a circle is fitted to those
edge points (algebraic least squares, @cite Kasa1976). A ray is skipped where it leaves the
image or where |F − B| < 0.02 (no contrast). The disk is returned unchanged when fewer than 16
rays remain, when its radius is under 6 px, or when the fit moves the centre or the radius by
more than 1.5 px (a fit that far off is not trusted).
@param frame the frame showing the object, linear CV_32FC3.
@param background the same view without the object (e.g. inpainted), linear CV_32FC3, same size.
@param disk the disk to refine (e.g. ObjectTracker's, within about a pixel).
@return the refined disk. */
CV_EXPORTS Disk refineDisk(InputArray frame, InputArray background, const Disk& disk);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
