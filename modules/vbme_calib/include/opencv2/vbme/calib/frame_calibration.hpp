// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CALIB_FRAME_CALIBRATION_HPP
#define OPENCV_VBME_CALIB_FRAME_CALIBRATION_HPP

#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/vbme/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_calib
//! @{

/** @brief What a set of parallel world lines is known to be. */
enum class AxisHint {
    ANY,         //!< unknown: the vertical is the direction closest to the image's y axis
    HORIZONTAL,  //!< lines parallel to the floor (along a wall)
    VERTICAL     //!< lines along world z (wall–wall corners, door frames)
};

/** @brief Parses "any", "horizontal" or "vertical"; throws naming @p field otherwise. */
CV_EXPORTS AxisHint parseAxisHint(const std::string& name, const std::string& field = "axis");
/** @brief The file name of an axis hint. */
CV_EXPORTS std::string toString(AxisHint h);

/** @brief A set of image segments whose world lines are parallel. */
struct CV_EXPORTS LineGroup {
    std::string name;               //!< name used in messages ("floor_x", …)
    AxisHint axis = AxisHint::ANY;  //!< what the direction is known to be
    std::vector<Vec4d> segments;    //!< (x1, y1, x2, y2) in pixels, pixel centres at integers
};

/** @brief Vanishing point of image segments whose world lines are parallel.

Two segments give their intersection. More give the point minimising the length-weighted sum
of squared algebraic distances to the segments' lines (in normalised coordinates), refined by
minimising the endpoints' distances to the lines joining each segment's midpoint to the
point @cite Kosecka2002.
@param segments (x1, y1, x2, y2) in pixels; at least two, not all on one image line.
@param name names the group in error messages.
@return unit homogeneous pixel coordinates (x, y, w) with w ≥ 0; w ≈ 0 for a point at
infinity (image lines parallel). Throws cv::Exception for fewer than two segments, degenerate
(zero-length) segments or collinear segments. */
CV_EXPORTS Vec3d estimateVanishingPoint(const std::vector<Vec4d>& segments,
                                        const std::string& name = "lines");

/** @brief Focal length (pixels) from the vanishing points of two orthogonal world directions:
`f² = −(v1 − c)·(v2 − c)` @cite Caprile1990.
Throws cv::Exception when a point is at infinity or the points are not consistent with
orthogonal directions (f² ≤ 0). */
CV_EXPORTS double focalFromVanishingPoints(const Vec3d& v1, const Vec3d& v2,
                                           const Point2d& principal_point);

/** @brief Orthocentre of a triangle: the principal point given the finite vanishing points of
three mutually orthogonal directions @cite Caprile1990. Throws for a degenerate triangle. */
CV_EXPORTS Point2d orthocenter(const Point2d& a, const Point2d& b, const Point2d& c);

/** @brief Rotation cam_from_world from two or three orthogonal directions seen by the camera,
following the DESIGN conventions.

The vertical is the direction hinted VERTICAL, else (among the two given and their cross
product) the one closest to the camera's y axis; world z points up in the image. +y is the
horizontal direction closest to the camera's viewing direction (pointing away from the
camera), x = y × z. The result is the nearest rotation to the measured directions.
@param dirs unit directions in camera coordinates (sign arbitrary), 2 or 3, about orthogonal.
@param hints one per direction (or empty: all ANY).
@param axis_of if not null, receives for each input direction its world axis (0 x, 1 y, 2 z). */
CV_EXPORTS Matx33d rotationFromDirections(const std::vector<Vec3d>& dirs,
                                          const std::vector<AxisHint>& hints = {},
                                          std::vector<int>* axis_of = nullptr);

