// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/core/camera_path.hpp"

#include "opencv2/vbme/core/fileio.hpp"
#include "opencv2/vbme/core/scene.hpp"

namespace cv {
namespace vbme {

std::string CameraPath::sourceName(Source s) {
    switch (s) {
        case SFM:
            return "sfm";
        case PNP:
            return "pnp";
        case INTERPOLATED:
            return "interpolated";
    }
    return "sfm";
}

CameraPath::Source CameraPath::parseSource(const std::string& s, const std::string& field) {
    if (s == "sfm") return SFM;
    if (s == "pnp") return PNP;
    if (s == "interpolated") return INTERPOLATED;
    CV_Error(Error::StsBadArg,
             field + ": unknown source '" + s + "' (expected sfm, pnp or interpolated)");
}

Camera CameraPath::camera(size_t i) const {
    CV_Assert(i < frames.size());
    Camera c;
    c.K = K;
    c.k1 = k1;
    c.R = frames[i].R;
    c.t = frames[i].t;
    c.image_size = image_size;
    return c;
}

CameraPath CameraPath::read(const std::string& path) {
    FileStorage fs = openForReading(path, "camera-path file");
    CameraPath p;
    try {
        p.K = Matx33d(readMatrix(fs["K"], 3, 3, "K"));
        if (!fs["k1"].empty()) {
            if (!fs["k1"].isReal() && !fs["k1"].isInt())
                CV_Error(Error::StsParseError, "k1: expected a number");
            p.k1 = (double)fs["k1"];
            if (!(std::abs(p.k1) < 10))
                CV_Error(Error::StsBadArg, format("k1: %g is not a plausible radial distortion "
                                                  "coefficient (expected |k1| < 10)",
                                                  p.k1));
        }
        if (!fs["image_size"].empty()) {
            p.image_size = readImageSize(fs["image_size"], "image_size");
        }
        const FileNode frames = fs["frames"];
        if (!frames.isSeq()) CV_Error(Error::StsParseError, "frames: expected a sequence");
        int i = 0;
        for (FileNodeIterator it = frames.begin(); it != frames.end(); ++it, ++i) {
            const std::string f = "frames[" + std::to_string(i) + "]";
            const FileNode n = *it;
            Frame fr;
            if (!n.isMap()) CV_Error(Error::StsParseError, f + ": expected a map {index, R, t}");
            const FileNode idx = n["index"];
            if (!idx.empty() && !idx.isInt())
                CV_Error(Error::StsParseError, f + ".index: expected an integer");
            fr.index = idx.empty() ? i : (int)idx;
            if (fr.index != i)
                CV_Error(Error::StsParseError,
                         format("%s.index: is %d, expected %d (one entry per frame, in order)",
                                f.c_str(), fr.index, i));
            fr.R = Matx33d(readMatrix(n["R"], 3, 3, f + ".R"));
            fr.t = Vec3d(readMatrix(n["t"], 3, 1, f + ".t"));
            if (!n["source"].empty())
                fr.source = parseSource(n["source"].isString() ? (std::string)n["source"] : "",
                                        f + ".source");
            if (std::abs(determinant(Mat(fr.R)) - 1.0) > 1e-3)
                CV_Error(Error::StsBadArg, f + ".R: not a rotation");
            p.frames.push_back(fr);
        }
    } catch (const cv::Exception& e) {
        CV_Error(e.code, path + ": " + e.err);
    }
    return p;
}

void CameraPath::write(const std::string& path) const {
    AtomicFile out(path);
    {
        FileStorage fs = openForWriting(out);
        fs << "K" << Mat(K);
        if (k1 != 0) fs << "k1" << k1;
        if (image_size.area() > 0)
            fs << "image_size"
               << "[:" << image_size.width << image_size.height << "]";
        fs << "frames"
           << "[";
        for (const auto& f : frames) {
            fs << "{"
               << "index" << f.index << "R" << Mat(f.R) << "t" << Mat(f.t) << "source"
               << sourceName(f.source) << "}";
        }
        fs << "]";
    }
    out.commit();
}

}  // namespace vbme
}  // namespace cv
