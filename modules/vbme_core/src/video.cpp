// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Video IO on FFmpeg's libraries (libavformat, libavcodec, libswscale, libavutil): reading with
// rotation, timestamps, colour description, bit depth and HDR conversion; writing with a chosen
// codec and quality, timestamps, colour tags and the input's audio. Image sequences through
// OpenCV's imgcodecs.
#include "opencv2/vbme/core/video.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/core/fileio.hpp"
#include "opencv2/vbme/core/progress.hpp"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/audio_fifo.h>
#include <libavutil/display.h>
#include <libavutil/imgutils.h>
#include <libavutil/opt.h>
#include <libavutil/pixdesc.h>
#include <libswresample/swresample.h>
#include <libswscale/swscale.h>
}

namespace fs = std::filesystem;

namespace cv {
namespace vbme {

namespace {

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

bool isImageExtension(const std::string& ext) {
    static const char* exts[] = {".png", ".jpg", ".jpeg", ".tif", ".tiff",
                                 ".bmp", ".exr", ".ppm",  ".pgm", ".webp"};
    const std::string e = lower(ext);
    for (const char* x : exts)
        if (e == x) return true;
    return false;
}

// The last run of digits in a file's stem, or -1.
long long frameNumber(const std::string& stem) {
    int end = (int)stem.size() - 1;
    while (end >= 0 && !std::isdigit((unsigned char)stem[end]))
        --end;
    if (end < 0) return -1;
    int begin = end;
    while (begin > 0 && std::isdigit((unsigned char)stem[begin - 1]))
        --begin;
    return std::stoll(stem.substr(begin, std::min(18, end - begin + 1)));
}

// An image as BGR of the wanted depth (CV_8U or CV_16U).
Mat toBgr(const Mat& m, const std::string& name, int depth) {
    Mat out = m;
    if (out.depth() == CV_32F) {
        CV_Error(Error::StsBadArg, "'" + name + "': only 8- and 16-bit frames are supported");
    } else if (out.depth() != depth) {
        if (out.depth() == CV_16U && depth == CV_8U)
            out.convertTo(out, CV_8U, 1.0 / 257.0);
        else if (out.depth() == CV_8U && depth == CV_16U)
            out.convertTo(out, CV_16U, 257.0);
        else
            CV_Error(Error::StsBadArg, "'" + name + "': only 8- and 16-bit frames are supported");
    }
    if (out.channels() == 1)
        cvtColor(out, out, COLOR_GRAY2BGR);
    else if (out.channels() == 4)
        cvtColor(out, out, COLOR_BGRA2BGR);
    return out;
}

std::string avError(int code) {
    char buf[AV_ERROR_MAX_STRING_SIZE] = {0};
    av_strerror(code, buf, sizeof buf);
    return buf;
}

struct FormatInputDeleter {
    void operator()(AVFormatContext* c) const { avformat_close_input(&c); }
};
struct CodecDeleter {
    void operator()(AVCodecContext* c) const { avcodec_free_context(&c); }
};
struct FrameDeleter {
    void operator()(AVFrame* f) const { av_frame_free(&f); }
};
struct PacketDeleter {
    void operator()(AVPacket* p) const { av_packet_free(&p); }
};
struct SwsDeleter {
    void operator()(SwsContext* c) const { sws_freeContext(c); }
};
struct SwrDeleter {
    void operator()(SwrContext* c) const { swr_free(&c); }
};
struct FifoDeleter {
    void operator()(AVAudioFifo* f) const { av_audio_fifo_free(f); }
};
using InputPtr = std::unique_ptr<AVFormatContext, FormatInputDeleter>;
using CodecPtr = std::unique_ptr<AVCodecContext, CodecDeleter>;
using FramePtr = std::unique_ptr<AVFrame, FrameDeleter>;
using PacketPtr = std::unique_ptr<AVPacket, PacketDeleter>;
using SwsPtr = std::unique_ptr<SwsContext, SwsDeleter>;
using SwrPtr = std::unique_ptr<SwrContext, SwrDeleter>;
using FifoPtr = std::unique_ptr<AVAudioFifo, FifoDeleter>;

// FFmpeg's own messages (per-macroblock decoding errors, encoder statistics) are silenced:
// what matters is reported by vbme in words (VideoReader::notes()). VBME_AV_LOG=1 shows them.
void quietLibav() {
    static const char* e = std::getenv("VBME_AV_LOG");
    av_log_set_level(e && *e == '1' ? AV_LOG_INFO : AV_LOG_FATAL);
}

InputPtr openInput(const std::string& path) {
    quietLibav();
    AVFormatContext* raw = nullptr;
    const int r = avformat_open_input(&raw, path.c_str(), nullptr, nullptr);
    if (r < 0)
        CV_Error(Error::StsError, "'" + path + "' is not a readable video (" + avError(r) + ")");
    InputPtr in(raw);
    const int s = avformat_find_stream_info(in.get(), nullptr);
    if (s < 0)
        CV_Error(
            Error::StsError,
            "'" + path + "' is not a readable video (no stream information: " + avError(s) + ")");
    return in;
}

// swscale's coefficient table for an H.273 matrix code; unspecified follows the usual player
// convention (BT.709 from 720 lines up, else BT.601).
int swsColorspace(int matrix, int height) {
    switch (matrix) {
        case AVCOL_SPC_BT709:
            return SWS_CS_ITU709;
        case AVCOL_SPC_BT2020_NCL:
        case AVCOL_SPC_BT2020_CL:
            return SWS_CS_BT2020;
        case AVCOL_SPC_FCC:
            return SWS_CS_FCC;
        case AVCOL_SPC_SMPTE240M:
            return SWS_CS_SMPTE240M;
        case AVCOL_SPC_BT470BG:
        case AVCOL_SPC_SMPTE170M:
            return SWS_CS_ITU601;
        default:
            return height >= 720 ? SWS_CS_ITU709 : SWS_CS_ITU601;
    }
}

bool isFullRangeFormat(AVPixelFormat f) {
    return f == AV_PIX_FMT_YUVJ420P || f == AV_PIX_FMT_YUVJ422P || f == AV_PIX_FMT_YUVJ444P ||
           f == AV_PIX_FMT_YUVJ440P || f == AV_PIX_FMT_YUVJ411P;
}

bool isRgbFormat(AVPixelFormat f) {
    const AVPixFmtDescriptor* d = av_pix_fmt_desc_get(f);
    return d && (d->flags & AV_PIX_FMT_FLAG_RGB);
}

// ---- HDR transfer functions (ITU-R BT.2100)

double pqEotf(double e) {  // non-linear [0,1] -> cd/m^2
    const double m1 = 2610.0 / 16384, m2 = 2523.0 / 4096 * 128, c1 = 3424.0 / 4096,
                 c2 = 2413.0 / 4096 * 32, c3 = 2392.0 / 4096 * 32;
    const double p = std::pow(std::max(e, 0.0), 1.0 / m2);
    return 10000.0 * std::pow(std::max(p - c1, 0.0) / (c2 - c3 * p), 1.0 / m1);
}

double hlgInverseOetf(double e) {  // non-linear [0,1] -> scene-linear [0,1]
    const double a = 0.17883277, b = 1 - 4 * a, c = 0.5 - a * std::log(4 * a);
    e = std::max(e, 0.0);
    return e <= 0.5 ? e * e / 3.0 : (std::exp((e - c) / a) + b) / 12.0;
}

// HDR reference white (ITU-R BT.2408): 203 cd/m^2 for PQ; 75 % HLG signal for HLG.
const double kPqReferenceWhite = 203.0;
double hlgReferenceWhite() {
    static const double w = hlgInverseOetf(0.75);
    return w;
}

double srgbEncode(double x) {
    x = std::min(std::max(x, 0.0), 1.0);
    return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1 / 2.4) - 0.055;
}

double srgbDecode(double v) {
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

// BT.2020 → BT.709 linear RGB (ITU-R BT.2087, from the two sets of primaries, D65).
const float kM2020to709[3][3] = {{1.660491f, -0.587641f, -0.072850f},
                                 {-0.124550f, 1.132900f, -0.008349f},
                                 {-0.018151f, -0.100579f, 1.118730f}};

// The per-stream HDR → SDR converter: a linearising table for 16-bit codes, then the gamut
// matrix, the knee and the sRGB curve (a table over 16-bit linear values).
struct HdrConverter {
    int transfer = 0;
    std::vector<float> lin;        // 65536 entries: code -> linear relative to reference white
    std::vector<uint16_t> encode;  // 65537 entries: linear [0,1] * 65536 -> sRGB 16-bit
    void init(int t) {
        transfer = t;
        lin.resize(65536);
        for (int i = 0; i < 65536; ++i) {
            const double e = i / 65535.0;
            lin[i] = (float)(t == AVCOL_TRC_SMPTE2084 ? pqEotf(e) / kPqReferenceWhite
                                                      : hlgInverseOetf(e) / hlgReferenceWhite());
        }
        encode.resize(65537);
        for (int i = 0; i <= 65536; ++i)
            encode[i] = (uint16_t)std::lround(srgbEncode(i / 65536.0) * 65535.0);
    }
    // src: BGR 16-bit holding non-linear BT.2020 R'G'B'; dst: BGR of @p depth.
    void convert(const Mat& src, Mat& dst, int depth) const {
        dst.create(src.size(), CV_MAKETYPE(depth, 3));
        parallel_for_(Range(0, src.rows), [&](const Range& r) {
            for (int y = r.start; y < r.end; ++y) {
                const uint16_t* s = src.ptr<uint16_t>(y);
                uint8_t* d8 = depth == CV_8U ? dst.ptr<uint8_t>(y) : nullptr;
                uint16_t* d16 = depth == CV_16U ? dst.ptr<uint16_t>(y) : nullptr;
                for (int x = 0; x < src.cols; ++x) {
                    const float in[3] = {lin[s[3 * x + 2]], lin[s[3 * x + 1]], lin[s[3 * x]]};
                    float o[3];
                    for (int k = 0; k < 3; ++k)
                        o[k] = std::max(0.f, kM2020to709[k][0] * in[0] + kM2020to709[k][1] * in[1] +
                                                 kM2020to709[k][2] * in[2]);
                    const float m = std::max(o[0], std::max(o[1], o[2]));
                    if (m > 0.8f) {
                        const float s2 = hdrKnee(m) / m;
                        for (float& v : o)
                            v *= s2;
                    }
                    for (int k = 0; k < 3; ++k) {
                        const int idx = std::min(65536, (int)std::lround(o[k] * 65536.f));
                        const uint16_t e = encode[idx];
                        if (d8)
                            d8[3 * x + 2 - k] = (uint8_t)((e + 128) / 257);
                        else
                            d16[3 * x + 2 - k] = e;
                    }
                }
            }
        });
    }
};

const char* nameOr(const char* n, const char* dflt) {
    return n ? n : dflt;
}

}  // namespace

// ------------------------------------------------------------------------ colour helpers

std::string VideoColorInfo::describe() const {
    return std::string(nameOr(av_color_primaries_name((AVColorPrimaries)primaries), "?")) + "/" +
           nameOr(av_color_transfer_name((AVColorTransferCharacteristic)transfer), "?") + "/" +
           nameOr(av_color_space_name((AVColorSpace)matrix), "?") + "/" +
           nameOr(av_color_range_name((AVColorRange)range), "?");
}

VideoColorInfo VideoColorInfo::sdrDefault() {
    VideoColorInfo c;
    c.primaries = AVCOL_PRI_BT709;
    c.transfer = AVCOL_TRC_IEC61966_2_1;
    c.matrix = AVCOL_SPC_BT709;
    c.range = AVCOL_RANGE_MPEG;
    return c;
}

float hdrKnee(float m) {
    if (m <= 0.8f) return m;
    return 0.8f + 0.2f * (1.f - std::exp(-(m - 0.8f) / 0.2f));
}

Vec3f hdrToLinear709(const Vec3f& rgb2020, int transfer) {
    CV_Assert(transfer == AVCOL_TRC_SMPTE2084 || transfer == AVCOL_TRC_ARIB_STD_B67);
    float in[3];
    for (int k = 0; k < 3; ++k)
        in[k] = (float)(transfer == AVCOL_TRC_SMPTE2084
                            ? pqEotf(rgb2020[k]) / kPqReferenceWhite
                            : hlgInverseOetf(rgb2020[k]) / hlgReferenceWhite());
    Vec3f o;
    for (int k = 0; k < 3; ++k)
        o[k] = std::max(
            0.f, kM2020to709[k][0] * in[0] + kM2020to709[k][1] * in[1] + kM2020to709[k][2] * in[2]);
    const float m = std::max(o[0], std::max(o[1], o[2]));
    if (m > 0.8f) o *= hdrKnee(m) / m;
    return o;
}

// ------------------------------------------------------------------------ VideoReader

struct VideoReader::Impl {
    std::string source;
    VideoReadOptions opt;
    std::vector<std::string> files;  // image sequence
    double fps = 30;
    Size size;
    int count = -1;
    int pos = 0;
    std::vector<double> times;
    std::vector<std::string> notes;
    std::vector<int> damaged;
    std::string conversion;