/** @brief Result of a single-frame camera calibration. */
struct CV_EXPORTS FrameCalibration {
    Size image_size;             //!< image size in pixels
    Matx33d K = Matx33d::eye();  //!< intrinsics (square pixels, no skew)
    Matx33d R = Matx33d::eye();  //!< rotation cam_from_world (DESIGN axes)
    /** @brief Vanishing points of world x, y, z: unit homogeneous pixel coordinates `K R e_i`. */
    Vec3d vanishing_points[3];
    int support[3] = {0, 0, 0};  //!< segments supporting each world axis
    /** @brief In [0, 1]: share of the segments' length explained by the three directions,
    reduced when the second-best direction has few segments and (automatic detection) divided
    by `1 + (focal_rel_sigma / 0.04)²` (1 for user-given lines). Automatic detection also
    multiplies it, after the ranking, by the support's spread: the second direction counted in
    distinct lines rather than pieces, and a factor falling when the second and third
    directions' segments lie mostly in one ninth of the image (one object's frame). */
    double confidence = 0;
    double rms_px = 0;  //!< RMS distance of segment endpoints to their VP lines
    /** @brief Relative standard deviation of the focal length (automatic detection: from the
    covariance of the joint refinement; 0 when the focal length is given or not estimated that
    way). Large when the vanishing points constrain the focal length weakly (one of them near
    the image centre, or at infinity). */
    double focal_rel_sigma = 0;
    std::vector<Vec4f> segments;  //!< segments used (detected or given)
    std::vector<int> labels;      //!< world axis of each segment (0, 1, 2) or −1 (outlier)
    /** @brief Radial distortion coefficient (one-parameter model of OpenCV / COLMAP
    SIMPLE_RADIAL: a normalised undistorted point x = K⁻¹ p is seen at x (1 + k1 |x|²)); 0
    unless estimated (VanishingPointCalibrator::Params::estimate_distortion). K, R and the
    vanishing points are those of the undistorted image; `segments` are as detected. */
    double k1 = 0;

    /** @brief The camera (K, R, image size; t = 0 until placed). */
    Camera camera() const;
    /** @brief Focal length in pixels. */
    double focal() const { return K(0, 0); }
};

