// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CORE_VIDEO_HPP
#define OPENCV_VBME_CORE_VIDEO_HPP

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_core
//! @{

/** @brief Colour description of a video stream, as ITU-T H.273 code points (the numbers
FFmpeg, H.264/H.265 VUI and MP4/MKV colour boxes use).

primaries: 1 BT.709, 9 BT.2020, 2 unspecified; transfer: 1 BT.709, 13 sRGB (IEC 61966-2-1),
16 PQ (SMPTE ST 2084), 18 HLG (ARIB STD-B67), 2 unspecified; matrix: 1 BT.709, 5/6 BT.601,
9 BT.2020 non-constant luminance, 0 RGB (identity), 2 unspecified; range: 1 limited ("tv"),
2 full ("pc"), 0 unspecified.
*/
struct CV_EXPORTS VideoColorInfo {
    int primaries = 2;  //!< colour primaries code (H.273 Table 2)
    int transfer = 2;   //!< transfer characteristics code (H.273 Table 3)
    int matrix = 2;     //!< matrix coefficients code (H.273 Table 4)
    int range = 0;      //!< 0 unspecified, 1 limited (16-235), 2 full (0-255)
    /** @brief True when the transfer is PQ (16) or HLG (18). */
    bool isHdr() const { return transfer == 16 || transfer == 18; }
    /** @brief Names in FFmpeg's words, e.g. "bt2020/arib-std-b67/bt2020nc/tv". */
    std::string describe() const;
    /** @brief The tags vbme writes for its own display-encoded frames: BT.709 primaries and
    matrix, sRGB transfer (DESIGN "Colour": renders are re-encoded with the `srgb` response),
    limited range. */
    static VideoColorInfo sdrDefault();
    /** @brief Reads the fields present in the map @p fn (others keep their value); an unknown
    key or a value check() refuses is an error. */
    void read(const FileNode& fn);
    /** @brief Writes every field as `name: value` into the open map of @p fs. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief What a VideoReader does with HDR (PQ or HLG) input. */
enum class HdrPolicy {
    /** Convert to display-referred BT.709 sRGB-encoded frames (tone map documented in
    doc/vbme_core.md, "HDR input"), stating it on stderr. */
    ToSdr,
    /** Refuse with a cv::Exception naming the clip's transfer and what to do. */
    Refuse
};

/** @brief Options of VideoReader. */
struct CV_EXPORTS VideoReadOptions {
    /** Depth of the delivered frames: CV_8U (default) or CV_16U (10/12/16-bit sources keep
    their precision; 8-bit sources are scaled by 257). */
    int depth = CV_8U;
    /** HDR input handling. */
    HdrPolicy hdr = HdrPolicy::ToSdr;
    /** Name of what reads the clip (e.g. "calibrate"), used in the refusal message. */
    std::string purpose;
    /** Print conversions and damaged-frame warnings to stderr (they are also kept in
    VideoReader::notes()). */
    bool log = true;
    /** When true, a frame the decoder reports damaged or missing throws a cv::Exception with
    its index instead of a warning. */
    bool strict = false;

    /** @brief Reads the fields present in the map @p fn (others keep their value); an unknown
    key or a value check() refuses is an error. */
    void read(const FileNode& fn);
    /** @brief Writes every field as `name: value` into the open map of @p fs. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief Reads a video file, a folder of numbered images, or a printf pattern
(`frames/%05d.png`), frame by frame.

Video files are decoded with FFmpeg's libraries (libavformat/libavcodec/libswscale).
Frames are delivered as BGR (CV_8UC3, or CV_16UC3 when VideoReadOptions::depth is CV_16U) in the
orientation a player shows them (the display matrix is honoured), each with its presentation
time (timestamp(); variable frame rate is kept). YUV is converted with the stream's own matrix
and range (unspecified: BT.709 from 720 lines up, else BT.601; limited range). HDR input (PQ,
HLG) is converted to display-referred BT.709 with the sRGB curve, or refused (HdrPolicy).
Damaged data: a frame the decoder reports corrupt is delivered with a warning naming its index;
frames lost entirely (a gap in the timestamps of a constant-rate stream) are replaced by repeats
of the previous frame, with a warning naming their indices, so that later frames keep their
index; with VideoReadOptions::strict either throws, naming the frame index.

Image folders are ordered by the number in the file name, then by name; all images must have
one size. A folder's frame rate is read from an optional `fps.txt` in it, else taken as 30.
*/
class CV_EXPORTS VideoReader {
public:
    /** @brief Opens @p source; throws cv::Exception saying what is wrong (missing, not a
    video, empty folder, HDR refused, …). */
    explicit VideoReader(const std::string& source);
    /** @brief Opens @p source with @p options. */
    VideoReader(const std::string& source, const VideoReadOptions& options);
    ~VideoReader();
    VideoReader(const VideoReader&) = delete;
    VideoReader& operator=(const VideoReader&) = delete;

