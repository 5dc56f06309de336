// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_DATASETS_BALL_CLIP_HPP
#define OPENCV_VBME_DATASETS_BALL_CLIP_HPP

#include <opencv2/core.hpp>

#include "opencv2/vbme/track/disk.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_datasets
//! @{

/** @brief A synthetic clip with exact ground truth for the tracker: a shaded coloured ball
moving and changing size over a textured background, with a specular highlight, sensor noise
and distractors. Used by the tests, the benchmarks and `vbme demo`. Frames are a pure function
of (parameters, index).
*/
class CV_EXPORTS SyntheticBallClip {
public:
    /** @brief What the clip contains. */
    struct CV_EXPORTS Params {
        Params();                                    //!< the defaults below
        Size size = Size(640, 480);                  //!< frame size
        int frames = 60;                             //!< number of frames
        Vec3f ball_rgb = Vec3f(1.0f, 0.35f, 0.03f);  //!< ball albedo (linear RGB): orange
        float radius_min = 34, radius_max = 52;      //!< radius range (pixels, at 640×480)
        float highlight = 1.0f;                      //!< specular highlight strength (0 = none)
        /** Direction towards the light making the highlight (camera frame); the default is the
        key light, upper left. A grazing direction puts the highlight on the rim. */
        Vec3f highlight_dir = Vec3f(-0.45f, -0.65f, -0.6f);
        float noise_sigma = 3.0f;          //!< sensor noise (8-bit levels)
        bool distractor = true;            //!< a ball of another hue (blue) moving about
        bool same_hue_distractor = false;  //!< an orange patch elsewhere (far from the ball)
        float light_drift = 0.f;           //!< 0..1: the illumination's colour drifts over the clip
        int hide_from = -1;                //!< frames [hide_from, hide_to) show no ball (occlusion)
        int hide_to = -1;                  //!< end of the hidden range
        int seed = 1;                      //!< texture and noise seed
    };

    /** @brief Prepares the clip (builds the background texture). */
    explicit SyntheticBallClip(const Params& params = Params());

    /** @brief Frame @p i (8-bit BGR, sRGB-encoded). @param truth receives the ball's disk
    (radius 0 when the ball is hidden). */
    Mat frame(int i, Disk* truth = nullptr) const;
    /** @brief The ball's true disk in frame @p i. */
    Disk truth(int i) const;
    /** @brief The settings. */
    const Params& params() const { return params_; }

private:
    Params params_;
    Mat background_;  // linear CV_32FC3
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