/** @brief Finds focal length and rotation from vanishing points: from user line groups or
automatically from an image (line segments + RANSAC Manhattan-frame search).

@code
auto cal = cv::vbme::VanishingPointCalibrator::create();
cv::vbme::FrameCalibration fc = cal->detect(image);      // or cal->calibrate(groups, size)
cv::vbme::Camera cam = fc.camera();
cv::vbme::placeCamera(cam, 1.6);                          // 1.6 m above the floor
@endcode
*/
class CV_EXPORTS VanishingPointCalibrator : public Algorithm {
public:
    /** @brief Settings. */
    struct CV_EXPORTS Params {
        Params();          //!< the defaults below
        double focal = 0;  //!< known focal length in pixels (0: estimate it)
        /** @brief Known principal point; negative: the image centre ((w−1)/2, (h−1)/2). */
        Point2d principal_point = Point2d(-1, -1);
        /** @brief With three finite vanishing points, take the principal point as their
        orthocentre (sensitive to noise; off by default). */
        bool principal_point_from_orthocenter = false;
        double min_segment_length = 0;  //!< detection: shortest segment (px); 0: 3 % of diagonal
        int max_segments = 300;         //!< detection: longest segments kept
        double inlier_angle_deg = 1.5;  //!< detection: segment-to-VP angle of an inlier
        int ransac_iterations = 2000;   //!< detection: hypotheses drawn
        double min_focal = 0.3;         //!< plausible focal range, in units of max(width, height)
        double max_focal = 6.0;         //!< plausible focal range, in units of max(width, height)
        int seed = 0;                   //!< detection: random seed (results are deterministic)
        /** @brief detection: results below this confidence are rejected as not a Manhattan
        scene. */
        double min_confidence = 0.25;
        /** @brief detection: the Manhattan-frame search. */
        enum Method {
            /** Exhaustive search over vanishing-point candidates from pairs of the longest
            segments, every pair of candidates giving a frame (focal from orthogonality),
            then a joint robust refinement of focal length and rotation (default). */
            GLOBAL = 0,
            /** RANSAC over random minimal sets of LSD segments: a baseline for GLOBAL (the two
            are compared in doc/vbme_calib.md). */
            RANSAC = 1
        };
        Method method = GLOBAL;  //!< detection: the search (file value "global" / "ransac")
        /** @brief detection: focal length prior in pixels (e.g. from EXIF; 0: none). Unlike
        `focal` it is not imposed: it adds hypotheses and a soft term to the refinement. */
        double focal_prior = 0;
        /** @brief detection: standard deviation of the focal prior, relative (in log f). */
        double focal_prior_sigma = 0.1;
        /** @brief detection: also estimate one radial distortion coefficient k1 from the
        straightness of the lines and their meeting in the vanishing points (GLOBAL only). */
        bool estimate_distortion = false;
        /** @brief detection (GLOBAL): a second opinion from OpenCV's FastLineDetector @cite
        Lee2014 when the first answer is not confident. The search runs on the LSD segments;
        when its first proposal's confidence is below `fld_pass_below_confidence`, it runs
        again on the same segments with the FLD segments of the σ = 2 smoothed image added (FLD
        finds long faint edges LSD misses in noisy images). When the two first frames agree
        (focal within 5 %, directions within 3°), the LSD pass's proposals are returned
        unchanged; when they disagree, the FLD pass's (unless only the LSD frame reaches
        `min_confidence`), with every confidence halved and the other pass's first frame as
        the second proposal. Without OpenCV's ximgproc module it has no effect. */
        bool fld_pass = true;
        /** @brief detection: the FLD pass runs when the LSD pass's first proposal's confidence
        (ManhattanProposal::confidence) is below this (above 1: always). */
        double fld_pass_below_confidence = 0.4;
        /** @brief detection (GLOBAL): also find and score Manhattan frames with every edge
        pixel of the image (the "Manhattan World" edgel likelihood @cite Coughlan1999
        @cite Denis2008), not only with the detected segments: frames from the strongest
        vanishing point alone (the other two directions from the edge pixels, refined by the
        segments with the edgels' focal length as a prior; not with `focal` or `focal_prior`)
        and the hypotheses the edgels score best are refined too; ranking and confidence stay
        those of the segments. On by default since session 10 (the edge pixels also decide
        whether a rival frame makes a proposal `ambiguous`); about 1.5× the CPU time of the
        segments alone (81.7 vs 55.3 ms per render). Not with `estimate_distortion`. Measured
        in doc/vbme_calib.md, "Edge pixels (session 9)" and "Ambiguity and the edge pixels on
        by default (session 10)". */
        bool edgel_scoring = true;
        /** @brief detection (GLOBAL): weight of the segments several LSD passes found in the
        refinement. A segment that m of the three LSD passes (full, half, quarter resolution)
        found gets the weight 1 + a (m − 1), a this value (a segment of FastLineDetector pieces
        alone counts as m = 1), divided by the weights' mean over the image's segments; the
        votes, the search and the inlier angles are unchanged, and the focal length's σ is
        computed from the unweighted residuals. Sharp edges every pass finds are nearly exact,
        soft edges one coarse pass finds alone carry most of the bias (doc/vbme_calib.md, "Which
        segments carry the bias"). 0: every segment alike. 0.5 by default since session 12: on
        two blind sets of renders nobody tuned on it gains AA on each and loses no right
        answer, and on 102 real photographs (York Urban) it changes AA by +0.5 / +0.3 / +0.2
        without a prior and not at all with one (doc/vbme_calib.md, "What the blind sets and
        the photographs decided (session 12)"). */
        double pass_weight = 0.5;
        /** @brief detection (GLOBAL): a prior on how people hold cameras, as a factor on each
        frame's ranking product (`calibration.confidence × (score / best score)⁸`, so on the
        ranking and the confidences' shares). A frame's roll and pitch are those its rotation
        implies (world vertical = the direction nearest the camera's y axis); within |roll| ≤
        15° and |pitch| ≤ 45° (cameras people hold) the factor is 1, beyond it falls as
        exp(−½ (excess / σ)²) per angle, σ this value in degrees. 0: off (every frame alike).
        Not on by default: the wrong answers on the Blender rooms are not tilted
        (doc/vbme_calib.md, "An upright-camera prior"). */
        double upright_prior = 0;

        /** @brief Reads the fields present in @p node (others keep their values); an
        unknown key or a value check() refuses is an error. */
        void read(const FileNode& node);
        /** @brief Writes all fields. */
        void write(FileStorage& fs) const;
        /** @brief Throws a cv::Exception naming the first field outside its valid range. */
        void check() const;
    };

    /** @brief Creates a calibrator. */
    static Ptr<VanishingPointCalibrator> create(const Params& params = Params());

    /** @brief Calibrates from two or three groups of user-given segments.
    Throws cv::Exception naming the group at fault when a group has fewer than two segments,
    collinear segments, when fewer than two directions are given, or when the focal length is
    undetermined (a needed vanishing point at infinity) and not given in Params. */
    virtual FrameCalibration calibrate(const std::vector<LineGroup>& groups,
                                       Size image_size) const = 0;

