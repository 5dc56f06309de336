// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Exemplar-based inpainting: Criminisi et al. 2004 fill order with three patch searches.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <queue>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/core/params.hpp"
#include "opencv2/vbme/inpaint/exemplar.hpp"
#include "vptree.hpp"

namespace cv {
namespace vbme {

PatchSearchMethod parsePatchSearchMethod(const std::string& name) {
    std::string n = name;
    for (auto& c : n)
        c = (char)std::tolower((unsigned char)c);
    if (n == "patchmatch") return PATCH_SEARCH_PATCHMATCH;
    if (n == "vptree" || n == "vp-tree") return PATCH_SEARCH_VPTREE;
    if (n == "local") return PATCH_SEARCH_LOCAL;
    CV_Error(Error::StsBadArg,
             "unknown patch search method '" + name + "'; expected patchmatch, vptree or local");
}

std::string toString(PatchSearchMethod m) {
    switch (m) {
        case PATCH_SEARCH_PATCHMATCH:
            return "patchmatch";
        case PATCH_SEARCH_VPTREE:
            return "vptree";
        case PATCH_SEARCH_LOCAL:
            return "local";
    }
    CV_Error(Error::StsBadArg, "unknown patch search method " + std::to_string((int)m));
}

ExemplarInpainter::Params::Params() = default;

void ExemplarInpainter::Params::read(const FileNode& node) {
    ParamsIn in(node, "exemplar parameters");
    in("patch_size", patch_size);
    if (const FileNode n = in.take("method"); n.isString())
        method = parsePatchSearchMethod((std::string)n);
    else
        in("method", method);
    in("color_space", color_space);
    in("local_radius", local_radius);
    in("pm_random_samples", pm_random_samples);
    in("pm_search_rounds", pm_search_rounds);
    in("pm_band_iterations", pm_band_iterations);
    in("vp_candidates", vp_candidates);
    in("vp_dims", vp_dims);
    in("vp_stride", vp_stride);
    in("vp_refine", vp_refine);
    in("vp_max_checks", vp_max_checks);
    in("seed", seed);
    in.finish();
    check();
}

void ExemplarInpainter::Params::check() const {
    const char* w = "exemplar parameters";
    checkParam(patch_size >= 3 && patch_size % 2 == 1, w, "patch_size", patch_size,
               "an odd number >= 3");
    checkParam(method == PATCH_SEARCH_PATCHMATCH || method == PATCH_SEARCH_VPTREE ||
                   method == PATCH_SEARCH_LOCAL,
               w, "method", method, "a PatchSearchMethod (patchmatch 0, vptree 1, local 2)");
    checkParam(color_space == PATCH_COLOR_RGB || color_space == PATCH_COLOR_LAB, w, "color_space",
               color_space, "PATCH_COLOR_RGB (0) or PATCH_COLOR_LAB (1)");
    checkParam(local_radius >= 1, w, "local_radius", local_radius, ">= 1");
    checkParam(pm_random_samples >= 1, w, "pm_random_samples", pm_random_samples, ">= 1");
    checkParam(pm_search_rounds >= 0, w, "pm_search_rounds", pm_search_rounds, ">= 0");
    checkParam(pm_band_iterations >= 0, w, "pm_band_iterations", pm_band_iterations, ">= 0");
    checkParam(vp_candidates >= 1, w, "vp_candidates", vp_candidates, ">= 1");
    checkParam(vp_dims >= 0, w, "vp_dims", vp_dims, ">= 0");
    checkParam(vp_stride >= 1, w, "vp_stride", vp_stride, ">= 1");
    checkParam(vp_refine >= 0, w, "vp_refine", vp_refine, ">= 0");
    checkParam(vp_max_checks >= 0, w, "vp_max_checks", vp_max_checks, ">= 0");
}

void ExemplarInpainter::Params::write(FileStorage& fs) const {
    fs << "patch_size" << patch_size;
    fs << "method" << toString((PatchSearchMethod)method);
    fs << "color_space" << color_space;
    fs << "local_radius" << local_radius;
    fs << "pm_random_samples" << pm_random_samples;
    fs << "pm_search_rounds" << pm_search_rounds;
    fs << "pm_band_iterations" << pm_band_iterations;
    fs << "vp_candidates" << vp_candidates;
    fs << "vp_dims" << vp_dims;
    fs << "vp_stride" << vp_stride;
    fs << "vp_refine" << vp_refine;
    fs << "vp_max_checks" << vp_max_checks;
    fs << "seed" << (double)seed;
}

ExemplarInpainter::~ExemplarInpainter() = default;

namespace {

enum : uint8_t { KNOWN = 0, HOLE = 1, OUTSIDE = 2 };

/** Smooth fill of the non-zero pixels of @p hole in the CV_8UC3 @p img: onion peeling (each
hole pixel next to known ones takes their mean, layer by layer), then a few Jacobi sweeps of
membrane smoothing inside the hole. */
void smoothFill(Mat& img, const Mat& hole) {
    Mat known = hole == 0;
    Mat f;
    img.convertTo(f, CV_32FC3);
    std::vector<Point> layer;
    const Rect box = boundingRect(hole);
    for (;;) {
        layer.clear();
        for (int y = box.y; y < box.y + box.height; ++y)
            for (int x = box.x; x < box.x + box.width; ++x) {
                if (known.at<uchar>(y, x)) continue;
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) {
                        const int yy = y + dy, xx = x + dx;
                        if ((dx || dy) && yy >= 0 && xx >= 0 && yy < img.rows && xx < img.cols &&
                            known.at<uchar>(yy, xx)) {
                            dy = dx = 2;  // found: leave both loops
                            layer.push_back(Point(x, y));
                        }
                    }
            }
        if (layer.empty()) break;
        for (const Point& p : layer) {
            Vec3f s(0, 0, 0);
            int n = 0;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int yy = p.y + dy, xx = p.x + dx;
                    if (yy >= 0 && xx >= 0 && yy < img.rows && xx < img.cols &&
                        known.at<uchar>(yy, xx)) {
                        s += f.at<Vec3f>(yy, xx);
                        ++n;
                    }
                }
            f.at<Vec3f>(p) = s * (1.f / n);
        }
        for (const Point& p : layer)
            known.at<uchar>(p) = 255;
    }
    std::vector<Point> inside;
    findNonZero(hole, inside);
    for (int it = 0; it < 20; ++it)
        for (const Point& p : inside) {
            Vec3f s(0, 0, 0);
            int n = 0;
            for (const Point d : {Point(-1, 0), Point(1, 0), Point(0, -1), Point(0, 1)}) {
                const Point q = p + d;
                if (q.x < 0 || q.y < 0 || q.x >= img.cols || q.y >= img.rows) continue;
                s += f.at<Vec3f>(q);
                ++n;
            }
            f.at<Vec3f>(p) = s * (1.f / n);
        }
    f.convertTo(img, CV_8UC3);
}

/** One fill of one image: padded working arrays and the three searches. */
class Filler {
public:
    explicit Filler(const ExemplarInpainter::Params& p) : p_(p), r_(p.patch_size / 2) {}

