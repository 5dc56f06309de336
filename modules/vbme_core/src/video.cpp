// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/core/video.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "opencv2/vbme/core/fileio.hpp"

namespace fs = std::filesystem;

namespace cv {
namespace vbme {

static std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

static bool isImageExtension(const std::string& ext) {
    static const char* exts[] = {".png", ".jpg", ".jpeg", ".tif", ".tiff",
                                 ".bmp", ".exr", ".ppm",  ".pgm", ".webp"};
    const std::string e = lower(ext);
    for (const char* x : exts)
        if (e == x) return true;
    return false;
}

// The last run of digits in a file's stem, or -1.
static long long frameNumber(const std::string& stem) {
    int end = (int)stem.size() - 1;
    while (end >= 0 && !std::isdigit((unsigned char)stem[end]))
        --end;
    if (end < 0) return -1;
    int begin = end;
    while (begin > 0 && std::isdigit((unsigned char)stem[begin - 1]))
        --begin;
    return std::stoll(stem.substr(begin, std::min(18, end - begin + 1)));
}

static Mat toBgr8(const Mat& m, const std::string& name) {
    Mat out = m;
    if (out.depth() != CV_8U) {
        if (out.depth() == CV_16U)
            out.convertTo(out, CV_8U, 1.0 / 257.0);
        else
            CV_Error(Error::StsBadArg, "'" + name + "': only 8- and 16-bit frames are supported");
    }
    if (out.channels() == 1)
        cvtColor(out, out, COLOR_GRAY2BGR);
    else if (out.channels() == 4)
        cvtColor(out, out, COLOR_BGRA2BGR);
    return out;
}

struct VideoReader::Impl {
    std::string source;
    VideoCapture cap;
    std::vector<std::string> files;  // image sequence
    Mat pending;                     // first frame, read at opening
    bool has_pending = false;
    double fps = 30;
    Size size;
    int count = -1;
    int pos = 0;
    int rotate_code = -1;  // cv::RotateFlags applied to every decoded frame, or -1
};

// Counter-clockwise display rotation (0, 90, 180, 270) of the first video stream, from its
// display matrix as ffprobe reports it (the angle players rotate by). False if ffprobe is
// not available or says nothing.
static bool probeDisplayRotation(const std::string& path, int& ccw) {
    std::string quoted = "'";
    for (char c : path)
        quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
    quoted += "'";
    const std::string cmd =
        "ffprobe -v error -select_streams v:0 -show_entries "
        "stream_side_data=rotation -of default=nw=1:nk=1 " +
        quoted + " 2>/dev/null";
    FILE* p = ::popen(cmd.c_str(), "r");
    if (!p) return false;
    char buf[256];
    std::string out;
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, p)) > 0)
        out.append(buf, n);
    const int status = ::pclose(p);
    if (status != 0) return false;
    ccw = 0;
    double angle = 0;
    if (std::sscanf(out.c_str(), "%lf", &angle) == 1) {
        int a = ((int)std::lround(angle / 90.0) * 90) % 360;
        ccw = a < 0 ? a + 360 : a;
    }
    return true;
}

VideoReader::VideoReader(const std::string& source) : impl_(new Impl) {
    Impl& m = *impl_;
    m.source = source;
    std::error_code ec;
    const bool pattern = source.find('%') != std::string::npos;
    if (!pattern && !fs::exists(source, ec))
        CV_Error(Error::StsError, "video '" + source + "' does not exist");

    if (!pattern && fs::is_directory(source, ec)) {
        std::vector<std::pair<long long, std::string>> items;
        for (const auto& e : fs::directory_iterator(source, ec)) {
            if (!e.is_regular_file() || !isImageExtension(e.path().extension().string())) continue;
            if (e.path().filename().string().find(".partial-") != std::string::npos) continue;
            items.emplace_back(frameNumber(e.path().stem().string()), e.path().string());
        }
        if (items.empty())
            CV_Error(Error::StsError, "folder '" + source + "' holds no images (png, jpg, tif, …)");
        std::sort(items.begin(), items.end());
        for (auto& it : items)
            m.files.push_back(it.second);
        std::ifstream fpsf((fs::path(source) / "fps.txt").string());
        double f = 0;
        if (fpsf >> f && f > 0) m.fps = f;
    } else if (pattern) {
        for (int i = 0;; ++i) {
            std::string name = format(source.c_str(), i);
            if (!fs::exists(name, ec)) {
                if (i == 0) {  // allow sequences starting at 1
                    name = format(source.c_str(), 1);
                    if (!fs::exists(name, ec)) break;
                    ++i;
                } else {
                    break;
                }
            }
            m.files.push_back(name);
        }
        if (m.files.empty())
            CV_Error(Error::StsError, "no image matches the pattern '" + source + "'");
    }

    if (!m.files.empty()) {
        m.count = (int)m.files.size();
        Mat first = imread(m.files[0], IMREAD_UNCHANGED);
        if (first.empty())
            CV_Error(Error::StsError, "'" + m.files[0] + "' is not a readable image");
        m.pending = toBgr8(first, m.files[0]);
        m.has_pending = true;
        m.size = m.pending.size();
        return;
    }

    // A video file through FFmpeg. OpenCV 4.6 reads only the legacy "rotate" tag, which
    // FFmpeg 5 no longer exports, so the display matrix is asked of ffprobe and the rotation
    // applied here; OpenCV's own auto-rotation is the fallback when ffprobe is missing.
    if (!m.cap.open(source, CAP_FFMPEG) && !m.cap.open(source, CAP_ANY))
        CV_Error(Error::StsError,
                 "'" + source + "' is not a readable video (no decoder opened it)");
    int ccw = 0;
    if (probeDisplayRotation(source, ccw)) {
        m.cap.set(CAP_PROP_ORIENTATION_AUTO, 0);
        m.rotate_code = ccw == 90    ? ROTATE_90_COUNTERCLOCKWISE
                        : ccw == 180 ? ROTATE_180
                        : ccw == 270 ? ROTATE_90_CLOCKWISE
                                     : -1;
    } else {
        m.cap.set(CAP_PROP_ORIENTATION_AUTO, 1);
    }
    m.fps = m.cap.get(CAP_PROP_FPS);
    if (!(m.fps > 0 && m.fps < 1000)) m.fps = 30;
    const double n = m.cap.get(CAP_PROP_FRAME_COUNT);
    m.count = n > 0 ? (int)n : -1;
    Mat first;
    if (!m.cap.read(first) || first.empty())
        CV_Error(Error::StsError, "'" + source + "' holds no decodable frame");
    m.pending = toBgr8(first, source);
    if (m.rotate_code >= 0) rotate(m.pending, m.pending, m.rotate_code);
    m.has_pending = true;
    m.size = m.pending.size();
}