    /** @brief Finds the vanishing points automatically in an 8-bit image (gray or BGR).
    Throws cv::Exception when no two orthogonal directions with a plausible focal length are
    found. */
    virtual FrameCalibration detect(InputArray image) const = 0;

    /** @brief The line segments detection works on (LSD, filtered and sorted by length;
    with the GLOBAL method collinear pieces are merged first). */
    virtual void detectSegments(InputArray image, std::vector<Vec4f>& segments) const = 0;

    /** @brief Current settings. */
    virtual const Params& params() const = 0;
};

/** @brief One Manhattan frame proposed by automatic detection, with how much to trust it. */
struct CV_EXPORTS ManhattanProposal {
    FrameCalibration calibration;  //!< K, R, vanishing points, segment labels, k1
    /** @brief Robust consensus: length-weighted share of the segments pointing at one of the
    three vanishing points (in [0, 1]). */
    double score = 0;
    /** @brief In [0, 1]: the frame's own quality (calibration.confidence) times its share of
    the frames' `calibration.confidence × (score / best score)⁸`; low when another frame scores
    close. Proposals are ranked by that product (`calibration.confidence × (score / best
    score)⁸`). Halved when the LSD and the LSD + FastLineDetector segment passes give different
    first frames (Params::fld_pass). Then multiplied, as calibration.confidence, by the
    support's spread (ranks nothing). Capped so that no proposal shows more confidence than one
    ranked before it. */
    double confidence = 0;
    /** @brief Set on the first proposal and on every other that rivals it, when there is
    one: two frames are plausible and the user should choose. A rival reaches at least half
    the first's `calibration.confidence × (score / best score)⁸`, labels more than 10 % of the
    segment length the two frames explain differently (frames grouping the segments alike
    differ only by the focal length's own uncertainty, `calibration.focal_rel_sigma`), and,
    with Params::edgel_scoring, has an edgel score (mean log-likelihood ratio per edge pixel)
    no more than 0.05 below the first's. */
    bool ambiguous = false;
    std::string note;  //!< human-readable reason for the confidence ("", or why it is low)
};

/** @brief Ranked Manhattan-frame proposals for the image, best first.

Line segments (LSD @cite vonGioi2012 after a 3×3 median, at three scales, collinear pieces
merged, each line refitted on the full-resolution gradient, short ones dropped) vote for
vanishing-point candidates (intersections of pairs of the longest segments, scored by a
robust truncated-quadratic angular consensus @cite Torr2000); every pair of candidates gives a frame
whose focal length follows from orthogonality with the principal point at the centre @cite
Caprile1990; all pairs are scored, distinct frames are refined jointly (focal, rotation, optionally
k1) with a Cauchy loss (Ceres), their focal length's uncertainty taken from the refinement's
covariance, and ranked by confidence × consensus. When the first proposal's confidence is below
Params::fld_pass_below_confidence, the search runs again with FastLineDetector segments added
@cite Lee2014 and that pass's proposals replace these, at half the confidence, when its first
frame differs (Params::fld_pass). The first proposal is what detect() returns.
@param image 8-bit gray or BGR.
@param params settings (method must be GLOBAL).
@param max_proposals the most proposals returned (≥ 1).
Throws cv::Exception with the reason when no plausible frame is found. */
CV_EXPORTS std::vector<ManhattanProposal> detectManhattanProposals(
    InputArray image, const VanishingPointCalibrator::Params& params = {}, int max_proposals = 3);

/** @brief Removes one-coefficient radial distortion from pixel points (inverse of
`p_d = c + f x (1 + k1 |x|²)`, x = (p − c) / f), by fixed-point iteration. */
CV_EXPORTS Point2d undistortPointK1(const Point2d& p, double f, const Point2d& c, double k1);

/** @brief Applies one-coefficient radial distortion to a pixel point of the undistorted image:
`p_d = c + f x (1 + k1 |x|²)`, x = (p − c) / f (inverse of undistortPointK1). */
CV_EXPORTS Point2d distortPointK1(const Point2d& p, double f, const Point2d& c, double k1);

/** @brief Places a camera whose K and R are known @p height metres above the world origin on
the floor: centre (0, 0, height), t = −R·centre. Throws for a non-positive height. */
CV_EXPORTS void placeCamera(Camera& camera, double height);