    // video file
    InputPtr fmt;
    CodecPtr dec;
    FramePtr frame;
    PacketPtr pkt;
    SwsPtr sws;
    int sws_w = 0, sws_h = 0;
    AVPixelFormat sws_src = AV_PIX_FMT_NONE, sws_dst = AV_PIX_FMT_NONE;
    SwsPtr chroma_sws;  // 8-bit Y'CbCr: chroma planes to full size (convertYuv8)
    int chroma_w = 0, chroma_h = 0;
    AVPixelFormat chroma_src = AV_PIX_FMT_NONE;
    int vidx = -1;
    AVRational tb{1, 1};
    int64_t first_pts = AV_NOPTS_VALUE, last_pts = AV_NOPTS_VALUE;
    int64_t frame_ticks = 0;  // nominal frame duration in tb units when the rate is constant
    bool eof_sent = false, decoder_done = false;
    int rotate_code = -1, rotation_cw = 0;
    VideoColorInfo color;
    int bit_depth = 8;
    int audio_streams = 0;
    int64 bit_rate = 0;
    std::string codec_name;
    bool hdr = false;
    HdrConverter hdrconv;
    std::vector<int64_t> lost_pts;  // packets the decoder rejected
    int unknown_lost = 0;           // frames the decoder reported lost without a time
    std::string read_error;
    bool end_noted = false;
    bool count_estimated = false;  // count from a duration, not the container's frame count
    int64_t steady_ticks = 0;      // the interval between frames so far, while it is one
    int steady_count = 0;
    bool steady_broken = false;

    struct Pending {
        Mat frame;
        double t;
    };
    std::deque<Pending> queue;
    Mat last;  // last delivered frame (for repeats)

    void note(const std::string& s) {
        notes.push_back(s);
        if (opt.log) std::fprintf(stderr, "vbme: %s\n", s.c_str());
    }