    /** @brief Reads the next frame; returns false at the end. Throws if a frame in an image
    folder cannot be decoded or differs in size. */
    bool read(OutputArray frame);
    /** @brief Frame rate (frames per second; the average for variable-rate video). */
    double fps() const;
    /** @brief Frame size as shown (after rotation). */
    Size frameSize() const;
    /** @brief Number of frames: exact for image folders, the container's count for videos
    (may be approximate; −1 if unknown). */
    int frameCount() const;
    /** @brief Index of the frame the next read() returns. */
    int position() const;
    /** @brief Whether the source is a folder or pattern of images. */
    bool isImageSequence() const;

    /** @brief Presentation time in seconds of the frame last returned by read(), counted from
    the first frame (0 for it). Image sequences: index / fps. */
    double timestamp() const;
    /** @brief Timestamps of the frames read so far (seconds, as timestamp()). */
    const std::vector<double>& timestamps() const;
    /** @brief Time base of the video stream as {numerator, denominator} (timestamps are
    multiples of it); {1, fps} rounded for image sequences. */
    Vec2i timeBase() const;
    /** @brief Colour description of the source (before any conversion). */
    VideoColorInfo colorInfo() const;
    /** @brief Bits per colour component of the source (8, 10, 12, 16). */
    int bitDepth() const;
    /** @brief Clockwise display rotation applied (0, 90, 180, 270 degrees). */
    int rotation() const;
    /** @brief Number of audio streams in the source (0 for image sequences). */
    int audioStreams() const;
    /** @brief Average bit rate of the video stream in bit/s (0 if unknown). */
    int64 bitRate() const;
    /** @brief Codec name of the video stream (e.g. "h264"; "image" for image sequences). */
    std::string codecName() const;
    /** @brief The conversion applied to the frames, in words ("" when none beyond YUV→BGR). */
    std::string conversion() const;
    /** @brief Warnings and conversions so far (damaged frames, HDR tone mapping, …). */
    const std::vector<std::string>& notes() const;
    /** @brief Indices of frames delivered damaged or repeated in place of lost ones. */
    const std::vector<int>& damagedFrames() const;
    /** @brief The source path as given. */
    const std::string& source() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/** @brief Options of VideoSink. */
struct CV_EXPORTS VideoSinkOptions {
    /** Codec: "" (by the path: `.mp4`/`.mov` → h264, `.mkv`/`.avi` → ffv1, a `%` pattern →
    png), or one of "h264", "h265", "prores", "ffv1" (video files) and "png" (16-bit), "exr"
    (linear half float, through the sRGB curve) for image sequences. */
    std::string codec;
    /** Constant rate factor of h264/h265, 0..51 (lower is better). 14 by default, chosen so
    that encoding loses little against the truth on noisy textured footage (figures in
    doc/vbme_core.md, "Writing", Quality). */
    int crf = 14;
    /** x264/x265 speed preset (doc/vbme_core.md, "Writing": why superfast is the default). */
    std::string preset = "superfast";
    /** When > 0 (h264/h265): average bit rate in bit/s to encode at instead of the CRF (e.g.
    to match an input's rate, VideoReader::bitRate()). */
    int64 bitrate = 0;
    /** When > 0 (h264, CRF mode): the lowest average bit rate in bit/s wanted, e.g. the
    input's (set by sinkOptionsFrom() for a lossy input). The encoder starts at @ref crf; four
    times per second of video the CRF is lowered (never raised above @ref crf) while the rate
    of the packets so far is below 1.1 × this, so the output gets the CRF's rate or this one,
    whichever is higher (doc/vbme_core.md, "Writing", Quality). */
    int64 min_bitrate = 0;
    /** When > 0 (h264/h265, CRF mode): the lowest PSNR in dB of the coding error wanted, that of
    the decoded frames against the frames written, both in the output's pixel format and
    converted back to BGR (so a 4:2:0 conversion's own loss is not counted). Before the first
    frame is encoded, the first @ref quality_trial_frames frames are encoded and decoded at
    @ref crf; while their PSNR is below this, the CRF is lowered (down to 0) and the trial
    repeated, and the video is encoded at the CRF found (never above @ref crf; never 0 for a
    subsampled pixel format such as yuv420p, since x264's CRF 0 is lossless and needs the High
    4:4:4 Predictive profile, which common players do not decode). 0: off (the CRF as given).
    Negative (the default): 48 dB for @ref full_chroma outputs (the overlays), off for the
    others. 48 dB, a coding error of MSE 1.03 levels², costs at most 0.5 dB against any truth
    the frames are 38.9 dB or further from, e.g. sensor noise of σ ≥ 2.9 levels drawn on by an
    overlay, which x264's CRF 14 loses up to 3 dB against; the edits' outputs lose at most
    0.31 dB at plain CRF 14 and would cost 4–6× the bits at the floor (figures in
    doc/vbme_core.md, "Writing", Quality). */
    double min_psnr = -1;
    /** Frames of the trial encodes of @ref min_psnr (fewer if the video is shorter); the first,
    a keyframe coded finer than the frames that follow it, is not scored unless it is the
    only one. */
    int quality_trial_frames = 4;
    /** Pixel format of the encoded video: "" (default: yuv420p for h264/h265, yuv422p10le for
    prores, bgr0 for ffv1) or e.g. "yuv444p", "yuv420p10le". */
    std::string pix_fmt;
    /** With an empty @ref pix_fmt, h264/h265 are encoded with full chroma (yuv444p, 16-bit
    frames yuv444p10le) instead of 4:2:0. Set for overlays: 4:2:0 blurs the colour of their
    one-pixel marks and text (doc/vbme_core.md, "Writing", Quality). */
    bool full_chroma = false;
    /** Colour tags written to the stream (frames are not converted). */
    VideoColorInfo color = VideoColorInfo::sdrDefault();
    /** A video whose audio streams are carried into the output (stream copy; re-encoded to AAC
    when the container cannot hold the codec), aligned to its first video frame and cut at
    the end of the video written. "" for none. Ignored for image sequences. */
    std::string audio_from;
    /** Time base {num, den} of the output timestamps ({0,0}: 1/90000, or 1/fps when frames are
    written without timestamps). */
    Vec2i time_base = Vec2i(0, 0);
    /** Container metadata (key, value), e.g. {"comment", "HLG converted to BT.709"}. */
    std::vector<std::pair<std::string, std::string>> metadata;
    /** When not empty, progress is reported under this label, out of @ref expected_frames. */
    std::string progress;
    /** Frames expected, for progress (0: unknown). */
    int64 expected_frames = 0;