/** @brief Clicked image points that locate the room box's faces (DESIGN face names). */
struct CV_EXPORTS RoomAnnotation {
    /** @brief Wall name (left, right, front, back) → points on the line where that wall
    meets the floor. */
    std::map<std::string, std::vector<Point2d>> floor_edges;
    /** @brief Wall name → points on the line where that wall meets the ceiling. */
    std::map<std::string, std::vector<Point2d>> ceiling_edges;
    /** @brief A vertical corner where two walls meet. */
    struct CV_EXPORTS WallCorner {
        std::string wall_a;           //!< one wall (left, right, front, back)
        std::string wall_b;           //!< the other, on the other axis
        std::vector<Point2d> points;  //!< image points anywhere on the corner line
    };
    std::vector<WallCorner> wall_corners;  //!< vertical wall–wall corners
    /** @brief Face name → its coordinate in metres, given by the user (left/right: x,
    front/back: y, ceiling: z); overrides the clicked points. */
    std::map<std::string, double> faces;

    /** @brief Whether nothing is given. */
    bool empty() const {
        return floor_edges.empty() && ceiling_edges.empty() && wall_corners.empty() &&
               faces.empty();
    }
};

/** @brief Fits the room box to the annotation in a placed camera (see placeCamera()).

Floor-edge points are ray-cast onto z = 0 and give the wall's coordinate (their mean); a
wall–wall corner point gives the ratio of the two walls' coordinates, so that one known wall
gives the other; ceiling-edge points are ray-cast onto their (known) wall and give the
ceiling height. Numbers in RoomAnnotation::faces override. Throws cv::Exception naming the
faces that stay undetermined and how to give them, and for points that do not hit the floor
or lie on a wall other than the named one. */
CV_EXPORTS Room fitRoom(const Camera& camera, const RoomAnnotation& annotation);

/** @brief A light source drawn on the image. */
struct CV_EXPORTS LightAnnotation {
    std::vector<Point2d> polygon;     //!< image polygon (≥ 3 points)
    std::string face;                 //!< box face it lies on; empty: the face its centre sees
    bool has_radiance = false;        //!< radiance given by the user
    Vec3d radiance = Vec3d(1, 1, 1);  //!< linear RGB radiance when given
};

/** @brief The box face (DESIGN name) that the ray through pixel @p px leaves the room by
(the camera must be inside the box). */
CV_EXPORTS std::string faceSeenAt(const Camera& camera, const Room& room, const Point2d& px);

/** @brief Ray-casts an image polygon onto a box face and makes it a polygon light.

The corners are clamped to the face rectangle and wound counter-clockwise seen from inside
the room (normal into the room). The radiance is the user's, else the mean linearised colour
(RGB) of @p image inside the polygon, an initial estimate (saturated pixels underestimate).
@param image the frame (8-bit BGR) or empty (radiance 1 unless given).
@param response camera response used to linearise @p image. */
CV_EXPORTS Light projectLight(const Camera& camera, const Room& room, const LightAnnotation& light,
                              InputArray image = noArray(), Response response = Response::SRGB);

/** @brief Mean linear RGB of an 8-bit BGR image inside an image polygon. */
CV_EXPORTS Vec3d meanLinearRGB(InputArray image, const std::vector<Point2d>& polygon,
                               Response response);

/** @brief Everything the user gives about the first frame (see doc/annotation_format.md). */
struct CV_EXPORTS FrameAnnotation {
    Size image_size;               //!< optional: checked against the image when given
    std::vector<LineGroup> lines;  //!< parallel-line groups (two or three directions)
    double focal = 0;              //!< known focal length (px), 0: estimate
    /** @brief Known radial distortion of the lens (Camera::k1, relative to the normalised
    coordinates K⁻¹ p), e.g. from an earlier `--distortion k1`; 0: none. The annotation's points
    and lines are those of the distorted frame, as clicked. Written only when not 0 (files
    without it read as 0). */
    double k1 = 0;
    /** @brief Known principal point (px); negative: the image centre. */
    Point2d principal_point = Point2d(-1, -1);
    /** @brief Principal point as the orthocentre of three vanishing points. */
    bool principal_point_from_orthocenter = false;
    double camera_height = 0;   //!< camera height above the floor (m), 0: unknown
    double room_height = 0;     //!< floor-to-ceiling height (m) when the camera's is unknown
    bool has_response = false;  //!< whether `response` was given
    Response response = Response::SRGB;   //!< camera response of the footage
    RoomAnnotation room;                  //!< box faces
    std::vector<LightAnnotation> lights;  //!< light polygons

