// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// A vantage-point tree (Yianilos 1993) over fixed-length float vectors, for k-nearest-neighbour
// queries under the Euclidean distance. Internal to vbme_inpaint.
#ifndef VBME_INPAINT_VPTREE_HPP
#define VBME_INPAINT_VPTREE_HPP

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {
namespace detail {

/** @brief Vantage-point tree over the rows of a CV_32F matrix (row i = item i). */
class VpTree {
public:
    /** @brief Builds the tree over @p data (rows are kept by reference: @p data must outlive
    the tree). Vantage points are chosen by a generator seeded with @p seed. */
    void build(const Mat& data, uint64 seed) {
        CV_Assert(data.type() == CV_32F && data.isContinuous());
        data_ = data;
        dims_ = data.cols;
        ids_.resize(data.rows);
        for (int i = 0; i < data.rows; ++i)
            ids_[i] = i;
        nodes_.clear();
        nodes_.reserve(2 * data.rows / kLeaf + 2);
        dist_.resize(data.rows);
        RNG rng(seed ^ 0x9e3779b97f4a7c15ULL);
        root_ = data.rows ? buildNode(0, data.rows, rng) : -1;
    }

    /** @brief The @p k nearest items to @p query (dims floats), nearest first, as
    (distance, item) pairs in @p out. @p heap is scratch (reused between calls). With
    @p maxChecks > 0 the search is approximate: it stops after that many distance
    evaluations (the side of each split nearer to the query is searched first). */
    void knn(const float* query, int k, std::vector<std::pair<float, int>>& out,
             std::vector<std::pair<float, int>>& heap, int maxChecks = 0) const {
        heap.clear();
        tau_ = std::numeric_limits<float>::max();
        checksLeft_ = maxChecks > 0 ? maxChecks : std::numeric_limits<int>::max();
        if (root_ >= 0 && k > 0) search(root_, query, k, heap);
        std::sort_heap(heap.begin(), heap.end());
        out.assign(heap.begin(), heap.end());
    }

    int size() const { return (int)ids_.size(); }

private:
    static constexpr int kLeaf = 8;
    struct Node {
        int vp = -1;             // item used as vantage point (internal nodes)
        float mu = 0;            // median distance from vp
        int inside = -1;         // child with d <= mu
        int outside = -1;        // child with d > mu
        int begin = 0, end = 0;  // item range in ids_ (leaves)
    };

    float dist(const float* a, int item) const {
        const float* b = data_.ptr<float>(item);
        float s = 0;
        for (int i = 0; i < dims_; ++i) {
            const float d = a[i] - b[i];
            s += d * d;
        }
        return std::sqrt(s);
    }

    int buildNode(int begin, int end, RNG& rng) {
        const int id = (int)nodes_.size();
        nodes_.emplace_back();
        if (end - begin <= kLeaf) {
            nodes_[id].begin = begin;
            nodes_[id].end = end;
            return id;
        }
        const int pick = begin + (int)rng.uniform(0, end - begin);
        std::swap(ids_[begin], ids_[pick]);
        const int vp = ids_[begin];
        const float* v = data_.ptr<float>(vp);
        for (int i = begin + 1; i < end; ++i)
            dist_[ids_[i]] = dist(v, ids_[i]);
        const int mid = (begin + 1 + end) / 2;
        std::nth_element(
            ids_.begin() + begin + 1, ids_.begin() + mid, ids_.begin() + end,
            [&](int a, int b) { return dist_[a] < dist_[b] || (dist_[a] == dist_[b] && a < b); });
        const float mu = dist_[ids_[mid]];
        const int inside = buildNode(begin + 1, mid + 1, rng);
        const int outside = buildNode(mid + 1, end, rng);
        Node& n = nodes_[id];
        n.vp = vp;
        n.mu = mu;
        n.inside = inside;
        n.outside = outside;
        return id;
    }

    void offer(float d, int item, int k, std::vector<std::pair<float, int>>& heap) const {
        const std::pair<float, int> e(d, item);
        if ((int)heap.size() < k) {
            heap.push_back(e);
            std::push_heap(heap.begin(), heap.end());
        } else if (e < heap.front()) {
            std::pop_heap(heap.begin(), heap.end());
            heap.back() = e;
            std::push_heap(heap.begin(), heap.end());
        }
        if ((int)heap.size() == k) tau_ = heap.front().first;
    }

    void search(int id, const float* q, int k, std::vector<std::pair<float, int>>& heap) const {
        if (checksLeft_ <= 0) return;
        const Node& n = nodes_[id];
        if (n.vp < 0) {
            for (int i = n.begin; i < n.end; ++i)
                offer(dist(q, ids_[i]), ids_[i], k, heap);
            checksLeft_ -= n.end - n.begin;
            return;
        }
        --checksLeft_;
        const float d = dist(q, n.vp);
        offer(d, n.vp, k, heap);
        if (d <= n.mu) {
            if (n.inside >= 0 && d - tau_ <= n.mu) search(n.inside, q, k, heap);
            if (n.outside >= 0 && d + tau_ > n.mu) search(n.outside, q, k, heap);
        } else {
            if (n.outside >= 0 && d + tau_ > n.mu) search(n.outside, q, k, heap);
            if (n.inside >= 0 && d - tau_ <= n.mu) search(n.inside, q, k, heap);
        }
    }

    Mat data_;
    int dims_ = 0;
    std::vector<int> ids_;
    std::vector<float> dist_;
    std::vector<Node> nodes_;
    int root_ = -1;
    mutable float tau_ = 0;
    mutable int checksLeft_ = 0;
};

}  // namespace detail
}  // namespace vbme
}  // namespace cv

#endif