    /** @brief Reads the fields present in the map @p fn (others keep their value); an unknown
    key or a value check() refuses is an error. */
    void read(const FileNode& fn);
    /** @brief Writes every field as `name: value` into the open map of @p fs. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief Writes frames to a video file or to numbered images, completed atomically.

Video files are encoded with FFmpeg's libraries: by default `.mp4`/`.mov` are H.264 (libx264,
CRF 14, yuv420p, BT.709 tags), `.mkv`/`.avi` lossless FFV1; see VideoSinkOptions for other
codecs, quality, colour tags, timestamps and audio. A path containing `%` (e.g.
`out/%05d.png`) writes numbered images (8-bit PNG by default, 16-bit PNG with codec "png",
half-float linear EXR with codec "exr"), each under a temporary name renamed when written. A
video file is written under a temporary name and renamed by close(). If the writer is
destroyed without close(), the partial video is deleted.
*/
class CV_EXPORTS VideoSink {
public:
    /** @brief Opens @p path for frames of @p size at @p fps (8-bit BGR, or 8-bit gray when
    @p color is false). Throws cv::Exception if no encoder can write it. */
    VideoSink(const std::string& path, double fps, Size size, bool color = true);
    /** @brief Opens @p path with @p options; frames are BGR CV_8UC3 or CV_16UC3. */
    VideoSink(const std::string& path, double fps, Size size, const VideoSinkOptions& options);
    ~VideoSink();
    VideoSink(const VideoSink&) = delete;
    VideoSink& operator=(const VideoSink&) = delete;

    /** @brief Appends a frame (must have the size given at opening) at time count() / fps. */
    void write(InputArray frame);
    /** @brief Appends a frame shown at @p seconds (from the first frame; increasing). */
    void write(InputArray frame, double seconds);
    /** @brief Finishes the file (flushes the encoder, writes the remaining audio) and renames
    it into place. */
    void close();
    /** @brief Frames written so far. */
    int count() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/** @brief @p base completed for writing, to @p out_path, frames read from @p in.

Sets what the output should carry from the input: its audio (`audio_from`, when @p in is a
video file with audio and @p out_path a video file), its colour tags (the input's primaries,
transfer and matrix when the input is SDR and tagged; vbme's BT.709/sRGB default after an HDR
conversion), its time base (so that VideoSink::write(frame, in.timestamp()) keeps every
timestamp to the tick), and a `comment` naming the input's conversion, if any. Fields of
@p base already set (a non-empty audio_from, a time base) are kept.
*/
CV_EXPORTS VideoSinkOptions sinkOptionsFrom(const VideoReader& in, const std::string& out_path,
                                            const VideoSinkOptions& base = VideoSinkOptions());

/** @brief Converts one HDR pixel value to vbme's working space, as VideoReader does.

@p rgb2020 holds non-linear R'G'B' in [0, 1] (BT.2020 primaries) encoded with @p transfer (16 PQ
or 18 HLG); returns linear BT.709 RGB relative to reference white (1.0 = 203 cd/m², HDR
reference white of ITU-R BT.2408), after the gamut conversion, clipping of negatives and the
highlight knee, but before the sRGB curve. Exposed for tests and documentation.
*/
CV_EXPORTS Vec3f hdrToLinear709(const Vec3f& rgb2020, int transfer);
/** @brief The highlight roll-off applied to the largest component @p m: identity up to 0.8,
then 0.8 + 0.2·(1 − exp(−(m − 0.8)/0.2)) (continuous slope, approaches 1). */
CV_EXPORTS float hdrKnee(float m);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