    /** @brief Reads an annotation file (YAML or JSON); throws naming the file and field. */
    static FrameAnnotation read(const std::string& path);
    /** @brief Reads from a FileStorage root node; @p source names it in messages. */
    void read(const FileNode& root, const std::string& source);
    /** @brief Writes the annotation as top-level fields of @p fs. */
    void write(FileStorage& fs) const;
    /** @brief Writes an annotation file (under a temporary name renamed when complete). */
    void write(const std::string& path) const;
};

/** @brief Options of calibrateFrame(). */
struct CV_EXPORTS FrameCalibrationOptions {
    bool auto_detect = false;  //!< find the vanishing points when the annotation has no lines
    double camera_height = 0;  //!< overrides the annotation's camera height when > 0
    /** @brief Height used when neither the camera's nor the room's is known and no room is
    annotated (a warning is printed). */
    double default_camera_height = 1.6;
    VanishingPointCalibrator::Params vp;  //!< vanishing-point settings

    /** @brief Reads the fields present in the map @p fn (others keep their value); an unknown
    key or a value check() refuses is an error. */
    void read(const FileNode& fn);
    /** @brief Writes every field as `name: value` into the open map of @p fs. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief Calibrates line groups clicked in a frame whose lens has a known radial distortion
@p k1 (FrameAnnotation::k1): the segments are undistorted (Camera::undistortPixel) before the
vanishing points are fitted. k1 is relative to `K⁻¹ p`, so the undistortion depends on the focal
length being sought: the focal is the one whose undistorted segments meet their vanishing
points best (smallest `rms_px`; a log grid of 25 focals from f0/2.8 to 1.4 f0 around the
distorted frame's focal f0, then a golden-section search to 1e-4 f0). The principal point is
the distorted frame's calibration's. calibrateFrame() and the annotator's live calibration
(`vbme annotate`, api/calibrate) both use it.
@param calibrator its Params apply to every fit (given focal, principal point, ...).
@param groups the clicked segments, in pixels of the distorted (clicked) frame.
@param image_size the frame's size.
@param k1 the lens's coefficient; 0 gives `calibrator.calibrate(groups, image_size)`.
@param undistorted if not null, receives @p groups undistorted at the focal found: the
segments (pixels of the undistorted frame) that the result's vanishing points and `rms_px`
refer to.
@return the calibration of the undistorted (pinhole) frame — K, R, vanishing points and
`rms_px` there — with `k1` set; `segments` and `labels` are those of the undistorted groups.
Throws cv::Exception when the groups do not calibrate at any focal searched. */
CV_EXPORTS FrameCalibration calibrateLinesWithK1(const VanishingPointCalibrator& calibrator,
                                                 const std::vector<LineGroup>& groups,
                                                 Size image_size, double k1,
                                                 std::vector<LineGroup>* undistorted = nullptr);

/** @brief Annotation (and/or automatic detection) → scene: camera, room, lights.

User lines override automatic detection. With the camera height (or, failing it, the room
height plus ceiling-edge points) the camera is placed above the world origin and the room
box fitted; the lights are projected onto the box.
@param image the frame (8-bit BGR).
@param annotation the user's annotation (may be empty with options.auto_detect).
@param options settings.
@param calibration if not null, receives the vanishing-point result (for overlays). */
CV_EXPORTS Scene calibrateFrame(InputArray image, const FrameAnnotation& annotation,
                                const FrameCalibrationOptions& options,
                                FrameCalibration* calibration = nullptr);

/** @brief Draws the calibration over the frame for checking at a glance: segments coloured
by world axis (x red, y green, z blue), vanishing points and horizon, the room box wireframe,
the light polygons and a caption with the focal length. With a radial distortion coefficient
(`fc.k1` ≠ 0, from `estimate_distortion`) the box, the horizon and the light polygons are
drawn as that lens shows them (distortPointK1), so they line up with the distorted frame; the
segments are drawn as detected.
@param image 8-bit BGR frame.
@param overlay output, 8-bit BGR of the same size. */
CV_EXPORTS void drawCalibrationOverlay(InputArray image, OutputArray overlay, const Scene& scene,
                                       const FrameCalibration& calibration);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