    void run(const Mat& bgr, const Mat& mask, const Mat& source, Mat& out);

private:
    // --- setup
    void setup(const Mat& bgr, const Mat& mask, const Mat& source);
    void buildVpTree();
    // --- priorities
    bool isFront(int i) const {
        if (state_[i] != HOLE) return false;
        return state_[i - 1] == KNOWN || state_[i + 1] == KNOWN || state_[i - W_] == KNOWN ||
               state_[i + W_] == KNOWN;
    }
    float priority(int i, float* confOut) const;
    // --- search
    void prepareQuery(int i);
    /** Distance of source centre @p s to the query, as one ordered key: the masked SSD over
    the query's known pixels (the distance of Criminisi et al.) in the high bits, and, to break
    its ties, the SSD of the source's pixels over the query's unknown pixels against the smooth
    pre-fill in the low 24 bits. Returns early with a key above @p bound. */
    int64 cost(int s, int64 bound) const {
        const int64 primaryBound = bound >> kTieBits;
        int64 sum = 0;
        const uint8_t* f = feat_.data();
        const int n = (int)qOff_.size();
        for (int k = 0; k < n; ++k) {
            const uint8_t* a = f + 3 * (s + qOff_[k]);
            const uint8_t* b = &qVal_[3 * k];
            const int d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
            sum += d0 * d0 + d1 * d1 + d2 * d2;
            if (sum > primaryBound) return sum << kTieBits;
        }
        int64 tie = 0;
        const int m = (int)qUnkOff_.size();
        for (int k = 0; k < m; ++k) {
            const uint8_t* a = f + 3 * (s + qUnkOff_[k]);
            const uint8_t* b = &qUnkVal_[3 * k];
            const int d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
            tie += d0 * d0 + d1 * d1 + d2 * d2;
        }
        return (sum << kTieBits) | std::min<int64>(tie, (int64(1) << kTieBits) - 1);
    }
    static constexpr int kTieBits = 24;
    int searchLocal(int i);
    int searchAll();
    int searchPatchMatch(int i);
    void bandPatchMatch();
    int64 costAt(int q, int s, int64 bound) const {
        int64 sum = 0;
        const uint8_t* f = feat_.data();
        for (int o : off_) {
            if (state_[q + o] != KNOWN) continue;
            const uint8_t* a = f + 3 * (s + o);
            const uint8_t* b = f + 3 * (q + o);
            const int d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
            sum += d0 * d0 + d1 * d1 + d2 * d2;
            if (sum > bound) return sum;
        }
        return sum;
    }
    int searchVpTree(int i);
    void consider(int s, int& best, int64& bestCost) const {
        if (s < 0 || s >= N_ || !srcValid_[s]) return;
        const int64 c = cost(s, bestCost);
        if (c < bestCost) {  // ties keep the earlier candidate: coherent ones come first
            bestCost = c;
            best = s;
        }
    }

