// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/track/disk.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "disk_fitter.hpp"
#include "opencv2/vbme/core/utility.hpp"

namespace cv {
namespace vbme {

namespace detail {

void DiskFitter::setVotes(const Mat& votes) {
    CV_Assert(votes.type() == CV_8SC1 || votes.type() == CV_8UC1);
    size_ = votes.size();
    prefix_.create(votes.rows, votes.cols + 1, CV_32S);
    row_count_.assign(votes.rows, 0);
    col_count_.assign(votes.cols, 0);
    total_ = 0;
    const bool binary = votes.type() == CV_8UC1;
    for (int y = 0; y < votes.rows; ++y) {
        int* p = prefix_.ptr<int>(y);
        int acc = 0, pos = 0;
        p[0] = 0;
        if (binary) {
            const uchar* v = votes.ptr<uchar>(y);
            for (int x = 0; x < votes.cols; ++x) {
                const int s = v[x] ? 1 : -1;
                acc += s;
                p[x + 1] = acc;
                if (s > 0) {
                    ++pos;
                    ++col_count_[x];
                }
            }
        } else {
            const schar* v = votes.ptr<schar>(y);
            for (int x = 0; x < votes.cols; ++x) {
                acc += v[x];
                p[x + 1] = acc;
                if (v[x] > 0) {
                    ++pos;
                    ++col_count_[x];
                }
            }
        }
        row_count_[y] = pos;
        total_ += acc;
    }
}

int DiskFitter::sumInside(float cx, float cy, float r) const {
    if (r <= 0) return 0;
    const int y0 = std::max(0, (int)std::ceil(cy - r));
    const int y1 = std::min(size_.height - 1, (int)std::floor(cy + r));
    const float r2 = r * r;
    int sum = 0;
    for (int y = y0; y <= y1; ++y) {
        const float dy = y - cy;
        const float w2 = r2 - dy * dy;
        if (w2 < 0) continue;
        const float w = std::sqrt(w2);
        const int x0 = std::max(0, (int)std::ceil(cx - w));
        const int x1 = std::min(size_.width - 1, (int)std::floor(cx + w));
        if (x0 > x1) continue;
        const int* p = prefix_.ptr<int>(y);
        sum += p[x1 + 1] - p[x0];
    }
    return sum;
}

Disk DiskFitter::fit(const Disk& init, const DiskFitParams& params) const {
    Disk d = init;
    if (d.radius < params.min_radius) d.radius = params.min_radius;
    if (params.max_radius > 0 && d.radius > params.max_radius)
        d.radius = std::max(params.min_radius, params.max_radius);
    int best = sumInside(d.center.x, d.center.y, d.radius);
    const float min_step = std::max(params.min_step, 1.f / 64);
    int moves = 0;
    for (float step = 1.f; step >= min_step * 0.999f; step *= 0.5f) {
        for (;;) {
            static const float dx[6] = {1, -1, 0, 0, 0, 0};
            static const float dy[6] = {0, 0, 1, -1, 0, 0};
            static const float dr[6] = {0, 0, 0, 0, 1, -1};
            int best_k = -1, best_val = best;
            for (int k = 0; k < 6; ++k) {
                const float r = d.radius + dr[k] * step;
                if (r < params.min_radius) continue;
                if (params.max_radius > 0 && r > params.max_radius) continue;
                const int v = sumInside(d.center.x + dx[k] * step, d.center.y + dy[k] * step, r);
                if (v > best_val) {
                    best_val = v;
                    best_k = k;
                }
            }
            if (best_k < 0 || ++moves > params.max_iterations) break;
            d.center.x += dx[best_k] * step;
            d.center.y += dy[best_k] * step;
            d.radius += dr[best_k] * step;
            best = best_val;
        }
    }
    return d;
}

static int medianIndex(const std::vector<int>& counts, int total) {
    // The smallest index whose cumulative count reaches half of the total.
    int acc = 0;
    for (size_t i = 0; i < counts.size(); ++i) {
        acc += counts[i];
        if (2 * acc >= total) return (int)i;
    }
    return (int)counts.size() - 1;
}

Disk DiskFitter::initial() const {
    int n = 0;
    for (int c : row_count_)
        n += c;
    if (n == 0) return Disk();
    int ymin = -1, ymax = -1, xmin = -1, xmax = -1;
    for (int y = 0; y < (int)row_count_.size(); ++y)
        if (row_count_[y]) {
            if (ymin < 0) ymin = y;
            ymax = y;
        }
    for (int x = 0; x < (int)col_count_.size(); ++x)
        if (col_count_[x]) {
            if (xmin < 0) xmin = x;
            xmax = x;
        }
    const float w = float(xmax - xmin + 1), h = float(ymax - ymin + 1);
    return Disk(Point2f((float)medianIndex(col_count_, n), (float)medianIndex(row_count_, n)),
                0.25f * (w + h));
}

}  // namespace detail

void diskMask(Size size, const Disk& d, OutputArray _mask) {
    _mask.create(size, CV_8UC1);
    Mat mask = _mask.getMat();
    mask.setTo(Scalar::all(0));
    if (d.radius <= 0) return;
    const float r2 = d.radius * d.radius;
    const int y0 = std::max(0, (int)std::ceil(d.center.y - d.radius));
    const int y1 = std::min(size.height - 1, (int)std::floor(d.center.y + d.radius));
    for (int y = y0; y <= y1; ++y) {
        const float dy = y - d.center.y;
        const float w2 = r2 - dy * dy;
        if (w2 < 0) continue;
        const float w = std::sqrt(w2);
        const int x0 = std::max(0, (int)std::ceil(d.center.x - w));
        const int x1 = std::min(size.width - 1, (int)std::floor(d.center.x + w));
        if (x0 <= x1) std::memset(mask.ptr<uchar>(y) + x0, 255, x1 - x0 + 1);
    }
}

double maskIoU(InputArray _a, InputArray _b) {
    Mat a = _a.getMat(), b = _b.getMat();
    CV_Assert(a.size() == b.size() && a.type() == CV_8UC1 && b.type() == CV_8UC1);
    Mat ab, aob;
    bitwise_and(a != 0, b != 0, ab);
    bitwise_or(a != 0, b != 0, aob);
    const int u = countNonZero(aob);
    return u == 0 ? 1.0 : double(countNonZero(ab)) / u;
}

double diskQuality(InputArray _mask, const Disk& d) {
    Mat mask = _mask.getMat();
    CV_Assert(mask.type() == CV_8UC1 || mask.type() == CV_8SC1);
    double q = 0;
    for (int y = 0; y < mask.rows; ++y)
        for (int x = 0; x < mask.cols; ++x) {
            const int v =
                mask.type() == CV_8UC1 ? (mask.at<uchar>(y, x) ? 1 : -1) : mask.at<schar>(y, x);
            q += d.contains(Point2f((float)x, (float)y)) ? v : -v;
        }
    return q;
}

Disk initialDisk(InputArray mask) {
    detail::DiskFitter f;
    f.setVotes(mask.getMat());
    return f.initial();
}

Disk fitDisk(InputArray _mask, const Disk* init, const DiskFitParams& params) {
    Mat mask = _mask.getMat();
    if (mask.empty()) CV_Error(Error::StsBadArg, "fitDisk: empty mask");
    if (mask.type() != CV_8UC1 && mask.type() != CV_8SC1)
        CV_Error(Error::StsBadArg, "fitDisk: expected a CV_8UC1 mask or CV_8SC1 votes");
    detail::DiskFitter f;
    f.setVotes(mask);
    const Disk start = init ? *init : f.initial();
    if (!init && start.radius <= 0) return Disk();
    return f.fit(start, params);
}

Disk refineDisk(InputArray _frame, InputArray _background, const Disk& disk) {
    const Mat I = _frame.getMat(), B = _background.getMat();
    if (I.type() != CV_32FC3 || B.type() != CV_32FC3 || I.size() != B.size())
        CV_Error(Error::StsBadArg,
                 "refineDisk: expected a linear CV_32FC3 frame and background of the same size");
    Point2f c = disk.center;
    const float r = disk.radius;
    if (r < 6) return disk;
    auto at = [](const Mat& m, float x, float y, Vec3f& v) {
        if (x < 0 || y < 0 || x > m.cols - 1.001f || y > m.rows - 1.001f) return false;
        v = bilinear<Vec3f>(m, x, y);
        return true;
    };
    std::vector<Point2f> pts;
    const int kRays = 64;
    for (int k = 0; k < kRays; k++) {
        const float a = (float)(2 * CV_PI * k / kRays), ux = std::cos(a), uy = std::sin(a);
        Vec3f F;
        if (!at(I, c.x + ux * (r - 1.25f), c.y + uy * (r - 1.25f), F)) continue;
        float prev_alpha = 1.f, prev_rho = r - 1.25f, edge = -1;
        bool ok = true;
        for (float rho = r - 1.f; rho <= r + 2.5f; rho += 0.25f) {
            Vec3f v, b;
            if (!at(I, c.x + ux * rho, c.y + uy * rho, v) ||
                !at(B, c.x + ux * rho, c.y + uy * rho, b)) {
                ok = false;
                break;
            }
            const Vec3f fb = F - b;
            const float den = fb.dot(fb);
            if (den < 0.02f * 0.02f) {
                ok = false;
                break;
            }
            const float alpha = (v - b).dot(fb) / den;
            if (alpha < 0.5f) {
                edge = prev_rho +
                       (rho - prev_rho) * (prev_alpha - 0.5f) / std::max(1e-6f, prev_alpha - alpha);
                break;
            }
            prev_alpha = alpha;
            prev_rho = rho;
        }
        if (ok && edge > 0) pts.push_back(Point2f(c.x + ux * edge, c.y + uy * edge));
    }
    if ((int)pts.size() < 16) return disk;
    // x² + y² + D x + E y + G = 0, solved for (D, E, G) in the least-squares sense.
    Mat A((int)pts.size(), 3, CV_64F), b((int)pts.size(), 1, CV_64F), sol;
    for (int i = 0; i < (int)pts.size(); i++) {
        const double x = pts[i].x - c.x, y = pts[i].y - c.y;  // centred for conditioning
        A.at<double>(i, 0) = x;
        A.at<double>(i, 1) = y;
        A.at<double>(i, 2) = 1;
        b.at<double>(i) = -(x * x + y * y);
    }
    if (!solve(A, b, sol, DECOMP_SVD)) return disk;
    const double cx = -sol.at<double>(0) / 2, cy = -sol.at<double>(1) / 2;
    const double rr = std::sqrt(std::max(0.0, cx * cx + cy * cy - sol.at<double>(2)));
    if (std::abs(cx) > 1.5 || std::abs(cy) > 1.5 || std::abs(rr - r) > 1.5) return disk;
    return Disk(Point2f((float)(c.x + cx), (float)(c.y + cy)), (float)rr);
}

}  // namespace vbme
}  // namespace cv
