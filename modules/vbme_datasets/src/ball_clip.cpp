// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/datasets/ball_clip.hpp"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/core/response.hpp"

namespace cv {
namespace vbme {

namespace {

// Linear RGB from hue (degrees), saturation, value, for the palette.
Vec3f hsvToLinearRgb(float h, float s, float v) {
    const float c = v * s, hp = std::fmod(h / 60.f, 6.f),
                x = c * (1 - std::fabs(std::fmod(hp, 2.f) - 1));
    Vec3f rgb = hp < 1   ? Vec3f(c, x, 0)
                : hp < 2 ? Vec3f(x, c, 0)
                : hp < 3 ? Vec3f(0, c, x)
                : hp < 4 ? Vec3f(0, x, c)
                : hp < 5 ? Vec3f(x, 0, c)
                         : Vec3f(c, 0, x);
    rgb += Vec3f::all(v - c);
    for (int i = 0; i < 3; ++i)
        rgb[i] = linearize(rgb[i], Response::SRGB);
    return rgb;
}

const float kPi = 3.14159265358979f;

}  // namespace

SyntheticBallClip::Params::Params() = default;

SyntheticBallClip::SyntheticBallClip(const Params& p) : params_(p) {
    CV_Assert(p.size.width >= 32 && p.size.height >= 32 && p.frames > 0);
    // Background: tiles of colours away from the ball's hue (greens, blues, purples, greys),
    // modulated by smooth waves and fine fixed grain: texture for the colour model to learn.
    RNG rng(p.seed);
    const float scale = p.size.width / 640.f;
    const int tile = std::max(8, cvRound(48 * scale));
    background_.create(p.size, CV_32FC3);
    const int tx = p.size.width / tile + 2, ty = p.size.height / tile + 2;
    std::vector<Vec3f> colours(tx * ty);
    for (auto& c : colours) {
        const bool grey = rng.uniform(0.f, 1.f) < 0.3f;
        const float hue = rng.uniform(100.f, 290.f);
        c = hsvToLinearRgb(hue, grey ? 0.05f : rng.uniform(0.25f, 0.7f), rng.uniform(0.35f, 0.85f));
    }
    Mat grain(p.size, CV_32F);
    rng.fill(grain, RNG::NORMAL, 0, 0.04);
    GaussianBlur(grain, grain, Size(0, 0), 0.8);
    for (int y = 0; y < p.size.height; ++y)
        for (int x = 0; x < p.size.width; ++x) {
            const Vec3f c = colours[(y / tile) * tx + (x / tile)];
            const float wave =
                0.85f + 0.15f * std::sin(x * 0.02f / scale) * std::cos(y * 0.03f / scale);
            background_.at<Vec3f>(y, x) = c * (wave * (1.f + grain.at<float>(y, x)));
        }
    if (p.same_hue_distractor) {
        // An orange patch in the top-left corner, away from the ball's path.
        const int s = cvRound(70 * scale), m = cvRound(12 * scale);
        background_(Rect(m, m, s, s))
            .setTo(Scalar(p.ball_rgb[0] * 0.6f, p.ball_rgb[1] * 0.6f, p.ball_rgb[2] * 0.6f));
    }
}

Disk SyntheticBallClip::truth(int i) const {
    const Params& p = params_;
    const float t = p.frames > 1 ? float(i) / (p.frames - 1) : 0.f;
    const float w = (float)p.size.width, h = (float)p.size.height, scale = w / 640.f;
    const float cx = w * (0.5f + 0.28f * std::sin(2 * kPi * t));
    const float cy = h * (0.55f + 0.22f * std::sin(4 * kPi * t + 0.6f));
    const float r = scale * (p.radius_min + (p.radius_max - p.radius_min) *
                                                (0.5f + 0.5f * std::sin(2 * kPi * t * 1.5f)));
    return Disk(Point2f(cx, cy), r);
}

Mat SyntheticBallClip::frame(int i, Disk* truth_out) const {
    const Params& p = params_;
    const bool hidden = i >= p.hide_from && i < p.hide_to;
    const Disk d = truth(i);
    if (truth_out) *truth_out = hidden ? Disk(d.center, 0.f) : d;
    const float t = p.frames > 1 ? float(i) / (p.frames - 1) : 0.f;
    // Illumination colour, optionally drifting from neutral to warm-green over the clip.
    const Vec3f light = Vec3f(1.f, 1.f, 1.f) + p.light_drift * t * Vec3f(-0.35f, 0.25f, -0.45f);
    Mat lin = background_.clone();
    for (int y = 0; y < lin.rows; ++y)
        for (int x = 0; x < lin.cols; ++x) {
            Vec3f& c = lin.at<Vec3f>(y, x);
            c = c.mul(light);
        }

    auto drawBall = [&](const Disk& b, const Vec3f& albedo, float spec) {
        // Lambertian + Blinn-Phong sphere lit from the upper left, 4×4 supersampled coverage.
        const Vec3f L =
            normalize(Vec3f(-0.45f, -0.65f, -0.6f));  // towards the light (camera frame)
        const Vec3f H = normalize(normalize(p.highlight_dir) + Vec3f(0, 0, -1));
        const int x0 = std::max(0, (int)std::floor(b.center.x - b.radius - 1));
        const int x1 = std::min(lin.cols - 1, (int)std::ceil(b.center.x + b.radius + 1));
        const int y0 = std::max(0, (int)std::floor(b.center.y - b.radius - 1));
        const int y1 = std::min(lin.rows - 1, (int)std::ceil(b.center.y + b.radius + 1));
        for (int y = y0; y <= y1; ++y)
            for (int x = x0; x <= x1; ++x) {
                Vec3f sum(0, 0, 0);
                int covered = 0;
                for (int sy = 0; sy < 4; ++sy)
                    for (int sx = 0; sx < 4; ++sx) {
                        const float px = x - 0.375f + 0.25f * sx, py = y - 0.375f + 0.25f * sy;
                        const float dx = (px - b.center.x) / b.radius,
                                    dy = (py - b.center.y) / b.radius;
                        const float q = 1 - dx * dx - dy * dy;
                        if (q < 0) continue;
                        const Vec3f n(dx, dy, -std::sqrt(q));
                        const float ndl = std::max(0.f, n.dot(L));
                        const float s = spec * std::pow(std::max(0.f, n.dot(H)), 60.f) * 3.f;
                        sum += (albedo * (0.12f + 0.95f * ndl) + Vec3f::all(s)).mul(light);
                        ++covered;
                    }
                if (!covered) continue;
                Vec3f& c = lin.at<Vec3f>(y, x);
                c = c * (1 - covered / 16.f) + sum * (1.f / 16.f);
            }
    };
    if (p.distractor) {
        // A blue ball crossing the frame the other way.
        const float w = (float)p.size.width, h = (float)p.size.height;
        const Disk blue(Point2f(w * (0.85f - 0.7f * t), h * (0.3f + 0.1f * std::cos(3 * kPi * t))),
                        d.radius * 0.8f);
        drawBall(blue, hsvToLinearRgb(220.f, 0.8f, 0.8f), 0.6f * p.highlight);
    }
    if (!hidden) drawBall(d, p.ball_rgb, p.highlight);

    Mat out;
    encode(lin, out, Response::SRGB, CV_32F);
    out.convertTo(out, CV_32F, 255.0);
    if (p.noise_sigma > 0) {
        Mat noise(out.size(), CV_32FC3);
        RNG rng((uint64)p.seed * 7919u + (uint64)i * 104729u + 17u);
        rng.fill(noise, RNG::NORMAL, 0, p.noise_sigma);
        out += noise;
    }
    Mat rgb8, bgr8;
    out.convertTo(rgb8, CV_8U);
    cvtColor(rgb8, bgr8, COLOR_RGB2BGR);
    return bgr8;
}

}  // namespace vbme
}  // namespace cv
