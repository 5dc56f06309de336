// This file is part of vbme, licensed under the Apache License 2.0 (see
// LICENSE).
#ifndef OPENCV_VBME_CALIB_COLMAP_HPP
#define OPENCV_VBME_CALIB_COLMAP_HPP

#include <map>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_calib
//! @{

/** @name COLMAP text models and the colmap program
COLMAP is used as a program (Debian's `colmap`), through its text model files
(`cameras.txt`, `images.txt`, `points3D.txt`). COLMAP puts pixel centres at
+0.5: the readers and writers here keep COLMAP's numbers as they are in the
files; convert principal points and keypoints at the boundary
(cv::vbme::Camera::fromColmapPrincipalPoint).
@{ */

/** @brief A camera of cameras.txt. */
struct CV_EXPORTS ColmapCamera {
    int id = 1;                     //!< CAMERA_ID
    std::string model = "PINHOLE";  //!< MODEL (PINHOLE: fx, fy, cx, cy)
    Size size;                      //!< WIDTH, HEIGHT
    std::vector<double> params;     //!< PARAMS[] in COLMAP's convention
};

/** @brief An image of images.txt: its pose (cam_from_world of the model) and
 * its keypoints. */
struct CV_EXPORTS ColmapImage {
    int id = 0;                          //!< IMAGE_ID
    Matx33d R = Matx33d::eye();          //!< rotation from QW QX QY QZ
    Vec3d t = Vec3d(0, 0, 0);            //!< TX TY TZ
    int camera_id = 1;                   //!< CAMERA_ID
    std::string name;                    //!< NAME
    std::vector<Point2d> xys;            //!< keypoints (COLMAP pixel convention)
    std::vector<long long> point3d_ids;  //!< POINT3D_ID per keypoint, −1 if none
};

/** @brief A point of points3D.txt. */
struct CV_EXPORTS ColmapPoint {
    long long id = 0;                        //!< POINT3D_ID
    Vec3d xyz;                               //!< position in the model frame
    Vec3b rgb;                               //!< colour (R, G, B)
    double error = 0;                        //!< mean reprojection error (pixels)
    std::vector<std::pair<int, int>> track;  //!< (IMAGE_ID, POINT2D_IDX)
};

/** @brief A COLMAP sparse model. */
struct CV_EXPORTS ColmapModel {
    std::map<int, ColmapCamera> cameras;      //!< by CAMERA_ID
    std::map<int, ColmapImage> images;        //!< by IMAGE_ID
    std::map<long long, ColmapPoint> points;  //!< by POINT3D_ID

    /** @brief Reads cameras.txt, images.txt and points3D.txt from @p dir. Throws
    cv::Exception naming the file and line at fault. */
    static ColmapModel readText(const std::string& dir);
    /** @brief Reads every model under @p root (one subdirectory each, as COLMAP's mapper and
    model_converter leave them: `0/`, `1/`, ...), largest first (most registered images; ties
    in the subdirectories' name order), so that a run and a later rerun that reads the same
    files back pick the same model whatever order the file system lists them in. Empty when
    @p root does not exist or holds no subdirectory. */
    static std::vector<ColmapModel> readTextModels(const std::string& root);
    /** @brief Writes the three text files into @p dir (created), each atomically.
     */
    void writeText(const std::string& dir) const;
    /** @brief The image called @p name, or nullptr. */
    const ColmapImage* imageByName(const std::string& name) const;
};

/** @brief Rotation matrix of a unit quaternion (w, x, y, z), COLMAP's order. */
CV_EXPORTS Matx33d rotationFromQuaternion(const Vec4d& wxyz);
/** @brief Unit quaternion (w, x, y, z) with w ≥ 0 of a rotation matrix. */
CV_EXPORTS Vec4d quaternionFromRotation(const Matx33d& R);

/** @brief How the colmap program is run. */
struct CV_EXPORTS ColmapOptions {
    std::string executable = "colmap";  //!< the program (a name on PATH or a path)
    int threads = 2;                    //!< threads of feature extraction and matching
    int mapper_threads = 1;             //!< threads of the mapper (1: runs repeat exactly)
    int random_seed = 0;                //!< COLMAP's --random_seed
    int overlap = 10;                   //!< sequential matcher: neighbours matched per frame
    std::string vocab_tree;             //!< vocabulary-tree file: enables loop detection when set
    int max_num_features = 4096;        //!< SIFT features per image
    int timeout = 0;          //!< seconds a step may run before it is stopped as hung (0: no limit)
    int min_model_size = 10;  //!< mapper: smaller models are discarded
    int abs_pose_min_num_inliers = 30;  //!< mapper: 2D-3D inliers needed to register an image
    /** A COLMAP database of the same images from an earlier run (its features and matches):
    runColmapSfM() maps a copy of it instead of extracting and matching. COLMAP's matching is not
    repeatable from run to run, its mapper is for a given database and seed, so this replays a
    run's model exactly (benchmarks, diagnosis). Empty (the default): extract and match. */
    std::string database;

    /** @brief Reads the fields present in the map @p fn (others keep their value); an unknown
    key or a value check() refuses is an error. */
    void read(const FileNode& fn);
    /** @brief Writes every field as `name: value` into the open map of @p fs. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief Runs COLMAP's sparse reconstruction on the images of @p image_dir
with fixed, known intrinsics: feature_extractor (one shared PINHOLE camera, CPU
SIFT), sequential_matcher (the images' names must sort in time), mapper
(intrinsics held fixed), model_converter to text. Everything goes to @p work_dir
(database, models, `colmap.log`).
@param K intrinsics in the vbme convention (converted to COLMAP's +0.5 here).
@param size image size.
@param step_seconds if given, receives the wall time of each COLMAP step (name, seconds).
@param step_cpu_seconds if given, receives the CPU time (user + system) of each COLMAP step's
process (name, seconds).
@return the reconstructed models, largest first (several when COLMAP splits the
video). Throws cv::Exception in plain words when the program is missing or a
step fails (naming the log). */
CV_EXPORTS std::vector<ColmapModel> runColmapSfM(
    const std::string& image_dir, const std::string& work_dir, const Matx33d& K, Size size,
    const ColmapOptions& options = ColmapOptions(),
    std::vector<std::pair<std::string, double>>* step_seconds = nullptr,
    std::vector<std::pair<std::string, double>>* step_cpu_seconds = nullptr);

/** @brief Runs COLMAP's mapper again on the features and matches a runColmapSfM() call left in
@p work_dir (its database), e.g. with another options.random_seed (the mapper's choice of initial
pair and its RANSAC draws), into `work_dir/<output_name>` and, as text,
`work_dir/<output_name>_txt`; the models of runColmapSfM() stay untouched. Costs the mapper's
time only (no feature extraction or matching).
@return the models, largest first. Throws cv::Exception when the database is missing or the
mapper fails. */
CV_EXPORTS std::vector<ColmapModel> rerunColmapMapper(
    const std::string& image_dir, const std::string& work_dir, const std::string& output_name,
    const ColmapOptions& options = ColmapOptions(),
    std::vector<std::pair<std::string, double>>* step_seconds = nullptr,
    std::vector<std::pair<std::string, double>>* step_cpu_seconds = nullptr);

/** @} */

//! @}

}  // namespace vbme
}  // namespace cv

#endif
