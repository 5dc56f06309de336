// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// read / write / check of the video option structs (VideoColorInfo, VideoReadOptions,
// VideoSinkOptions).
#include "opencv2/vbme/core/params.hpp"
#include "opencv2/vbme/core/video.hpp"

namespace cv {
namespace vbme {

void VideoColorInfo::read(const FileNode& fn) {
    ParamsIn in(fn, "video colour");
    in("primaries", primaries);
    in("transfer", transfer);
    in("matrix", matrix);
    in("range", range);
    in.finish();
    check();
}

void VideoColorInfo::write(FileStorage& fs) const {
    fs << "primaries" << primaries << "transfer" << transfer << "matrix" << matrix << "range"
       << range;
}

void VideoColorInfo::check() const {
    // H.273 codes are 8-bit; range is 0..2 (AVColorRange without the count)
    checkParam(primaries >= 0 && primaries <= 255, "video colour", "primaries", primaries,
               "an H.273 code 0..255");
    checkParam(transfer >= 0 && transfer <= 255, "video colour", "transfer", transfer,
               "an H.273 code 0..255");
    checkParam(matrix >= 0 && matrix <= 255, "video colour", "matrix", matrix,
               "an H.273 code 0..255");
    checkParam(range >= 0 && range <= 2, "video colour", "range", range,
               "0 (unspecified), 1 (limited) or 2 (full)");
}

void VideoReadOptions::read(const FileNode& fn) {
    ParamsIn in(fn, "video read options");
    in("depth", depth);
    in.choice("hdr", hdr, {{"to_sdr", HdrPolicy::ToSdr}, {"refuse", HdrPolicy::Refuse}});
    in("purpose", purpose);
    in("log", log);
    in("strict", strict);
    in.finish();
    check();
}

void VideoReadOptions::write(FileStorage& fs) const {
    fs << "depth" << depth << "hdr" << (hdr == HdrPolicy::Refuse ? "refuse" : "to_sdr");
    fs << "purpose" << purpose << "log" << (int)log << "strict" << (int)strict;
}

void VideoReadOptions::check() const {
    checkParam(depth == CV_8U || depth == CV_16U, "video read options", "depth", depth,
               "CV_8U (0) or CV_16U (2)");
    checkParam(hdr == HdrPolicy::ToSdr || hdr == HdrPolicy::Refuse, "video read options", "hdr",
               (double)hdr, "HdrPolicy::ToSdr or HdrPolicy::Refuse");
}

void VideoSinkOptions::read(const FileNode& fn) {
    ParamsIn in(fn, "video sink options");
    in("codec", codec);
    in("crf", crf);
    in("preset", preset);
    in("bitrate", bitrate);
    in("min_bitrate", min_bitrate);
    in("min_psnr", min_psnr);
    in("quality_trial_frames", quality_trial_frames);
    in("pix_fmt", pix_fmt);
    in("full_chroma", full_chroma);
    in("color", color);
    in("audio_from", audio_from);
    in("time_base", time_base);
    if (const FileNode n = in.take("metadata"); !n.empty()) {
        if (!n.isSeq())
            CV_Error(Error::StsParseError,
                     "video sink options.metadata: expected a list of [key, value]");
        metadata.clear();
        for (const FileNode& kv : n) {
            if (!kv.isSeq() || kv.size() != 2 || !kv[0].isString() || !kv[1].isString())
                CV_Error(Error::StsParseError,
                         "video sink options.metadata: expected a list of [key, value] strings");
            metadata.emplace_back((std::string)kv[0], (std::string)kv[1]);
        }
    }
    in("progress", progress);
    in("expected_frames", expected_frames);
    in.finish();
    check();
}

void VideoSinkOptions::write(FileStorage& fs) const {
    fs << "codec" << codec << "crf" << crf << "preset" << preset << "bitrate" << (double)bitrate;
    fs << "min_bitrate" << (double)min_bitrate;
    fs << "min_psnr" << min_psnr << "quality_trial_frames" << quality_trial_frames;
    fs << "pix_fmt" << pix_fmt;
    fs << "full_chroma" << (int)full_chroma;
    fs << "color"
       << "{";
    color.write(fs);
    fs << "}";
    fs << "audio_from" << audio_from;
    fs << "time_base"
       << "[:" << time_base[0] << time_base[1] << "]";
    fs << "metadata"
       << "[";
    for (const auto& kv : metadata)
        fs << "[:" << kv.first << kv.second << "]";
    fs << "]";
    fs << "progress" << progress << "expected_frames" << (double)expected_frames;
}

void VideoSinkOptions::check() const {
    const char* w = "video sink options";
    if (!(codec.empty() || codec == "h264" || codec == "h265" || codec == "prores" ||
          codec == "ffv1" || codec == "png" || codec == "exr"))
        CV_Error(Error::StsBadArg, std::string(w) + ".codec = '" + codec +
                                       "': expected \"\", h264, h265, prores, ffv1, png "
                                       "or exr");
    checkParam(crf >= 0 && crf <= 51, w, "crf", crf, "0..51");
    checkParam(bitrate >= 0, w, "bitrate", (double)bitrate, ">= 0 bit/s (0: use the CRF)");
    checkParam(min_bitrate >= 0, w, "min_bitrate", (double)min_bitrate, ">= 0 bit/s (0: none)");
    checkParam(min_psnr <= 100, w, "min_psnr", min_psnr,
               "<= 100 dB (0: off; negative: the default, 48 for full_chroma, else off)");
    checkParam(quality_trial_frames >= 1 && quality_trial_frames <= 250, w, "quality_trial_frames",
               quality_trial_frames, "1..250");
    checkParam((time_base[0] == 0 && time_base[1] == 0) || (time_base[0] > 0 && time_base[1] > 0),
               w, "time_base", time_base[0],
               "{0, 0} (automatic) or two positive numbers {num, den}");
    checkParam(expected_frames >= 0, w, "expected_frames", (double)expected_frames,
               ">= 0 (0: unknown)");
    color.check();
}

}  // namespace vbme
}  // namespace cv