    void openVideo();
    bool decodeOne();  // decodes one frame into `frame`; false at the end
    Mat convert(const AVFrame* f);
    void repeatLost(const std::vector<int64_t>& at);
    bool fill();  // pushes the next frame(s) to the queue; false at the end
    Mat convertYuv8(const AVFrame* f);
};

void VideoReader::Impl::openVideo() {
    fmt = openInput(source);
    const AVCodec* codec = nullptr;
    vidx = av_find_best_stream(fmt.get(), AVMEDIA_TYPE_VIDEO, -1, -1, &codec, 0);
    if (vidx < 0 || !codec)
        CV_Error(Error::StsError,
                 "'" + source + "' is not a readable video (" +
                     (vidx == AVERROR_DECODER_NOT_FOUND ? "no decoder for it" : "no video stream") +
                     ")");
    for (unsigned i = 0; i < fmt->nb_streams; ++i)
        if (fmt->streams[i]->codecpar->codec_type == AVMEDIA_TYPE_AUDIO) ++audio_streams;
    AVStream* st = fmt->streams[vidx];
    tb = st->time_base;
    codec_name = codec->name;
    dec.reset(avcodec_alloc_context3(codec));
    avcodec_parameters_to_context(dec.get(), st->codecpar);
    dec->thread_count = 0;
    dec->flags |= AV_CODEC_FLAG_OUTPUT_CORRUPT;
    const AVCodecDescriptor* cd = avcodec_descriptor_get(codec->id);
    if (cd && (cd->props & AV_CODEC_PROP_INTRA_ONLY)) {
        // every frame stands alone: a damaged one is reported lost (and repeated) rather than
        // concealed silently; slice threads keep the error with its packet
        dec->err_recognition |= AV_EF_CRCCHECK | AV_EF_EXPLODE;
        dec->thread_type = FF_THREAD_SLICE;
    }
    const int r = avcodec_open2(dec.get(), codec, nullptr);
    if (r < 0)
        CV_Error(Error::StsError, "'" + source + "': cannot open the " + codec->name +
                                      " decoder (" + avError(r) + ")");
    frame.reset(av_frame_alloc());
    pkt.reset(av_packet_alloc());

    // rotation from the display matrix (counter-clockwise degrees)
    size_t sd_size = 0;
    const uint8_t* sd = av_stream_get_side_data(st, AV_PKT_DATA_DISPLAYMATRIX, &sd_size);
    if (sd && sd_size >= 9 * sizeof(int32_t)) {
        const double angle = av_display_rotation_get((const int32_t*)sd);
        if (std::isfinite(angle)) {
            int a = ((int)std::lround(angle / 90.0) * 90) % 360;
            const int ccw = a < 0 ? a + 360 : a;
            rotate_code = ccw == 90    ? ROTATE_90_COUNTERCLOCKWISE
                          : ccw == 180 ? ROTATE_180
                          : ccw == 270 ? ROTATE_90_CLOCKWISE
                                       : -1;
            rotation_cw = (360 - ccw) % 360;
        }
    }
    AVRational fr = st->avg_frame_rate.num > 0 ? st->avg_frame_rate : st->r_frame_rate;
    fps = fr.num > 0 && fr.den > 0 ? av_q2d(fr) : 0;
    if (!(fps > 0 && fps < 1000)) fps = 30;
    // constant rate: the container's nominal rate agrees with the average one
    if (st->r_frame_rate.num > 0 && st->avg_frame_rate.num > 0 &&
        std::abs(av_q2d(st->r_frame_rate) / av_q2d(st->avg_frame_rate) - 1) < 0.01)
        frame_ticks = av_rescale_q(1, av_inv_q(st->r_frame_rate), tb);
    count = st->nb_frames > 0 ? (int)st->nb_frames : -1;
    count_estimated = count < 0;
    if (count < 0 && st->duration > 0 && fps > 0)
        count = (int)std::lround(st->duration * av_q2d(tb) * fps);
    if (count < 0 && fmt->duration > 0 && fps > 0)  // e.g. Matroska: the segment's duration
        count = (int)std::lround(fmt->duration / (double)AV_TIME_BASE * fps);
    bit_rate = st->codecpar->bit_rate > 0 ? st->codecpar->bit_rate : 0;
    if (bit_rate == 0 && fmt->bit_rate > 0 && fmt->nb_streams == 1) bit_rate = fmt->bit_rate;
    if (bit_rate == 0 && st->nb_frames > 0 && st->duration > 0) {
        // sum of packet sizes is not known without reading; estimate from the file size
        std::error_code ec;
        const auto bytes = fs::file_size(source, ec);
        if (!ec) bit_rate = (int64)(bytes * 8 / (st->duration * av_q2d(tb)));
    }
    const AVPixFmtDescriptor* d = av_pix_fmt_desc_get((AVPixelFormat)st->codecpar->format);
    bit_depth = d ? d->comp[0].depth : 8;
    color.primaries = st->codecpar->color_primaries;
    color.transfer = st->codecpar->color_trc;
    color.matrix = st->codecpar->color_space;
    color.range = st->codecpar->color_range;
    if (isFullRangeFormat((AVPixelFormat)st->codecpar->format)) color.range = AVCOL_RANGE_JPEG;
    hdr = color.isHdr();
    if (hdr) {
        const char* tname =
            color.transfer == AVCOL_TRC_SMPTE2084 ? "PQ (SMPTE ST 2084)" : "HLG (ARIB STD-B67)";
        if (opt.hdr == HdrPolicy::Refuse)
            CV_Error(Error::StsError,
                     format("'%s' is HDR video (%s, %s, %d-bit); %s works on standard-dynamic-"
                            "range video only: convert it first (e.g. read it with vbme's "
                            "default HDR conversion or with ffmpeg's zscale/tonemap filters)",
                            source.c_str(), tname, color.describe().c_str(), bit_depth,
                            opt.purpose.empty() ? "this command" : opt.purpose.c_str()));
        hdrconv.init(color.transfer);
        conversion = format(
            "%s %s %d-bit converted to BT.709 sRGB-encoded (reference white "
            "203 cd/m2 -> 1.0, BT.2020->BT.709 gamut matrix, highlight knee "
            "above 0.8)",
            color.transfer == AVCOL_TRC_SMPTE2084 ? "PQ" : "HLG",
            nameOr(av_color_primaries_name((AVColorPrimaries)color.primaries), "?"), bit_depth);
        note("'" + source + "': " + conversion);
    }
}

bool VideoReader::Impl::decodeOne() {
    for (;;) {
        if (decoder_done) return false;
        int r = avcodec_receive_frame(dec.get(), frame.get());
        if (r == 0) return true;
        if (r == AVERROR_EOF) {
            decoder_done = true;
            return false;
        }
        if (r != AVERROR(EAGAIN)) {
            ++unknown_lost;  // the decoder goes on; the frame's place shows as a timestamp gap
            continue;
        }
        if (eof_sent) {
            decoder_done = true;
            return false;
        }
        r = av_read_frame(fmt.get(), pkt.get());
        if (r < 0) {
            if (r != AVERROR_EOF) read_error = avError(r);
            avcodec_send_packet(dec.get(), nullptr);
            eof_sent = true;
            continue;
        }
        if (pkt->stream_index != vidx) {
            av_packet_unref(pkt.get());
            continue;
        }
        const int64_t ppts = pkt->pts != AV_NOPTS_VALUE ? pkt->pts : pkt->dts;
        r = avcodec_send_packet(dec.get(), pkt.get());
        av_packet_unref(pkt.get());
        if (r < 0 && r != AVERROR(EAGAIN)) {
            if (ppts != AV_NOPTS_VALUE)
                lost_pts.push_back(ppts);
            else
                ++unknown_lost;
        }
    }
}

void VideoReader::Impl::repeatLost(const std::vector<int64_t>& at) {
    if (at.empty()) return;
    const int index = pos + (int)queue.size();
    const int n = (int)at.size();
    const std::string msg = format(
        "'%s': frame%s %d%s could not be decoded (damaged data); %s with a repeat of frame %d so "
        "that later frames keep their index and time",
        source.c_str(), n > 1 ? "s" : "", index, n > 1 ? format("-%d", index + n - 1).c_str() : "",
        n > 1 ? "they are replaced" : "it is replaced", index - 1);
    if (opt.strict || last.empty()) CV_Error(Error::StsError, msg);
    note(msg);
    for (int k = 0; k < n; ++k) {
        damaged.push_back(index + k);
        queue.push_back({last, (at[k] - first_pts) * av_q2d(tb)});
    }
}

// Luma and chroma weights (Kr, Kb) of a swscale colourspace.
static void lumaWeights(int sws_cs, double& kr, double& kb) {
    switch (sws_cs) {
        case SWS_CS_ITU709:
            kr = 0.2126, kb = 0.0722;
            break;
        case SWS_CS_BT2020:
            kr = 0.2627, kb = 0.0593;
            break;
        case SWS_CS_FCC:
            kr = 0.30, kb = 0.11;
            break;
        case SWS_CS_SMPTE240M:
            kr = 0.212, kb = 0.087;
            break;
        default:  // BT.601
            kr = 0.299, kb = 0.114;
    }
}

bool isYuv8(AVPixelFormat f) {
    return f == AV_PIX_FMT_YUV420P || f == AV_PIX_FMT_YUVJ420P || f == AV_PIX_FMT_YUV422P ||
           f == AV_PIX_FMT_YUVJ422P || f == AV_PIX_FMT_YUV444P || f == AV_PIX_FMT_YUVJ444P;
}

// 8-bit Y'CbCr (4:2:0, 4:2:2, 4:4:4) to BGR24, as accurate as swscale's accurate RGB path
// (full chroma interpolation, exact rounding) but faster: swscale scales the chroma planes
// alone to full size (Lanczos: on test_core_video_av's clip it gives the accurate path's
// 38.22 dB, where bicubic gives 38.16 and bilinear 37.80), then the matrix is applied by
// OpenCV's vectorised transform (rounding to nearest) in parallel stripes. Opt-in, with
// VBME_YUV=fast in the environment: its frames differ from swscale's RGB path by a code value
// here and there, and that alone moved the pale-ball tracker's frame 1 from IoU 0.925 to 0.883
// (TrackPhone, a thin margin); swscale's RGB path stays the default until that margin is wider.
Mat VideoReader::Impl::convertYuv8(const AVFrame* f) {
    const AVPixelFormat src = (AVPixelFormat)f->format;
    const AVPixFmtDescriptor* d = av_pix_fmt_desc_get(src);
    const bool full =
        isFullRangeFormat(src) || f->color_range == AVCOL_RANGE_JPEG ||
        (f->color_range == AVCOL_RANGE_UNSPECIFIED && color.range == AVCOL_RANGE_JPEG);
    const uint8_t* planes[3] = {f->data[0], f->data[1], f->data[2]};
    size_t steps[3] = {(size_t)f->linesize[0], (size_t)f->linesize[1], (size_t)f->linesize[2]};
    FramePtr up;
    if (d->log2_chroma_w || d->log2_chroma_h) {
        const AVPixelFormat dst = isFullRangeFormat(src) ? AV_PIX_FMT_YUVJ444P : AV_PIX_FMT_YUV444P;
        if (!chroma_sws || chroma_w != f->width || chroma_h != f->height || chroma_src != src) {
            chroma_sws.reset(sws_getContext(
                f->width, f->height, src, f->width, f->height, dst,
                SWS_LANCZOS | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INT | SWS_FULL_CHR_H_INP, nullptr,
                nullptr, nullptr));
            if (!chroma_sws)
                CV_Error(Error::StsError,
                         format("'%s': cannot convert pixel format %s", source.c_str(),
                                nameOr(av_get_pix_fmt_name(src), "?")));
            chroma_w = f->width;
            chroma_h = f->height;
            chroma_src = src;
        }
        up.reset(av_frame_alloc());
        up->format = dst;
        up->width = f->width;
        up->height = f->height;
        const int r = sws_scale_frame(chroma_sws.get(), up.get(), f);
        if (r < 0)
            CV_Error(Error::StsError, format("'%s': pixel conversion failed (%s)", source.c_str(),
                                             avError(r).c_str()));
        for (int k = 0; k < 3; ++k) {
            planes[k] = up->data[k];
            steps[k] = (size_t)up->linesize[k];
        }
    }
    const int matrix = f->colorspace != AVCOL_SPC_UNSPECIFIED ? f->colorspace : color.matrix;
    double kr, kb;
    lumaWeights(swsColorspace(matrix, f->height), kr, kb);
    const double kg = 1 - kr - kb;
    const double ys = full ? 1.0 : 255.0 / 219.0, cs = full ? 1.0 : 255.0 / 224.0;
    const double yo = full ? 0.0 : 16.0;
    // rows: B, G, R from (Y', Cb, Cr, 1)
    const double bu = cs * 2 * (1 - kb), rv = cs * 2 * (1 - kr);
    const double gu = -cs * 2 * (1 - kb) * kb / kg, gv = -cs * 2 * (1 - kr) * kr / kg;
    const Matx34f m((float)ys, (float)bu, 0.f, (float)(-ys * yo - bu * 128),  //
                    (float)ys, (float)gu, (float)gv, (float)(-ys * yo - (gu + gv) * 128), (float)ys,
                    0.f, (float)rv, (float)(-ys * yo - rv * 128));
    Mat out(f->height, f->width, CV_8UC3);
    const Mat yp(f->height, f->width, CV_8U, (void*)planes[0], steps[0]);
    const Mat up_(f->height, f->width, CV_8U, (void*)planes[1], steps[1]);
    const Mat vp(f->height, f->width, CV_8U, (void*)planes[2], steps[2]);
    parallel_for_(
        Range(0, f->height),
        [&](const Range& rows) {
            Mat yuv;
            merge(std::vector<Mat>{yp.rowRange(rows), up_.rowRange(rows), vp.rowRange(rows)}, yuv);
            Mat dst = out.rowRange(rows);
            transform(yuv, dst, m);
        },
        8);
    return out;
}

Mat VideoReader::Impl::convert(const AVFrame* f) {
    const AVPixelFormat src = (AVPixelFormat)f->format;
    const bool deep = hdr || opt.depth == CV_16U;
    static const bool fast_yuv = [] {
        const char* v = std::getenv("VBME_YUV");
        return v && std::string(v) == "fast";
    }();
    if (!deep && isYuv8(src) && fast_yuv) {
        Mat out = convertYuv8(f);
        if (rotate_code >= 0) rotate(out, out, rotate_code);
        return out;
    }
    const AVPixelFormat dst = deep ? AV_PIX_FMT_BGR48LE : AV_PIX_FMT_BGR24;
    // accurate conversion (full chroma interpolation, exact rounding: the fast path loses
    // 1.3 dB on test_core_video_av's clip), spread over slice threads
    const int flags = SWS_BICUBIC | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INT | SWS_FULL_CHR_H_INP;
    if (!sws || sws_w != f->width || sws_h != f->height || sws_src != src || sws_dst != dst) {
        sws.reset(sws_alloc_context());
        av_opt_set_int(sws.get(), "srcw", f->width, 0);
        av_opt_set_int(sws.get(), "srch", f->height, 0);
        av_opt_set_int(sws.get(), "src_format", src, 0);
        av_opt_set_int(sws.get(), "dstw", f->width, 0);
        av_opt_set_int(sws.get(), "dsth", f->height, 0);
        av_opt_set_int(sws.get(), "dst_format", dst, 0);
        av_opt_set_int(sws.get(), "sws_flags", flags, 0);
        av_opt_set_int(sws.get(), "threads", 0, 0);
        if (sws_init_context(sws.get(), nullptr, nullptr) < 0) sws.reset();
        if (!sws)
            CV_Error(Error::StsError, format("'%s': cannot convert pixel format %s", source.c_str(),
                                             nameOr(av_get_pix_fmt_name(src), "?")));
        sws_w = f->width;
        sws_h = f->height;
        sws_src = src;
        sws_dst = dst;
    }
    if (!isRgbFormat(src)) {
        int matrix = f->colorspace != AVCOL_SPC_UNSPECIFIED ? f->colorspace : color.matrix;
        const int full =
            isFullRangeFormat(src) || f->color_range == AVCOL_RANGE_JPEG ||
            (f->color_range == AVCOL_RANGE_UNSPECIFIED && color.range == AVCOL_RANGE_JPEG);
        sws_setColorspaceDetails(sws.get(), sws_getCoefficients(swsColorspace(matrix, f->height)),
                                 full, sws_getCoefficients(SWS_CS_DEFAULT), 1, 0, 1 << 16, 1 << 16);
    }
    Mat out(f->height, f->width, deep ? CV_16UC3 : CV_8UC3);
    {
        FramePtr d(av_frame_alloc());
        d->format = dst;
        d->width = f->width;
        d->height = f->height;
        const int r = sws_scale_frame(sws.get(), d.get(), f);
        if (r < 0)
            CV_Error(Error::StsError, format("'%s': pixel conversion failed (%s)", source.c_str(),
                                             avError(r).c_str()));
        const size_t row = (size_t)f->width * out.elemSize();
        for (int y = 0; y < f->height; ++y)
            std::memcpy(out.ptr(y), d->data[0] + (size_t)y * d->linesize[0], row);
    }
    if (hdr) {
        Mat sdr;
        hdrconv.convert(out, sdr, opt.depth);
        out = sdr;
    } else if (deep && opt.depth == CV_8U) {
        out.convertTo(out, CV_8U, 1.0 / 257.0);
    }
    if (rotate_code >= 0) rotate(out, out, rotate_code);
    return out;
}

bool VideoReader::Impl::fill() {
    if (!decodeOne()) {
        // lost frames after the last decoded one
        std::sort(lost_pts.begin(), lost_pts.end());
        std::vector<int64_t> tail;
        for (int64_t p : lost_pts)
            if (last_pts == AV_NOPTS_VALUE || p > last_pts) tail.push_back(p);
        lost_pts.clear();
        if (!tail.empty() && !last.empty()) {
            repeatLost(tail);
            return true;
        }
        if (unknown_lost > 0) {
            const std::string msg = format(
                "'%s': %d frame(s) after frame %d could not be decoded "
                "(damaged data)",
                source.c_str(), unknown_lost, pos - 1);
            unknown_lost = 0;
            if (opt.strict) CV_Error(Error::StsError, msg);
            note(msg);
        }
        if (!read_error.empty()) {
            const std::string msg =
                format("'%s': reading stopped after frame %d: %s", source.c_str(),
                       pos + (int)queue.size() - 1, read_error.c_str());
            read_error.clear();
            if (opt.strict) CV_Error(Error::StsError, msg);
            note(msg);
        }
        const int got_frames = pos + (int)queue.size();
        // an estimated count (duration x average rate) is trusted to 5 % and a frame
        if (count > 0 && !end_noted &&
            (count_estimated ? got_frames < 0.95 * count - 1 : got_frames < count)) {
            end_noted = true;
            const int got = pos + (int)queue.size();
            const std::string msg = format(
                "'%s': the video ends after %d frames, the container announced %d "
                "(truncated file?)",
                source.c_str(), got, count);
            if (opt.strict) CV_Error(Error::StsError, msg);
            note(msg);
            count = got;
        }
        return false;
    }
    int64_t pts = frame->best_effort_timestamp;
    if (pts == AV_NOPTS_VALUE)
        pts = last_pts == AV_NOPTS_VALUE ? 0 : last_pts + std::max<int64_t>(frame_ticks, 1);
    if (first_pts == AV_NOPTS_VALUE) first_pts = pts;
    // frames lost before this one: their packets failed (known times), or the decoder said so
    // without a time (then a gap of whole frame durations in a constant-rate stream)
    std::sort(lost_pts.begin(), lost_pts.end());
    std::vector<int64_t> before;
    while (!lost_pts.empty() && lost_pts.front() < pts) {
        if (last_pts == AV_NOPTS_VALUE || lost_pts.front() > last_pts)
            before.push_back(lost_pts.front());
        lost_pts.erase(lost_pts.begin());
    }
    const int64_t gap = last_pts == AV_NOPTS_VALUE ? 0 : pts - last_pts;
    if (before.empty() && unknown_lost > 0 && frame_ticks > 0 && last_pts != AV_NOPTS_VALUE &&
        gap > frame_ticks * 3 / 2) {
        const int missing =
            std::min<int>(unknown_lost, (int)((gap + frame_ticks / 2) / frame_ticks) - 1);
        for (int k = 1; k <= missing; ++k)
            before.push_back(last_pts + k * frame_ticks);
        unknown_lost = 0;
    } else if (before.empty() && last_pts != AV_NOPTS_VALUE && !steady_broken &&
               steady_count >= 4 && steady_ticks > 0) {
        // packets lost before the decoder saw them (e.g. a damaged Matroska block the demuxer
        // skipped): in a stream whose frames have so far come at one interval, a gap of a whole
        // multiple of it
        const int64_t m = (gap + steady_ticks / 2) / steady_ticks;
        if (m >= 2 && m <= 10 && std::llabs(gap - m * steady_ticks) <= m)
            for (int64_t k = 1; k < m; ++k)
                before.push_back(last_pts + k * steady_ticks);
    }
    if (last_pts != AV_NOPTS_VALUE && before.empty()) {
        if (steady_count == 0) {
            steady_ticks = gap;
            steady_count = 1;
        } else if (std::llabs(gap - steady_ticks) <= 1) {
            ++steady_count;
        } else {
            steady_broken = true;
        }
    }
    repeatLost(before);
    const int my_index = pos + (int)queue.size();
    if (frame->decode_error_flags || (frame->flags & AV_FRAME_FLAG_CORRUPT)) {
        const std::string msg =
            format("'%s': frame %d (t=%.3f s) was decoded from damaged data (errors concealed)",
                   source.c_str(), my_index, (pts - first_pts) * av_q2d(tb));
        if (opt.strict) CV_Error(Error::StsError, msg);
        note(msg);
        damaged.push_back(my_index);
    }
    Mat m = convert(frame.get());
    av_frame_unref(frame.get());
    last = m;
    last_pts = pts;
    queue.push_back({m, (pts - first_pts) * av_q2d(tb)});
    return true;
}

VideoReader::VideoReader(const std::string& source) : VideoReader(source, VideoReadOptions()) {}

VideoReader::VideoReader(const std::string& source, const VideoReadOptions& options)
    : impl_(new Impl) {
    Impl& m = *impl_;
    m.source = source;
    m.opt = options;
    if (m.opt.depth != CV_8U && m.opt.depth != CV_16U)
        CV_Error(Error::StsBadArg, "VideoReader: depth must be CV_8U or CV_16U");
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
        m.codec_name = "image";
        Mat first = imread(m.files[0], IMREAD_UNCHANGED);
        if (first.empty())
            CV_Error(Error::StsError, "'" + m.files[0] + "' is not a readable image");
        m.bit_depth = first.depth() == CV_16U ? 16 : 8;
        m.color = VideoColorInfo::sdrDefault();
        m.color.matrix = AVCOL_SPC_RGB;
        m.color.range = AVCOL_RANGE_JPEG;
        Mat f = toBgr(first, m.files[0], m.opt.depth);
        m.size = f.size();
        m.queue.push_back({f, 0.0});
        return;
    }