    ExemplarInpainter::Params p_;
    int r_;
    int W_ = 0, H_ = 0, N_ = 0;  // padded size
    int w_ = 0, h_ = 0;          // image size
    std::vector<uint8_t> state_, feat_, color_, gray_, srcValid_;
    std::vector<float> conf_;
    std::vector<int> srcOf_, srcList_, off_;
    std::vector<int> qOff_, qUnkOff_;
    std::vector<uint8_t> qVal_, qUnkVal_;
    std::vector<int> candScratch_;
    RNG rng_;
    // vp-tree
    detail::VpTree tree_;
    Mat treeData_;
    std::vector<int> treeItem_;   // row → padded centre index
    std::vector<uint8_t> guess_;  // smooth pre-fill of feat_ (padded)
    PCA pca_;
    bool project_ = false;
    Mat qFull_, qProj_;
    std::vector<std::pair<float, int>> knnOut_, knnHeap_;
};

void Filler::setup(const Mat& bgr, const Mat& mask, const Mat& source) {
    w_ = bgr.cols;
    h_ = bgr.rows;
    W_ = w_ + 2 * r_;
    H_ = h_ + 2 * r_;
    N_ = W_ * H_;
    state_.assign(N_, OUTSIDE);
    feat_.assign(3 * N_, 0);
    color_.assign(3 * N_, 0);
    gray_.assign(N_, 0);
    conf_.assign(N_, 0.f);
    srcOf_.assign(N_, -1);
    srcValid_.assign(N_, 0);

    Mat feat;
    if (p_.color_space == PATCH_COLOR_LAB)
        cvtColor(bgr, feat, COLOR_BGR2Lab);
    else
        feat = bgr;
    Mat gray;
    cvtColor(bgr, gray, COLOR_BGR2GRAY);
    for (int y = 0; y < h_; ++y) {
        const uint8_t* m = mask.ptr<uint8_t>(y);
        const uint8_t* c = bgr.ptr<uint8_t>(y);
        const uint8_t* f = feat.ptr<uint8_t>(y);
        const uint8_t* g = gray.ptr<uint8_t>(y);
        for (int x = 0; x < w_; ++x) {
            const int i = (y + r_) * W_ + x + r_;
            state_[i] = m[x] ? HOLE : KNOWN;
            conf_[i] = m[x] ? 0.f : 1.f;
            for (int k = 0; k < 3; ++k) {
                color_[3 * i + k] = c[3 * x + k];
                feat_[3 * i + k] = f[3 * x + k];
            }
            gray_[i] = g[x];
        }
    }
    // Source centres: patch entirely inside, known and in the source mask.
    Mat bad(H_, W_, CV_8U, Scalar(1));
    for (int y = 0; y < h_; ++y)
        for (int x = 0; x < w_; ++x)
            bad.at<uint8_t>(y + r_, x + r_) =
                (mask.at<uint8_t>(y, x) || (!source.empty() && !source.at<uint8_t>(y, x))) ? 1 : 0;
    Mat sum;
    integral(bad, sum, CV_32S);
    srcList_.clear();
    for (int y = r_; y < h_ + r_; ++y)
        for (int x = r_; x < w_ + r_; ++x) {
            const int s = sum.at<int>(y + r_ + 1, x + r_ + 1) - sum.at<int>(y - r_, x + r_ + 1) -
                          sum.at<int>(y + r_ + 1, x - r_) + sum.at<int>(y - r_, x - r_);
            if (s == 0) {
                srcValid_[y * W_ + x] = 1;
                srcList_.push_back(y * W_ + x);
            }
        }
    off_.clear();
    for (int dy = -r_; dy <= r_; ++dy)
        for (int dx = -r_; dx <= r_; ++dx)
            off_.push_back(dy * W_ + dx);
    qOff_.reserve(off_.size());
    qVal_.reserve(3 * off_.size());
    rng_ = RNG(p_.seed * 6364136223846793005ULL + 1442695040888963407ULL);

    // Smooth pre-fill of the hole: the vp-tree's query completion and every search's
    // tie-breaker.
    {
        Mat g = feat.clone();
        smoothFill(g, mask);
        Mat gp;  // replicated border: pixels outside the image take the nearest image pixel
        copyMakeBorder(g, gp, r_, r_, r_, r_, BORDER_REPLICATE);
        CV_Assert(gp.isContinuous() && (int)gp.total() == N_);
        guess_.assign(gp.data, gp.data + 3 * N_);
    }
    qUnkOff_.reserve(off_.size());
    qUnkVal_.reserve(3 * off_.size());
    if (p_.method == PATCH_SEARCH_VPTREE) buildVpTree();
}

void Filler::bandPatchMatch() {
    // Known pixels within 2r of the hole: their patches are the known parts of the target
    // patches to come. A PatchMatch nearest-neighbour field over them (Barnes et al. 2009:
    // random init, propagation, random search), excluding trivial matches (sources
    // overlapping the pixel's own patch by more than half), seeds the coherent candidates of
    // the fill.
    std::vector<int> band;
    {
        Mat hole(H_, W_, CV_8U, state_.data());
        Mat holeOnly = hole == HOLE, near;
        dilate(holeOnly, near, getStructuringElement(MORPH_RECT, Size(4 * r_ + 1, 4 * r_ + 1)));
        for (int i = 0; i < N_; ++i)
            if (state_[i] == KNOWN && near.data[i]) band.push_back(i);
    }
    if (band.empty()) return;
    const int n = (int)srcList_.size();
    auto trivial = [&](int q, int s) {
        return std::abs(q % W_ - s % W_) <= r_ && std::abs(q / W_ - s / W_) <= r_;
    };
    std::vector<int64> cst(band.size());
    auto tryCand = [&](size_t bi, int s) {
        const int q = band[bi];
        if (s < 0 || s >= N_ || !srcValid_[s] || trivial(q, s)) return;
        const int64 c = costAt(q, s, cst[bi]);
        if (c < cst[bi]) {
            cst[bi] = c;
            srcOf_[q] = s;
        }
    };
    for (size_t bi = 0; bi < band.size(); ++bi) {
        cst[bi] = std::numeric_limits<int64>::max();
        for (int k = 0; k < 4 && srcOf_[band[bi]] < 0; ++k)
            tryCand(bi, srcList_[rng_.uniform(0, n)]);
        if (srcOf_[band[bi]] < 0) tryCand(bi, srcList_[rng_.uniform(0, n)]);
    }
    const int maxR = std::max(w_, h_);
    for (int it = 0; it < p_.pm_band_iterations; ++it) {
        const bool fwd = it % 2 == 0;
        const int d = fwd ? 1 : -1;
        for (size_t k = 0; k < band.size(); ++k) {
            const size_t bi = fwd ? k : band.size() - 1 - k;
            const int q = band[bi];
            // Propagation from the previous pixel in scan order (left/up or right/down).
            for (int nb : {q - d, q - d * W_})
                if (srcOf_[nb] >= 0 && state_[nb] == KNOWN) tryCand(bi, srcOf_[nb] + (q - nb));
            // Random search around the current match.
            if (srcOf_[q] < 0) continue;
            for (int R = maxR; R >= 1; R /= 2) {
                const int b = srcOf_[q], bx = b % W_, by = b / W_;
                const int x = std::min(std::max(bx + rng_.uniform(-R, R + 1), r_), w_ + r_ - 1);
                const int y = std::min(std::max(by + rng_.uniform(-R, R + 1), r_), h_ + r_ - 1);
                tryCand(bi, y * W_ + x);
            }
        }
    }
}

void Filler::buildVpTree() {
    const int stride = std::max(1, p_.vp_stride);
    treeItem_.clear();
    for (int s : srcList_) {
        const int x = s % W_ - r_, y = s / W_ - r_;
        if (x % stride == 0 && y % stride == 0) treeItem_.push_back(s);
    }
    if (treeItem_.empty()) treeItem_ = srcList_;
    const int D = 3 * (int)off_.size();
    Mat full((int)treeItem_.size(), D, CV_32F);
    for (int row = 0; row < full.rows; ++row) {
        float* d = full.ptr<float>(row);
        const int s = treeItem_[row];
        for (size_t k = 0; k < off_.size(); ++k)
            for (int c = 0; c < 3; ++c)
                d[3 * k + c] = feat_[3 * (s + off_[k]) + c];
    }
    project_ = p_.vp_dims > 0 && p_.vp_dims < D && full.rows > p_.vp_dims;
    if (project_) {
        const int maxSample = 4000;
        Mat sample;
        if (full.rows <= maxSample) {
            sample = full;
        } else {
            sample.create(maxSample, D, CV_32F);
            for (int i = 0; i < maxSample; ++i)
                full.row((int)((int64)i * full.rows / maxSample)).copyTo(sample.row(i));
        }
        pca_ = PCA(sample, noArray(), PCA::DATA_AS_ROW, p_.vp_dims);
        treeData_ = pca_.project(full);
        if (!treeData_.isContinuous()) treeData_ = treeData_.clone();
    } else {
        treeData_ = full;
    }
    tree_.build(treeData_, p_.seed);
    qFull_.create(1, D, CV_32F);
}

float Filler::priority(int i, float* confOut) const {
    // Confidence term.
    float c = 0;
    int inside = 0;
    for (int o : off_) {
        const int q = i + o;
        if (state_[q] == OUTSIDE) continue;
        ++inside;
        if (state_[q] == KNOWN) c += conf_[q];
    }
    c /= std::max(1, inside);
    if (confOut) *confOut = c;
    // Dominant gradient among known pixels of the patch whose 3×3 neighbourhood is known.
    float gx = 0, gy = 0, g2 = -1;
    const uint8_t* g = gray_.data();
    for (int o : off_) {
        const int q = i + o;
        if (state_[q] != KNOWN) continue;
        bool ok = true;
        for (int dy = -1; dy <= 1 && ok; ++dy)
            for (int dx = -1; dx <= 1; ++dx)
                if (state_[q + dy * W_ + dx] != KNOWN) {
                    ok = false;
                    break;
                }
        if (!ok) continue;
        const int a = q - W_, b = q + W_;
        const float sx =
            ((g[a + 1] + 2 * g[q + 1] + g[b + 1]) - (g[a - 1] + 2 * g[q - 1] + g[b - 1])) / 8.f;
        const float sy =
            ((g[b - 1] + 2 * g[b] + g[b + 1]) - (g[a - 1] + 2 * g[a] + g[a + 1])) / 8.f;
        const float m = sx * sx + sy * sy;
        if (m > g2) {
            g2 = m;
            gx = sx;
            gy = sy;
        }
    }
    // Fill-front normal: mean direction to the unfilled pixels within 2 pixels (1 for 3×3
    // patches).
    float nx = 0, ny = 0;
    const int nr = std::min(2, r_);  // the padding is r_ wide
    for (int dy = -nr; dy <= nr; ++dy)
        for (int dx = -nr; dx <= nr; ++dx)
            if ((dx || dy) && state_[i + dy * W_ + dx] == HOLE) {
                const float len = std::sqrt(float(dx * dx + dy * dy));
                nx += dx / len;
                ny += dy / len;
            }
    const float nl = std::sqrt(nx * nx + ny * ny);
    float d = 0;
    if (nl > 1e-6f && g2 > 0) {
        // Isophote = gradient rotated by 90°: (-gy, gx).
        d = std::abs(-gy * nx / nl + gx * ny / nl) / 255.f;
    }
    return c * (d + 0.001f);
}

void Filler::prepareQuery(int i) {
    qOff_.clear();
    qVal_.clear();
    for (int o : off_) {
        const int q = i + o;
        if (state_[q] != KNOWN) continue;
        qOff_.push_back(o);
        for (int c = 0; c < 3; ++c)
            qVal_.push_back(feat_[3 * q + c]);
    }
    qUnkOff_.clear();
    qUnkVal_.clear();
    for (int o : off_) {
        const int q = i + o;
        if (state_[q] != HOLE) continue;
        qUnkOff_.push_back(o);
        for (int c = 0; c < 3; ++c)
            qUnkVal_.push_back(guess_[3 * q + c]);
    }
}

int Filler::searchAll() {
    int best = -1;
    int64 bestCost = std::numeric_limits<int64>::max();
    for (int s : srcList_)
        consider(s, best, bestCost);
    return best;
}

int Filler::searchLocal(int i) {
    const int cx = i % W_, cy = i / W_;
    int best = -1;
    int64 bestCost = std::numeric_limits<int64>::max();
    // Deep inside a large hole the window may hold no whole source patch: it then doubles
    // until it does.
    for (int R = std::max(1, p_.local_radius); best < 0; R *= 2) {
        for (int y = std::max(r_, cy - R); y <= std::min(h_ + r_ - 1, cy + R); ++y)
            for (int x = std::max(r_, cx - R); x <= std::min(w_ + r_ - 1, cx + R); ++x)
                consider(y * W_ + x, best, bestCost);
        if (R > w_ + h_) break;
    }
    return best >= 0 ? best : searchAll();
}

int Filler::searchPatchMatch(int i) {
    int best = -1;
    int64 bestCost = std::numeric_limits<int64>::max();
    // Propagation: sources of already-filled pixels of the patch, shifted to this centre.
    candScratch_.clear();
    for (int o : off_) {
        const int q = i + o;
        if (srcOf_[q] >= 0) candScratch_.push_back(srcOf_[q] - o);
    }
    std::sort(candScratch_.begin(), candScratch_.end());
    candScratch_.erase(std::unique(candScratch_.begin(), candScratch_.end()), candScratch_.end());
    for (int s : candScratch_)
        consider(s, best, bestCost);
    // Uniform random samples over the whole source region.
    const int n = (int)srcList_.size();
    for (int k = 0; k < p_.pm_random_samples; ++k)
        consider(srcList_[rng_.uniform(0, n)], best, bestCost);
    if (best < 0) return searchAll();
    // Random search around the best with halving radius.
    const int maxR = std::max(w_, h_);
    for (int round = 0; round < p_.pm_search_rounds; ++round) {
        for (int R = maxR; R >= 1; R /= 2) {
            const int bx = best % W_, by = best / W_;
            const int x = std::min(std::max(bx + rng_.uniform(-R, R + 1), r_), w_ + r_ - 1);
            const int y = std::min(std::max(by + rng_.uniform(-R, R + 1), r_), h_ + r_ - 1);
            consider(y * W_ + x, best, bestCost);
        }
    }
    // Final exhaustive look at the 8 neighbours of the best.
    const int b = best;
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
            consider(b + dy * W_ + dx, best, bestCost);
    return best;
}

int Filler::searchVpTree(int i) {
    // Auto-complete the query: known pixels as they are, unknown ones from the smooth pre-fill
    // in the first pass, from the best match so far in the refinement passes.
    int best = -1;
    int64 bestCost = std::numeric_limits<int64>::max();
    for (int pass = 0; pass <= p_.vp_refine; ++pass) {
        float* q = qFull_.ptr<float>();
        for (size_t k = 0; k < off_.size(); ++k) {
            const int p = i + off_[k];
            const uint8_t* src = state_[p] == KNOWN ? &feat_[3 * p]
                                 : best >= 0        ? &feat_[3 * (best + off_[k])]
                                                    : &guess_[3 * p];
            for (int c = 0; c < 3; ++c)
                q[3 * k + c] = src[c];
        }
        const float* query = q;
        if (project_) {
            pca_.project(qFull_, qProj_);
            query = qProj_.ptr<float>();
        }
        tree_.knn(query, std::max(1, p_.vp_candidates), knnOut_, knnHeap_, p_.vp_max_checks);
        const int before = best;
        for (const auto& e : knnOut_)
            consider(treeItem_[e.second], best, bestCost);
        if (best == before) break;  // the completion did not change: converged
    }
    return best >= 0 ? best : searchAll();
}

void Filler::run(const Mat& bgr, const Mat& mask, const Mat& source, Mat& out) {
    setup(bgr, mask, source);
    if (srcList_.empty()) {
        const double frac = 100.0 * countNonZero(mask) / double(w_ * h_);
        CV_Error(
            Error::StsBadArg,
            cv::format("no %dx%d patch lies entirely in the known source region (the hole "
                       "covers %.1f%% of the %dx%d image); a smaller mask or patch_size is needed",
                       p_.patch_size, p_.patch_size, frac, w_, h_));
    }
    int remaining = 0;
    for (int i = 0; i < N_; ++i)
        remaining += state_[i] == HOLE;
    if (p_.method == PATCH_SEARCH_PATCHMATCH && p_.pm_band_iterations > 0) bandPatchMatch();

    struct Entry {
        float pri;
        int idx;
        uint32_t stamp;
        bool operator<(const Entry& o) const {
            return pri < o.pri || (pri == o.pri && idx > o.idx);
        }
    };
    std::vector<uint32_t> stamp(N_, 0);
    std::priority_queue<Entry> heap;
    for (int i = 0; i < N_; ++i)
        if (isFront(i)) heap.push({priority(i, nullptr), i, 0});

    const int R = 2 * r_ + 2;
    while (remaining > 0) {
        if (heap.empty()) CV_Error(Error::StsInternal, "inpainting fill front became empty");
        const Entry e = heap.top();
        heap.pop();
        if (e.stamp != stamp[e.idx] || !isFront(e.idx)) continue;
        const int i = e.idx;
        float c = 0;
        priority(i, &c);
        prepareQuery(i);
        int s = -1;
        switch (p_.method) {
            case PATCH_SEARCH_LOCAL:
                s = searchLocal(i);
                break;
            case PATCH_SEARCH_VPTREE:
                s = searchVpTree(i);
                break;
            default:
                s = searchPatchMatch(i);
                break;
        }
        CV_Assert(s >= 0);
        for (int o : off_) {
            const int q = i + o;
            if (state_[q] != HOLE) continue;
            const int from = s + o;
            for (int k = 0; k < 3; ++k) {
                feat_[3 * q + k] = feat_[3 * from + k];
                color_[3 * q + k] = color_[3 * from + k];
            }
            gray_[q] = gray_[from];
            state_[q] = KNOWN;
            conf_[q] = c;
            srcOf_[q] = from;
            --remaining;
        }
        const int cx = i % W_, cy = i / W_;
        for (int y = std::max(1, cy - R); y <= std::min(H_ - 2, cy + R); ++y)
            for (int x = std::max(1, cx - R); x <= std::min(W_ - 2, cx + R); ++x) {
                const int j = y * W_ + x;
                if (!isFront(j)) continue;
                heap.push({priority(j, nullptr), j, ++stamp[j]});
            }
    }
    out.create(h_, w_, CV_8UC3);
    for (int y = 0; y < h_; ++y) {
        uint8_t* o = out.ptr<uint8_t>(y);
        for (int x = 0; x < w_; ++x) {
            const int i = (y + r_) * W_ + x + r_;
            for (int k = 0; k < 3; ++k)
                o[3 * x + k] = color_[3 * i + k];
        }
    }
}

class ExemplarInpainterImpl CV_FINAL : public ExemplarInpainter {
public:
    explicit ExemplarInpainterImpl(const Params& p) : p_(p) {}