VideoReader::~VideoReader() = default;

bool VideoReader::read(OutputArray frame) {
    Impl& m = *impl_;
    if (m.has_pending) {
        m.has_pending = false;
        m.pending.copyTo(frame);
        m.pending.release();
        ++m.pos;
        return true;
    }
    Mat f;
    if (!m.files.empty()) {
        if (m.pos >= (int)m.files.size()) return false;
        const std::string& name = m.files[m.pos];
        f = imread(name, IMREAD_UNCHANGED);
        if (f.empty()) CV_Error(Error::StsError, "'" + name + "' is not a readable image");
        f = toBgr8(f, name);
        if (f.size() != m.size)
            CV_Error(Error::StsError,
                     format("'%s' is %dx%d, but the sequence is %dx%d", name.c_str(), f.cols,
                            f.rows, m.size.width, m.size.height));
    } else {
        if (!m.cap.read(f) || f.empty()) return false;
        f = toBgr8(f, m.source);
        if (m.rotate_code >= 0) rotate(f, f, m.rotate_code);
    }
    ++m.pos;
    f.copyTo(frame);
    return true;
}

double VideoReader::fps() const {
    return impl_->fps;
}
Size VideoReader::frameSize() const {
    return impl_->size;
}
int VideoReader::frameCount() const {
    return impl_->count;
}
int VideoReader::position() const {
    return impl_->pos;
}
bool VideoReader::isImageSequence() const {
    return !impl_->files.empty();
}

// ---------------------------------------------------------------- VideoSink

struct VideoSink::Impl {
    std::string path;
    bool sequence = false;
    std::unique_ptr<AtomicFile> file;
    VideoWriter writer;
    Size size;
    bool color = true;
    int count = 0;
    bool closed = false;
};

VideoSink::VideoSink(const std::string& path, double fps, Size size, bool color) : impl_(new Impl) {
    Impl& m = *impl_;
    m.path = path;
    m.size = size;
    m.color = color;
    CV_Assert(size.width > 0 && size.height > 0);
    if (!(fps > 0)) CV_Error(Error::StsBadArg, "frame rate must be positive");
    if (path.find('%') != std::string::npos) {
        m.sequence = true;
        fs::path folder = fs::path(path).parent_path();
        std::error_code ec;
        if (!folder.empty()) fs::create_directories(folder, ec);
        if (!folder.empty()) {
            std::ofstream f((folder / "fps.txt").string());
            f << fps << "\n";
        }
        return;
    }
    const std::string ext = lower(fs::path(path).extension().string());
    std::vector<int> fourccs;
    if (ext == ".mp4" || ext == ".mov" || ext == ".m4v")
        fourccs = {VideoWriter::fourcc('a', 'v', 'c', '1'),
                   VideoWriter::fourcc('m', 'p', '4', 'v')};
    else if (ext == ".mkv" || ext == ".avi")
        fourccs = {VideoWriter::fourcc('F', 'F', 'V', '1')};
    else
        CV_Error(Error::StsBadArg, "'" + path +
                                       "': unsupported output (use .mp4, .mkv, .avi, or an image "
                                       "pattern such as frames/%05d.png)");
    m.file.reset(new AtomicFile(path));
    for (int cc : fourccs) {
        if (m.writer.open(m.file->tempPath(), CAP_FFMPEG, cc, fps, size, color)) break;
    }
    if (!m.writer.isOpened())
        CV_Error(Error::StsError, "cannot open a video encoder for '" + path + "'");
}

VideoSink::~VideoSink() {
    // Without close() the partial file is removed by AtomicFile's destructor.
    if (impl_->writer.isOpened()) impl_->writer.release();
}

void VideoSink::write(InputArray _frame) {
    Impl& m = *impl_;
    CV_Assert(!m.closed);
    Mat frame = _frame.getMat();
    if (frame.size() != m.size || frame.type() != (m.color ? CV_8UC3 : CV_8UC1))
        CV_Error(Error::StsBadArg, format("frame %d has size %dx%d type %d, expected %dx%d %s",
                                          m.count, frame.cols, frame.rows, frame.type(),
                                          m.size.width, m.size.height, m.color ? "8UC3" : "8UC1"));
    if (m.sequence)
        imwriteAtomic(format(m.path.c_str(), m.count), frame);
    else
        m.writer.write(frame);
    ++m.count;
}

void VideoSink::close() {
    Impl& m = *impl_;
    if (m.closed) return;
    m.closed = true;
    if (m.sequence) return;
    m.writer.release();
    m.file->commit();
}

int VideoSink::count() const {
    return impl_->count;
}

}  // namespace vbme
}  // namespace cv