    m.openVideo();
    if (!m.fill()) CV_Error(Error::StsError, "'" + source + "' holds no decodable frame");
    m.size = m.queue.front().frame.size();
}

VideoReader::~VideoReader() = default;

bool VideoReader::read(OutputArray frame) {
    Impl& m = *impl_;
    if (m.queue.empty()) {
        if (!m.files.empty()) {
            if (m.pos >= (int)m.files.size()) return false;
            const std::string& name = m.files[m.pos];
            Mat f = imread(name, IMREAD_UNCHANGED);
            if (f.empty()) CV_Error(Error::StsError, "'" + name + "' is not a readable image");
            f = toBgr(f, name, m.opt.depth);
            if (f.size() != m.size)
                CV_Error(Error::StsError,
                         format("'%s' is %dx%d, but the sequence is %dx%d", name.c_str(), f.cols,
                                f.rows, m.size.width, m.size.height));
            m.queue.push_back({f, m.pos / m.fps});
        } else if (!m.fill()) {
            return false;
        }
    }
    Impl::Pending p = std::move(m.queue.front());
    m.queue.pop_front();
    m.times.push_back(p.t);
    ++m.pos;
    if (frame.needed()) p.frame.copyTo(frame);
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
double VideoReader::timestamp() const {
    return impl_->times.empty() ? 0.0 : impl_->times.back();
}
const std::vector<double>& VideoReader::timestamps() const {
    return impl_->times;
}
Vec2i VideoReader::timeBase() const {
    if (!impl_->files.empty()) return Vec2i(1, std::max(1, (int)std::lround(impl_->fps)));
    return Vec2i(impl_->tb.num, impl_->tb.den);
}
VideoColorInfo VideoReader::colorInfo() const {
    return impl_->color;
}
int VideoReader::bitDepth() const {
    return impl_->bit_depth;
}
int VideoReader::rotation() const {
    return impl_->rotation_cw;
}
int VideoReader::audioStreams() const {
    return impl_->audio_streams;
}
int64 VideoReader::bitRate() const {
    return impl_->bit_rate;
}
std::string VideoReader::codecName() const {
    return impl_->codec_name;
}
std::string VideoReader::conversion() const {
    return impl_->conversion;
}
const std::vector<std::string>& VideoReader::notes() const {
    return impl_->notes;
}
const std::vector<int>& VideoReader::damagedFrames() const {
    return impl_->damaged;
}
const std::string& VideoReader::source() const {
    return impl_->source;
}

// ---------------------------------------------------------------- VideoSink

namespace {

struct OutputDeleter {
    void operator()(AVFormatContext* c) const {
        if (!c) return;
        if (c->pb && !(c->oformat->flags & AVFMT_NOFILE)) avio_closep(&c->pb);
        avformat_free_context(c);
    }
};
using OutputPtr = std::unique_ptr<AVFormatContext, OutputDeleter>;

// One carried audio stream: copied, or decoded and re-encoded to AAC.
struct AudioTrack {
    int in_index = -1;
    AVStream* out = nullptr;
    AVRational in_tb{1, 1};
    int64_t offset = 0;  // input ticks subtracted (the source's first video frame)
    bool copy = true;
    CodecPtr dec, enc;
    SwrPtr swr;
    FifoPtr fifo;
    int64_t next_pts = 0;  // re-encode: samples written
    bool started = false;
};

}  // namespace

struct QualityTrialFrames;

struct VideoSink::Impl {
    std::string path;
    VideoSinkOptions opt;
    bool sequence = false;
    std::string seq_codec;  // "", "png", "exr"
    std::unique_ptr<AtomicFile> file;
    Size size;
    bool color = true;
    bool deep = false;  // frames CV_16UC3 (decided by the first frame)
    double fps = 30;
    int count = 0;
    bool closed = false;
    double last_t = -1, next_end = 0;
    std::unique_ptr<Progress> progress;

    OutputPtr oc;
    const AVCodec* codec = nullptr;
    CodecPtr enc;
    AVStream* vst = nullptr;
    FramePtr vframe;
    PacketPtr pkt;
    SwsPtr sws;
    AVPixelFormat pix_fmt = AV_PIX_FMT_NONE;
    bool opened = false;
    // bit-rate floor (VideoSinkOptions::min_bitrate): the CRF now, the first frame sent with it
    // (encoder ticks), bytes and time span of the packets of frames from that one on, and the
    // video time of the next look at them
    bool rate_floor = false;
    double crf_now = 0;
    int64_t crf_since = 0;
    int64 rate_bytes = 0;
    int64_t pkt_first = AV_NOPTS_VALUE, pkt_end = AV_NOPTS_VALUE;
    double next_rate_check = 0.25;
    void adjustRate(double seconds, int64_t pts);

    InputPtr ain;
    std::vector<AudioTrack> tracks;
    bool audio_done = false;
    PacketPtr apkt;
    FramePtr aframe;

    // the quality floor (VideoSinkOptions::min_psnr): frames held until the trial encodes
    // chose the CRF, and what the trials found (for the stream's encoder_settings)
    bool trial_done = false;
    std::vector<std::pair<Mat, double>> held;
    std::string trial_note;
    bool trialPending() const;
    double minPsnr() const;  // VideoSinkOptions::min_psnr, its default resolved
    void runQualityTrial();
    double trialPsnr(const QualityTrialFrames& t, int crf);
    void encodeVideoFrame(const Mat& frame, double seconds);
    void flushHeld();

    std::string pixelFormatName() const;
    AVRational videoTimeBase() const;
    void openEncoder(bool deep_frames);
    void encode(AVFrame* f);
    void pumpAudio(double until, bool final);
    bool has_held = false;
    void setupAudio();
    void writeAudioPacket(AudioTrack& t, AVPacket* p);
    void reencodeAudio(AudioTrack& t, AVPacket* p);  // p == nullptr: flush
    void drainAudioEncoder(AudioTrack& t, bool flush);
};

static const char* codecLibName(const std::string& c) {
    if (c == "h264") return "libx264";
    if (c == "h265") return "libx265";
    if (c == "prores") return "prores_ks";
    if (c == "ffv1") return "ffv1";
    return nullptr;
}

VideoSink::VideoSink(const std::string& path, double fps, Size size, bool color)
    : VideoSink(path, fps, size, VideoSinkOptions()) {
    impl_->color = color;
}

VideoSink::VideoSink(const std::string& path, double fps, Size size,
                     const VideoSinkOptions& options)
    : impl_(new Impl) {
    Impl& m = *impl_;
    m.path = path;
    m.size = size;
    m.opt = options;
    m.fps = fps;
    CV_Assert(size.width > 0 && size.height > 0);
    if (!(fps > 0)) CV_Error(Error::StsBadArg, "frame rate must be positive");
    const std::string codec = lower(options.codec);
    if (!options.progress.empty())
        m.progress.reset(new Progress(options.progress, options.expected_frames));
    if (path.find('%') != std::string::npos) {
        if (!codec.empty() && codec != "png" && codec != "exr")
            CV_Error(Error::StsBadArg, "'" + path +
                                           "': an image pattern is written as png or exr, "
                                           "not " +
                                           codec);
        m.sequence = true;
        m.seq_codec = codec;
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
    std::string c = codec;
    if (ext == ".mp4" || ext == ".mov" || ext == ".m4v") {
        if (c.empty()) c = "h264";
        if (c == "ffv1")
            CV_Error(Error::StsBadArg, "'" + path + "': FFV1 goes into .mkv or .avi, not " + ext);
    } else if (ext == ".mkv" || ext == ".avi") {
        if (c.empty()) c = "ffv1";
    } else {
        CV_Error(Error::StsBadArg, "'" + path +
                                       "': unsupported output (use .mp4, .mov, .mkv, .avi, or an "
                                       "image pattern such as frames/%05d.png)");
    }
    if (c == "png" || c == "exr")
        CV_Error(Error::StsBadArg, "'" + path + "': codec " + c +
                                       " writes an image sequence: give a pattern such as "
                                       "frames/%05d." +
                                       c);
    const char* lib = codecLibName(c);
    if (!lib)
        CV_Error(Error::StsBadArg,
                 "unknown codec '" + c + "' (use h264, h265, prores, ffv1, png or exr)");
    m.codec = avcodec_find_encoder_by_name(lib);
    if (!m.codec)
        CV_Error(Error::StsError, std::string("the encoder ") + lib + " is not available");
    m.opt.codec = c;
    m.file.reset(new AtomicFile(path));
}

// The encoded pixel format (VideoSinkOptions::pix_fmt or the codec's default), for frames of
// depth `deep`.
std::string VideoSink::Impl::pixelFormatName() const {
    const std::string& c = opt.codec;
    std::string pf = opt.pix_fmt;
    if (pf.empty()) {
        if (c == "ffv1")
            pf = deep ? "gbrp16le" : "bgr0";
        else if (c == "prores")
            pf = "yuv422p10le";
        else if (opt.full_chroma && (c == "h264" || c == "h265"))
            pf = deep ? "yuv444p10le" : "yuv444p";
        else
            pf = deep ? "yuv420p10le" : "yuv420p";
    }
    const AVPixelFormat f = av_get_pix_fmt(pf.c_str());
    if (f == AV_PIX_FMT_NONE) CV_Error(Error::StsBadArg, "unknown pixel format '" + pf + "'");
    const AVPixFmtDescriptor* pd = av_pix_fmt_desc_get(f);
    if (pd && (pd->log2_chroma_w || pd->log2_chroma_h) && (size.width % 2 || size.height % 2))
        pf = deep ? "yuv444p10le" : "yuv444p";  // 4:2:0 / 4:2:2 need even sizes: full chroma
    return pf;
}

AVRational VideoSink::Impl::videoTimeBase() const {
    if (lower(fs::path(path).extension().string()) == ".avi")
        return av_inv_q(av_d2q(fps, 100000));  // AVI counts frames: its tick is one frame
    return opt.time_base[0] > 0 && opt.time_base[1] > 0
               ? AVRational{opt.time_base[0], opt.time_base[1]}
               : AVRational{1, 90000};
}

double VideoSink::Impl::minPsnr() const {
    return opt.min_psnr >= 0 ? opt.min_psnr : (opt.full_chroma ? 48.0 : 0.0);
}

bool VideoSink::Impl::trialPending() const {
    return !trial_done && !sequence && minPsnr() > 0 && opt.bitrate == 0 &&
           (opt.codec == "h264" || opt.codec == "h265");
}

// The frames of the quality trials: as the sink converts them for the encoder, and converted
// back to BGR (what a lossless coder would keep, the reference of the coding error).
struct QualityTrialFrames {
    std::vector<FramePtr> coded;
    std::vector<Mat> refs;
    SwsPtr back;  // the encoder's pixel format to BGR
    AVPixelFormat pf = AV_PIX_FMT_NONE;
};

static Mat swsToBgr(SwsContext* back, const AVFrame* f, Size size, int type) {
    Mat m(size, type);
    uint8_t* dst[4] = {m.data, nullptr, nullptr, nullptr};
    const int stride[4] = {(int)m.step[0], 0, 0, 0};
    sws_scale(back, f->data, f->linesize, 0, size.height, dst, stride);
    return m;
}

// One trial of the quality floor: the trial frames encoded at @p crf by an encoder set up as
// the sink's (codec, preset, pixel format, colour), decoded and converted back to BGR; returns
// the PSNR against the references over the frames after the first (the coding error alone), -1
// on failure.
double VideoSink::Impl::trialPsnr(const QualityTrialFrames& t, int crf) {
    const bool rgb = isRgbFormat(t.pf);
    CodecPtr e(avcodec_alloc_context3(codec));
    e->width = size.width;
    e->height = size.height;
    e->pix_fmt = t.pf;
    e->time_base = AVRational{1, 1000};
    e->framerate = av_d2q(fps, 100000);
    e->thread_count = 0;
    e->color_primaries = (AVColorPrimaries)opt.color.primaries;
    e->color_trc = (AVColorTransferCharacteristic)opt.color.transfer;
    e->colorspace = rgb ? AVCOL_SPC_RGB : (AVColorSpace)opt.color.matrix;
    e->color_range = rgb ? AVCOL_RANGE_JPEG : (AVColorRange)opt.color.range;
    av_opt_set(e->priv_data, "crf", std::to_string(crf).c_str(), 0);
    av_opt_set(e->priv_data, "preset", opt.preset.c_str(), 0);
    if (opt.codec == "h265") av_opt_set(e->priv_data, "x265-params", "log-level=error", 0);
    if (avcodec_open2(e.get(), codec, nullptr) < 0) return -1;
    const AVCodec* dc = avcodec_find_decoder(codec->id);
    if (!dc) return -1;
    CodecPtr d(avcodec_alloc_context3(dc));
    d->thread_count = 1;
    if (avcodec_open2(d.get(), dc, nullptr) < 0) return -1;
    const int type = deep ? CV_16UC3 : CV_8UC3;
    double sse = 0, n = 0;
    size_t got = 0;
    PacketPtr p(av_packet_alloc());
    FramePtr out(av_frame_alloc());
    auto frames = [&]() {
        while (avcodec_receive_frame(d.get(), out.get()) == 0) {
            // the first frame (a keyframe, coded finer than the frames between keyframes) is
            // left out unless it is the only one
            if (got < t.refs.size() && (got > 0 || t.refs.size() == 1)) {
                const Mat m = swsToBgr(t.back.get(), out.get(), size, type);
                sse += norm(m, t.refs[got], NORM_L2SQR);
                n += (double)m.total() * 3;
            }
            ++got;
            av_frame_unref(out.get());
        }
    };
    auto packets = [&]() {
        while (avcodec_receive_packet(e.get(), p.get()) == 0) {
            avcodec_send_packet(d.get(), p.get());
            av_packet_unref(p.get());
            frames();
        }
    };
    for (size_t i = 0; i < t.coded.size(); ++i) {
        t.coded[i]->pts = (int64_t)i * 40;
        if (avcodec_send_frame(e.get(), t.coded[i].get()) < 0) return -1;
        packets();
    }
    avcodec_send_frame(e.get(), nullptr);
    packets();
    avcodec_send_packet(d.get(), nullptr);
    frames();
    if (got != t.refs.size() || n == 0) return -1;
    const double peak = deep ? 65535.0 : 255.0;
    return sse <= 0 ? 100.0 : std::min(100.0, 10 * std::log10(peak * peak * n / sse));
}

// The quality floor (VideoSinkOptions::min_psnr): trial encodes of the frames held choose the
// CRF the video is encoded at. The first trial is at the CRF asked for; each next one lowers
// it by the dB still missing (plus 0.3 dB) at 1 dB per CRF step (the quantizer step doubles
// every 6 steps, its error power quadruples: 6 dB), or at the slope measured between the last
// two trials, at least 1 step; at most 5 trials, the lowest CRF tried being kept if none
// reaches the floor. CRF 0 is lossless in 8 bits (x264), which ends the search.
void VideoSink::Impl::runQualityTrial() {
    trial_done = true;
    if (held.empty()) return;
    quietLibav();
    QualityTrialFrames t;
    const std::string pf_name = pixelFormatName();
    t.pf = av_get_pix_fmt(pf_name.c_str());
    const bool rgb = isRgbFormat(t.pf);
    const int flags = SWS_BICUBIC | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INT | SWS_FULL_CHR_H_INP;
    // the sink's forward conversion, as openEncoder sets it up, and its inverse
    const AVPixelFormat bgrf = deep ? AV_PIX_FMT_BGR48LE : AV_PIX_FMT_BGR24;
    SwsPtr fwd(sws_getContext(size.width, size.height, bgrf, size.width, size.height, t.pf, flags,
                              nullptr, nullptr, nullptr));
    t.back.reset(sws_getContext(size.width, size.height, t.pf, size.width, size.height, bgrf, flags,
                                nullptr, nullptr, nullptr));
    if (!fwd || !t.back) CV_Error(Error::StsError, "cannot convert frames to " + pf_name);
    if (!rgb) {
        const int* cs = sws_getCoefficients(swsColorspace(opt.color.matrix, 1080));
        const int full = opt.color.range == AVCOL_RANGE_JPEG ? 1 : 0;
        sws_setColorspaceDetails(fwd.get(), sws_getCoefficients(SWS_CS_DEFAULT), 1, cs, full, 0,
                                 1 << 16, 1 << 16);
        sws_setColorspaceDetails(t.back.get(), cs, full, sws_getCoefficients(SWS_CS_DEFAULT), 1, 0,
                                 1 << 16, 1 << 16);
    }
    for (const auto& h : held) {
        Mat bgr = h.first;
        if (bgr.channels() == 1) cvtColor(bgr, bgr, COLOR_GRAY2BGR);
        FramePtr f(av_frame_alloc());
        f->format = t.pf;
        f->width = size.width;
        f->height = size.height;
        if (av_frame_get_buffer(f.get(), 0) < 0)
            CV_Error(Error::StsNoMem, "cannot allocate a video frame");
        const uint8_t* src[4] = {bgr.data, nullptr, nullptr, nullptr};
        const int stride[4] = {(int)bgr.step[0], 0, 0, 0};
        sws_scale(fwd.get(), src, stride, 0, size.height, f->data, f->linesize);
        t.refs.push_back(swsToBgr(t.back.get(), f.get(), size, deep ? CV_16UC3 : CV_8UC3));
        t.coded.push_back(std::move(f));
    }
    // CRF 0 is lossless in 8 bits and needs x264's High 4:4:4 Predictive profile: kept for
    // full-chroma outputs (already that profile), not for subsampled ones (High profile)
    const AVPixFmtDescriptor* pd = av_pix_fmt_desc_get(t.pf);
    const int lowest_crf = pd && (pd->log2_chroma_w || pd->log2_chroma_h) ? 1 : 0;
    const double floor_db = minPsnr();
    int crf = opt.crf, prev_crf = -1;
    double prev_psnr = 0, psnr = 0;
    std::string tried;
    for (int trial = 0; trial < 5; ++trial) {
        psnr = trialPsnr(t, crf);
        if (psnr < 0) {
            trial_note = " (quality trial failed: the CRF as given)";
            return;
        }
        tried += format("%s%d: %.2f dB", tried.empty() ? "" : ", ", crf, psnr);
        if (psnr >= floor_db || crf <= lowest_crf) break;
        double slope = 1.0;
        if (prev_crf > crf && psnr > prev_psnr)
            slope = std::max(0.3, (psnr - prev_psnr) / (prev_crf - crf));
        const int step = std::max(1, (int)std::ceil((floor_db + 0.3 - psnr) / slope));
        prev_crf = crf;
        prev_psnr = psnr;
        crf = std::max(lowest_crf, crf - step);
    }
    trial_note = format(
        " (crf %d asked; PSNR of the coding error on the first %zu frames at crf "
        "%s; floor %.1f dB)",
        opt.crf, t.coded.size(), tried.c_str(), floor_db);
    opt.crf = crf;
}

void VideoSink::Impl::flushHeld() {
    runQualityTrial();
    for (const auto& h : held)
        encodeVideoFrame(h.first, h.second);
    held.clear();
}

void VideoSink::Impl::encodeVideoFrame(const Mat& frame, double seconds) {
    if (!opened) openEncoder(deep);
    Mat bgr = frame;
    if (frame.channels() == 1) cvtColor(frame, bgr, COLOR_GRAY2BGR);
    if (av_frame_make_writable(vframe.get()) < 0)
        CV_Error(Error::StsNoMem, "cannot allocate a video frame");
    const uint8_t* src[4] = {bgr.data, nullptr, nullptr, nullptr};
    const int stride[4] = {(int)bgr.step[0], 0, 0, 0};
    sws_scale(sws.get(), src, stride, 0, size.height, vframe->data, vframe->linesize);
    vframe->pts = (int64_t)std::llround(seconds / av_q2d(enc->time_base));
    next_end = seconds + 1.0 / fps;
    pumpAudio(seconds, false);
    adjustRate(seconds, vframe->pts);
    encode(vframe.get());
}

void VideoSink::Impl::openEncoder(bool deep_frames) {
    deep = deep_frames;
    quietLibav();
    AVFormatContext* raw = nullptr;
    int r = avformat_alloc_output_context2(&raw, nullptr, nullptr, path.c_str());
    if (r < 0 || !raw) CV_Error(Error::StsError, "cannot write '" + path + "': " + avError(r));
    oc.reset(raw);
    // the muxer was chosen by the final name; it writes (and, for faststart, re-opens) the
    // temporary one
    av_freep(&oc->url);
    oc->url = av_strdup(file->tempPath().c_str());
    const std::string& c = opt.codec;
    const std::string pf = pixelFormatName();
    pix_fmt = av_get_pix_fmt(pf.c_str());
    enc.reset(avcodec_alloc_context3(codec));
    enc->width = size.width;
    enc->height = size.height;
    enc->pix_fmt = pix_fmt;
    enc->time_base = videoTimeBase();
    enc->framerate = av_d2q(fps, 100000);
    enc->thread_count = 0;
    const bool rgb = isRgbFormat(pix_fmt);
    enc->color_primaries = (AVColorPrimaries)opt.color.primaries;
    enc->color_trc = (AVColorTransferCharacteristic)opt.color.transfer;
    enc->colorspace = rgb ? AVCOL_SPC_RGB : (AVColorSpace)opt.color.matrix;
    enc->color_range = rgb ? AVCOL_RANGE_JPEG : (AVColorRange)opt.color.range;
    if (c == "h264" || c == "h265") {
        if (opt.bitrate > 0) {
            enc->bit_rate = opt.bitrate;
        } else {
            av_opt_set(enc->priv_data, "crf", std::to_string(opt.crf).c_str(), 0);
            // libx264 takes a new CRF between frames (x264_encoder_reconfig); libx265 does not
            rate_floor = opt.min_bitrate > 0 && c == "h264";
            crf_now = opt.crf;
        }
        av_opt_set(enc->priv_data, "preset", opt.preset.c_str(), 0);
        if (c == "h265") av_opt_set(enc->priv_data, "x265-params", "log-level=error", 0);
    } else if (c == "prores") {
        av_opt_set(enc->priv_data, "profile", "hq", 0);
    } else if (c == "ffv1") {
        enc->level = 3;
        enc->gop_size = 1;  // every frame a keyframe: damage stays in its frame
        av_opt_set(enc->priv_data, "slicecrc", "1", 0);
    }
    if (oc->oformat->flags & AVFMT_GLOBALHEADER) enc->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
    r = avcodec_open2(enc.get(), codec, nullptr);
    if (r < 0)
        CV_Error(Error::StsError,
                 format("cannot open the %s encoder for '%s' (%s, %s)", codec->name, path.c_str(),
                        pf.c_str(), avError(r).c_str()));
    vst = avformat_new_stream(oc.get(), nullptr);
    vst->time_base = enc->time_base;
    vst->avg_frame_rate = enc->framerate;
    avcodec_parameters_from_context(vst->codecpar, enc.get());
    for (const auto& kv : opt.metadata)
        av_dict_set(&oc->metadata, kv.first.c_str(), kv.second.c_str(), 0);
    av_dict_set(
        &oc->metadata, "encoder_settings",
        (c == "h264" || c == "h265"
             ? (opt.bitrate > 0
                    ? format("%s %lld bit/s %s", codec->name, (long long)opt.bitrate, pf.c_str())
                    : format("%s crf %d%s %s%s", codec->name, opt.crf,
                             rate_floor
                                 ? format(" min %lld bit/s", (long long)opt.min_bitrate).c_str()
                                 : "",
                             pf.c_str(), trial_note.c_str()))
             : format("%s %s", codec->name, pf.c_str()))
            .c_str(),
        0);
    setupAudio();
    r = avio_open(&oc->pb, file->tempPath().c_str(), AVIO_FLAG_WRITE);
    if (r < 0) CV_Error(Error::StsError, "cannot create '" + file->tempPath() + "': " + avError(r));
    AVDictionary* mux = nullptr;
    const std::string ext = lower(fs::path(path).extension().string());
    if (ext == ".mp4" || ext == ".mov" || ext == ".m4v")
        av_dict_set(&mux, "movflags", "+faststart+use_metadata_tags", 0);
    r = avformat_write_header(oc.get(), &mux);
    av_dict_free(&mux);
    if (r < 0) CV_Error(Error::StsError, "cannot write '" + path + "': " + avError(r));
    vframe.reset(av_frame_alloc());
    vframe->format = pix_fmt;
    vframe->width = size.width;
    vframe->height = size.height;
    vframe->color_primaries = enc->color_primaries;
    vframe->color_trc = enc->color_trc;
    vframe->colorspace = enc->colorspace;
    vframe->color_range = enc->color_range;
    if (av_frame_get_buffer(vframe.get(), 0) < 0)
        CV_Error(Error::StsNoMem, "cannot allocate a video frame");
    pkt.reset(av_packet_alloc());
    const AVPixelFormat srcf = deep ? AV_PIX_FMT_BGR48LE : AV_PIX_FMT_BGR24;
    sws.reset(
        sws_getContext(size.width, size.height, srcf, size.width, size.height, pix_fmt,
                       SWS_BICUBIC | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INT | SWS_FULL_CHR_H_INP,
                       nullptr, nullptr, nullptr));
    if (!sws) CV_Error(Error::StsError, "cannot convert frames to " + pf);
    if (!rgb)
        sws_setColorspaceDetails(sws.get(), sws_getCoefficients(SWS_CS_DEFAULT), 1,
                                 sws_getCoefficients(swsColorspace(opt.color.matrix, 1080)),
                                 opt.color.range == AVCOL_RANGE_JPEG ? 1 : 0, 0, 1 << 16, 1 << 16);
    opened = true;
}

void VideoSink::Impl::setupAudio() {
    if (opt.audio_from.empty()) return;
    ain = openInput(opt.audio_from);
    const int v = av_find_best_stream(ain.get(), AVMEDIA_TYPE_VIDEO, -1, -1, nullptr, 0);
    double start = 0;  // seconds of the source's first video frame
    if (v >= 0 && ain->streams[v]->start_time != AV_NOPTS_VALUE)
        start = ain->streams[v]->start_time * av_q2d(ain->streams[v]->time_base);
    for (unsigned i = 0; i < ain->nb_streams; ++i) {
        AVStream* is = ain->streams[i];
        if (is->codecpar->codec_type != AVMEDIA_TYPE_AUDIO) continue;
        AudioTrack t;
        t.in_index = (int)i;
        t.in_tb = is->time_base;
        t.offset = (int64_t)std::llround(start / av_q2d(is->time_base));
        t.copy =
            avformat_query_codec(oc->oformat, is->codecpar->codec_id, FF_COMPLIANCE_NORMAL) == 1;
        t.out = avformat_new_stream(oc.get(), nullptr);
        if (t.copy) {
            avcodec_parameters_copy(t.out->codecpar, is->codecpar);
            t.out->codecpar->codec_tag = 0;
            t.out->time_base = is->time_base;
        } else {
            const AVCodec* d = avcodec_find_decoder(is->codecpar->codec_id);
            const AVCodec* e = avcodec_find_encoder(AV_CODEC_ID_AAC);
            if (!d || !e)
                CV_Error(Error::StsError, format("cannot carry the audio of '%s' into '%s' (no "
                                                 "decoder for it or no AAC encoder)",
                                                 opt.audio_from.c_str(), path.c_str()));
            t.dec.reset(avcodec_alloc_context3(d));
            avcodec_parameters_to_context(t.dec.get(), is->codecpar);
            if (avcodec_open2(t.dec.get(), d, nullptr) < 0)
                CV_Error(Error::StsError, "cannot decode the audio of '" + opt.audio_from + "'");
            t.enc.reset(avcodec_alloc_context3(e));
            t.enc->sample_rate = t.dec->sample_rate;
            av_channel_layout_copy(&t.enc->ch_layout, &t.dec->ch_layout);
            if (t.enc->ch_layout.order == AV_CHANNEL_ORDER_UNSPEC)
                av_channel_layout_default(&t.enc->ch_layout, t.dec->ch_layout.nb_channels);
            t.enc->sample_fmt = AV_SAMPLE_FMT_FLTP;
            t.enc->bit_rate = 192000;
            t.enc->time_base = AVRational{1, t.enc->sample_rate};
            if (oc->oformat->flags & AVFMT_GLOBALHEADER)
                t.enc->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
            if (avcodec_open2(t.enc.get(), e, nullptr) < 0)
                CV_Error(Error::StsError, "cannot open the AAC encoder");
            avcodec_parameters_from_context(t.out->codecpar, t.enc.get());
            t.out->time_base = t.enc->time_base;
            SwrContext* s = nullptr;
            swr_alloc_set_opts2(&s, &t.enc->ch_layout, t.enc->sample_fmt, t.enc->sample_rate,
                                &t.dec->ch_layout, t.dec->sample_fmt, t.dec->sample_rate, 0,
                                nullptr);
            t.swr.reset(s);
            if (!s || swr_init(s) < 0)
                CV_Error(Error::StsError, "cannot resample the audio of '" + opt.audio_from + "'");
            t.fifo.reset(av_audio_fifo_alloc(t.enc->sample_fmt, t.enc->ch_layout.nb_channels,
                                             t.enc->frame_size > 0 ? t.enc->frame_size : 1024));
            std::fprintf(stderr,
                         "vbme: the audio of '%s' (%s) cannot go into '%s' as it is; re-encoded "
                         "to AAC\n",
                         opt.audio_from.c_str(), avcodec_get_name(is->codecpar->codec_id),
                         path.c_str());
        }
        tracks.push_back(std::move(t));
    }
    apkt.reset(av_packet_alloc());
    aframe.reset(av_frame_alloc());
    if (tracks.empty()) {
        ain.reset();
        audio_done = true;
    }
}

void VideoSink::Impl::writeAudioPacket(AudioTrack& t, AVPacket* p) {
    p->pts = p->pts == AV_NOPTS_VALUE ? p->pts : p->pts - t.offset;
    p->dts = p->dts == AV_NOPTS_VALUE ? p->dts : p->dts - t.offset;
    av_packet_rescale_ts(p, t.in_tb, t.out->time_base);
    p->stream_index = t.out->index;
    p->pos = -1;
    const int r = av_interleaved_write_frame(oc.get(), p);
    if (r < 0) CV_Error(Error::StsError, "cannot write audio to '" + path + "': " + avError(r));
}

void VideoSink::Impl::drainAudioEncoder(AudioTrack& t, bool flush) {
    const int fs = t.enc->frame_size > 0 ? t.enc->frame_size : 1024;
    while (av_audio_fifo_size(t.fifo.get()) >= fs ||
           (flush && av_audio_fifo_size(t.fifo.get()) > 0)) {
        const int n = std::min(fs, av_audio_fifo_size(t.fifo.get()));
        FramePtr f(av_frame_alloc());
        f->nb_samples = n;
        f->format = t.enc->sample_fmt;
        f->sample_rate = t.enc->sample_rate;
        av_channel_layout_copy(&f->ch_layout, &t.enc->ch_layout);
        av_frame_get_buffer(f.get(), 0);
        av_audio_fifo_read(t.fifo.get(), (void**)f->data, n);
        f->pts = t.next_pts;
        t.next_pts += n;
        avcodec_send_frame(t.enc.get(), f.get());
        PacketPtr p(av_packet_alloc());
        while (avcodec_receive_packet(t.enc.get(), p.get()) == 0) {
            av_packet_rescale_ts(p.get(), t.enc->time_base, t.out->time_base);
            p->stream_index = t.out->index;
            av_interleaved_write_frame(oc.get(), p.get());
        }
    }
    if (flush) {
        avcodec_send_frame(t.enc.get(), nullptr);
        PacketPtr p(av_packet_alloc());
        while (avcodec_receive_packet(t.enc.get(), p.get()) == 0) {
            av_packet_rescale_ts(p.get(), t.enc->time_base, t.out->time_base);
            p->stream_index = t.out->index;
            av_interleaved_write_frame(oc.get(), p.get());
        }
    }
}

void VideoSink::Impl::reencodeAudio(AudioTrack& t, AVPacket* p) {
    if (avcodec_send_packet(t.dec.get(), p) < 0) return;
    while (avcodec_receive_frame(t.dec.get(), aframe.get()) == 0) {
        if (!t.started) {
            // first output sample: where this frame lies after the shift (may be cut)
            t.started = true;
            const int64_t pts = aframe->pts == AV_NOPTS_VALUE ? 0 : aframe->pts - t.offset;
            t.next_pts =
                std::max<int64_t>(0, av_rescale_q(pts, t.in_tb, AVRational{1, t.enc->sample_rate}));
        }
        const int out_n = swr_get_out_samples(t.swr.get(), aframe->nb_samples);
        std::vector<uint8_t*> planes(t.enc->ch_layout.nb_channels);
        av_samples_alloc(planes.data(), nullptr, t.enc->ch_layout.nb_channels, out_n,
                         t.enc->sample_fmt, 0);
        const int got = swr_convert(t.swr.get(), planes.data(), out_n,
                                    (const uint8_t**)aframe->extended_data, aframe->nb_samples);
        if (got > 0) av_audio_fifo_write(t.fifo.get(), (void**)planes.data(), got);
        av_freep(&planes[0]);
        av_frame_unref(aframe.get());
        drainAudioEncoder(t, false);
    }
}

// Carries the source's audio packets that start before @p until (seconds of the output
// timeline); with @p final, all the rest that start before the video's end.
void VideoSink::Impl::pumpAudio(double until, bool final) {
    if (!ain || audio_done) return;
    for (;;) {
        if (!has_held) {
            if (av_read_frame(ain.get(), apkt.get()) < 0) {
                audio_done = true;
                break;
            }
            bool ours = apkt->pts != AV_NOPTS_VALUE;
            if (ours) {
                ours = false;
                for (auto& tr : tracks)
                    if (tr.in_index == apkt->stream_index) ours = true;
            }
            if (!ours) {
                av_packet_unref(apkt.get());
                continue;
            }
            has_held = true;
        }
        AudioTrack* t = nullptr;
        for (auto& tr : tracks)
            if (tr.in_index == apkt->stream_index) t = &tr;
        const double start = (apkt->pts - t->offset) * av_q2d(t->in_tb);
        const double dur = apkt->duration * av_q2d(t->in_tb);
        if (!final && start >= until) break;  // held for later
        has_held = false;
        if (start + dur < 0 || (final && start >= next_end)) {
            av_packet_unref(apkt.get());  // before the first frame or after the last
            continue;
        }
        if (t->copy)
            writeAudioPacket(*t, apkt.get());
        else
            reencodeAudio(*t, apkt.get());
        av_packet_unref(apkt.get());
    }
}

void VideoSink::Impl::encode(AVFrame* f) {
    int r = avcodec_send_frame(enc.get(), f);
    if (r < 0) CV_Error(Error::StsError, "encoding '" + path + "' failed: " + avError(r));
    for (;;) {
        r = avcodec_receive_packet(enc.get(), pkt.get());
        if (r == AVERROR(EAGAIN) || r == AVERROR_EOF) break;
        if (r < 0) CV_Error(Error::StsError, "encoding '" + path + "' failed: " + avError(r));
        if (rate_floor && pkt->pts != AV_NOPTS_VALUE && pkt->pts >= crf_since) {
            rate_bytes += pkt->size;
            if (pkt_first == AV_NOPTS_VALUE || pkt->pts < pkt_first) pkt_first = pkt->pts;
            if (pkt_end == AV_NOPTS_VALUE || pkt->pts > pkt_end) pkt_end = pkt->pts;
        }
        av_packet_rescale_ts(pkt.get(), enc->time_base, vst->time_base);
        pkt->stream_index = vst->index;
        r = av_interleaved_write_frame(oc.get(), pkt.get());
        if (r < 0) CV_Error(Error::StsError, "writing '" + path + "' failed: " + avError(r));
    }
}

// The bit-rate floor: four times per second of video, once the packets of at least 0.25 s of
// frames sent at the current CRF are out (they lag the frames by x264's look-ahead), their rate
// is compared with 1.1 x min_bitrate (the margin covers the start, encoded at the starting
// CRF). H.264's bit rate roughly halves per +6 CRF, so the CRF moves by
// 6 log2(rate / target), kept between 1 and the CRF asked for; the change applies to the frames
// x264 has not encoded yet, those in its look-ahead included.
void VideoSink::Impl::adjustRate(double seconds, int64_t pts) {
    if (!rate_floor || seconds < next_rate_check) return;
    next_rate_check = seconds + 0.25;
    if (pkt_first == AV_NOPTS_VALUE || rate_bytes == 0) return;
    const double span = (pkt_end - pkt_first) * av_q2d(enc->time_base) + 1.0 / fps;
    if (span < 0.25) return;
    const double rate = rate_bytes * 8.0 / span, target = 1.1 * (double)opt.min_bitrate;
    const double crf =
        std::max(1.0, std::min((double)opt.crf, crf_now + 6.0 * std::log2(rate / target)));
    if (std::abs(crf - crf_now) < 0.5) return;
    if (av_opt_set_double(enc->priv_data, "crf", crf, 0) < 0) {
        rate_floor = false;
        return;
    }
    crf_now = crf;
    crf_since = pts;
    rate_bytes = 0;
    pkt_first = pkt_end = AV_NOPTS_VALUE;
}

VideoSink::~VideoSink() {
    // Without close() the partial file is removed by AtomicFile's destructor.
    Impl& m = *impl_;
    if (m.progress) m.progress->finish();
    m.oc.reset();
}

void VideoSink::write(InputArray frame) {
    write(frame, impl_->count / impl_->fps);
}

void VideoSink::write(InputArray _frame, double seconds) {
    Impl& m = *impl_;
    CV_Assert(!m.closed);
    Mat frame = _frame.getMat();
    const bool ok_type =
        m.color ? (frame.type() == CV_8UC3 || frame.type() == CV_16UC3) : frame.type() == CV_8UC1;
    if (frame.size() != m.size || !ok_type || (m.count > 0 && (frame.depth() == CV_16U) != m.deep))
        CV_Error(Error::StsBadArg,
                 format("frame %d has size %dx%d type %d, expected %dx%d %s", m.count, frame.cols,
                        frame.rows, frame.type(), m.size.width, m.size.height,
                        m.color ? (m.count > 0 ? (m.deep ? "16UC3" : "8UC3") : "8UC3 or 16UC3")
                                : "8UC1"));
    if (m.count > 0 && !(seconds > m.last_t))
        CV_Error(Error::StsBadArg, format("frame %d: time %.6f s does not follow %.6f s", m.count,
                                          seconds, m.last_t));
    if (m.count == 0) m.deep = frame.depth() == CV_16U;
    if (m.sequence) {
        const std::string name = format(m.path.c_str(), m.count);
        if (m.seq_codec == "png") {
            Mat f16 = frame;
            if (f16.depth() == CV_8U) f16.convertTo(f16, CV_16U, 257.0);
            imwriteAtomic(name, f16);
        } else if (m.seq_codec == "exr") {
            // linear half float through the sRGB curve, encoded by FFmpeg's EXR encoder
            Mat bgr = frame.channels() == 1 ? Mat() : frame;
            if (frame.channels() == 1) cvtColor(frame, bgr, COLOR_GRAY2BGR);
            const double scale = bgr.depth() == CV_16U ? 1.0 / 65535 : 1.0 / 255;
            const AVCodec* ec = avcodec_find_encoder(AV_CODEC_ID_EXR);
            if (!ec) CV_Error(Error::StsError, "FFmpeg's EXR encoder is not available");
            CodecPtr ctx(avcodec_alloc_context3(ec));
            ctx->width = m.size.width;
            ctx->height = m.size.height;
            ctx->pix_fmt = AV_PIX_FMT_GBRPF32LE;
            ctx->time_base = AVRational{1, 1};
            av_opt_set(ctx->priv_data, "format", "half", 0);
            av_opt_set(ctx->priv_data, "compression", "zip16", 0);
            if (avcodec_open2(ctx.get(), ec, nullptr) < 0)
                CV_Error(Error::StsError, "cannot open FFmpeg's EXR encoder");
            FramePtr f(av_frame_alloc());
            f->format = AV_PIX_FMT_GBRPF32LE;
            f->width = m.size.width;
            f->height = m.size.height;
            av_frame_get_buffer(f.get(), 0);
            std::vector<float> lut(bgr.depth() == CV_16U ? 65536 : 256);
            for (size_t i = 0; i < lut.size(); ++i)
                lut[i] = (float)srgbDecode(i * scale);
            for (int y = 0; y < m.size.height; ++y) {
                float* g = (float*)(f->data[0] + y * f->linesize[0]);
                float* b = (float*)(f->data[1] + y * f->linesize[1]);
                float* r = (float*)(f->data[2] + y * f->linesize[2]);
                for (int x = 0; x < m.size.width; ++x) {
                    int v[3];
                    if (bgr.depth() == CV_16U) {
                        const Vec3w p = bgr.at<Vec3w>(y, x);
                        v[0] = p[0], v[1] = p[1], v[2] = p[2];
                    } else {
                        const Vec3b p = bgr.at<Vec3b>(y, x);
                        v[0] = p[0], v[1] = p[1], v[2] = p[2];
                    }
                    b[x] = lut[v[0]];
                    g[x] = lut[v[1]];
                    r[x] = lut[v[2]];
                }
            }
            PacketPtr p(av_packet_alloc());
            if (avcodec_send_frame(ctx.get(), f.get()) < 0 ||
                avcodec_receive_packet(ctx.get(), p.get()) < 0)
                CV_Error(Error::StsError, "EXR encoding of '" + name + "' failed");
            AtomicFile af(name);
            {
                std::ofstream o(af.tempPath(), std::ios::binary);
                o.write((const char*)p->data, p->size);
                if (!o) CV_Error(Error::StsError, "cannot write '" + af.tempPath() + "'");
            }
            af.commit();
        } else {
            imwriteAtomic(name, frame);
        }
    } else {
        const double tick = av_q2d(m.videoTimeBase());
        if (m.count > 0 &&
            (int64_t)std::llround(seconds / tick) <= (int64_t)std::llround(m.last_t / tick))
            CV_Error(Error::StsBadArg,
                     format("frame %d: time %.6f s is within one tick of the previous frame",
                            m.count, seconds));
        if (m.trialPending()) {
            // held until the quality trial has chosen the CRF
            m.held.emplace_back(frame.clone(), seconds);
            if ((int)m.held.size() >= m.opt.quality_trial_frames) m.flushHeld();
        } else {
            m.encodeVideoFrame(frame, seconds);
        }
    }
    m.last_t = seconds;
    ++m.count;
    if (m.progress) m.progress->tick();
}

void VideoSink::close() {
    Impl& m = *impl_;
    if (m.closed) return;
    if (m.progress) m.progress->finish();
    if (m.sequence) {
        m.closed = true;
        return;
    }
    if (!m.held.empty()) m.flushHeld();   // a video shorter than the quality trial
    if (!m.opened) m.openEncoder(false);  // an empty video: header and trailer only
    m.encode(nullptr);
    m.closed = true;
    m.pumpAudio(0, true);  // the rest, cut at the video's end
    for (auto& t : m.tracks)
        if (!t.copy) {
            t.started = true;
            avcodec_send_packet(t.dec.get(), nullptr);
            while (avcodec_receive_frame(t.dec.get(), m.aframe.get()) == 0)
                av_frame_unref(m.aframe.get());
            m.drainAudioEncoder(t, true);
        }
    int r = av_write_trailer(m.oc.get());
    if (r < 0) CV_Error(Error::StsError, "finishing '" + m.path + "' failed: " + avError(r));
    avio_closep(&m.oc->pb);
    m.oc.reset();
    m.file->commit();
}

int VideoSink::count() const {
    return impl_->count;
}

VideoSinkOptions sinkOptionsFrom(const VideoReader& in, const std::string& out_path,
                                 const VideoSinkOptions& base) {
    VideoSinkOptions o = base;
    const bool out_video = out_path.find('%') == std::string::npos;
    if (in.isImageSequence() || !out_video) return o;
    if (o.audio_from.empty() && in.audioStreams() > 0) o.audio_from = in.source();
    if (o.time_base[0] <= 0 || o.time_base[1] <= 0) o.time_base = in.timeBase();
    const VideoColorInfo c = in.colorInfo();
    if (!c.isHdr()) {
        if (c.primaries != AVCOL_PRI_UNSPECIFIED && c.primaries != AVCOL_PRI_RESERVED0)
            o.color.primaries = c.primaries;
        if (c.transfer != AVCOL_TRC_UNSPECIFIED && c.transfer != AVCOL_TRC_RESERVED0)
            o.color.transfer = c.transfer;
        if (c.matrix != AVCOL_SPC_UNSPECIFIED && c.matrix != AVCOL_SPC_RGB)
            o.color.matrix = c.matrix;
    }
    if (!in.conversion().empty())
        o.metadata.emplace_back("comment", "vbme: input " + in.conversion());
    // the input's bit rate as a floor when it was coded lossily (a lossless input's rate says
    // nothing about the quality a lossy output needs)
    if (o.bitrate == 0 && o.min_bitrate == 0 && in.bitRate() > 0) {
        const AVCodec* dc = avcodec_find_decoder_by_name(in.codecName().c_str());
        const AVCodecDescriptor* d = dc ? avcodec_descriptor_get(dc->id) : nullptr;
        if (d && (d->props & AV_CODEC_PROP_LOSSY)) o.min_bitrate = in.bitRate();
    }
    return o;
}

}  // namespace vbme
}  // namespace cv