    void inpaint(InputArray _image, InputArray _mask, OutputArray _result,
                 InputArray _source) CV_OVERRIDE {
        const Mat image = _image.getMat();
        const Mat mask = _mask.getMat();
        if (image.empty()) CV_Error(Error::StsBadArg, "inpaint: the image is empty");
        if (image.type() != CV_8UC3 && image.type() != CV_8UC1)
            CV_Error(Error::StsBadArg, "inpaint: image type is " + typeToString(image.type()) +
                                           ", expected CV_8UC3 (BGR) or CV_8UC1");
        if (mask.empty())
            CV_Error(Error::StsBadArg,
                     "inpaint: the mask is empty; expected a CV_8UC1 image of the image's size");
        if (mask.type() != CV_8UC1)
            CV_Error(Error::StsBadArg, "inpaint: mask type is " + typeToString(mask.type()) +
                                           ", expected CV_8UC1 (non-zero = hole)");
        if (mask.size() != image.size())
            CV_Error(Error::StsBadSize,
                     cv::format("inpaint: mask is %dx%d but the image is %dx%d; they must match",
                                mask.cols, mask.rows, image.cols, image.rows));
        Mat source;
        if (!_source.empty()) {
            source = _source.getMat();
            if (source.type() != CV_8UC1 || source.size() != image.size())
                CV_Error(Error::StsBadArg,
                         cv::format("inpaint: source mask is %s %dx%d, expected CV_8UC1 %dx%d",
                                    typeToString(source.type()).c_str(), source.cols, source.rows,
                                    image.cols, image.rows));
        }
        if (countNonZero(mask) == 0) {
            image.copyTo(_result);
            return;
        }
        Mat bgr;
        if (image.channels() == 1)
            cvtColor(image, bgr, COLOR_GRAY2BGR);
        else
            bgr = image;
        Filler f(p_);
        Mat out;
        f.run(bgr, mask, source, out);
        if (image.channels() == 1)
            cvtColor(out, _result, COLOR_BGR2GRAY);
        else
            out.copyTo(_result);
    }

    const Params& params() const CV_OVERRIDE { return p_; }

private:
    Params p_;
};

}  // namespace

Ptr<ExemplarInpainter> ExemplarInpainter::create(const Params& p) {
    p.check();
    return makePtr<ExemplarInpainterImpl>(p);
}

}  // namespace vbme
}  // namespace cv
