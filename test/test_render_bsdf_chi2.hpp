// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Chi-square goodness-of-fit of a direction sampler against its claimed solid-angle pdf
// (after the approach of Mitsuba's and PBRT's BSDF tests), shared by the vbme_render tests.
#ifndef VBME_TEST_RENDER_BSDF_CHI2_HPP
#define VBME_TEST_RENDER_BSDF_CHI2_HPP

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace vbme_test {

/** @brief Outcome of chiSquareDirections(). */
struct Chi2Result {
    double chi2 = 0;     //!< statistic
    int dof = 0;         //!< degrees of freedom
    double p = 0;        //!< p-value (Wilson–Hilferty approximation)
    std::string detail;  //!< description of the worst cells, for failure messages
};

/** @brief Upper-tail p-value of a chi-square statistic with k degrees of freedom, by the
Wilson–Hilferty cube-root normal approximation (accurate to ~1e-3 for k ≥ 3). */
inline double chi2PValue(double chi2, int k) {
    if (k <= 0) return 1.0;
    const double a = 2.0 / (9.0 * k);
    const double z = (std::cbrt(chi2 / k) - (1.0 - a)) / std::sqrt(a);
    return 0.5 * std::erfc(z / std::sqrt(2.0));
}

/** @brief Tests samples against a pdf over the sphere, binned into theta_bins × phi_bins
(θ, φ) cells plus one "other" cell for samples that are not directions of the pdf (failed or
delta samples).
@param sample draws one direction; returns false for a sample that the pdf does not describe.
@param pdf solid-angle density of the non-"other" samples (integrates to ≤ 1).
@param n number of samples. Cells with expectation < 5 are pooled. */
inline Chi2Result chiSquareDirections(const std::function<bool(cv::Vec3f&)>& sample,
                                      const std::function<double(const cv::Vec3f&)>& pdf, int n,
                                      int theta_bins = 10, int phi_bins = 20, int sub = 24) {
    const double pi = 3.14159265358979323846;
    const int cells = theta_bins * phi_bins;
    std::vector<double> obs(cells + 1, 0.0), expd(cells + 1, 0.0);
    for (int i = 0; i < n; i++) {
        cv::Vec3f w;
        if (!sample(w)) {
            obs[cells] += 1;
            continue;
        }
        const double theta = std::acos(std::min(std::max((double)w[2], -1.0), 1.0));
        double phi = std::atan2((double)w[1], (double)w[0]);
        if (phi < 0) phi += 2 * pi;
        const int ti = std::min((int)(theta / pi * theta_bins), theta_bins - 1);
        const int pj = std::min((int)(phi / (2 * pi) * phi_bins), phi_bins - 1);
        obs[ti * phi_bins + pj] += 1;
    }
    // Expected counts: midpoint rule with sub×sub points per cell.
    const double dt = pi / theta_bins / sub, dp = 2 * pi / phi_bins / sub;
    double total = 0;
    for (int ti = 0; ti < theta_bins; ti++)
        for (int pj = 0; pj < phi_bins; pj++) {
            double s = 0;
            for (int a = 0; a < sub; a++) {
                const double theta = (ti * sub + a + 0.5) * dt;
                const double st = std::sin(theta), ct = std::cos(theta);
                for (int b = 0; b < sub; b++) {
                    const double phi = (pj * sub + b + 0.5) * dp;
                    const cv::Vec3f w((float)(st * std::cos(phi)), (float)(st * std::sin(phi)),
                                      (float)ct);
                    s += pdf(w) * st;
                }
            }
            expd[ti * phi_bins + pj] = s * dt * dp * n;
            total += s * dt * dp;
        }
    expd[cells] = std::max(0.0, 1.0 - total) * n;

    Chi2Result r;
    double pool_o = 0, pool_e = 0;
    int used = 0;
    std::vector<std::pair<double, int>> contrib;
    for (int c = 0; c <= cells; c++) {
        if (expd[c] < 5) {
            pool_o += obs[c];
            pool_e += expd[c];
            continue;
        }
        const double d = obs[c] - expd[c];
        r.chi2 += d * d / expd[c];
        contrib.push_back({d * d / expd[c], c});
        used++;
    }
    if (pool_e > 0) {
        const double d = pool_o - pool_e;
        r.chi2 += d * d / pool_e;
        used++;
    } else if (pool_o > 0) {
        r.chi2 = 1e30;  // samples where the pdf says there are none
    }
    r.dof = used - 1;
    r.p = r.chi2 >= 1e30 ? 0.0 : chi2PValue(r.chi2, r.dof);
    std::sort(contrib.rbegin(), contrib.rend());
    std::ostringstream os;
    os << "chi2=" << r.chi2 << " dof=" << r.dof << " p=" << r.p << " pdf mass=" << total
       << " pooled obs/exp=" << pool_o << "/" << pool_e << "; worst cells:";
    for (size_t i = 0; i < std::min<size_t>(4, contrib.size()); i++) {
        const int c = contrib[i].second;
        os << " [" << (c == cells ? std::string("other") : std::to_string(c)) << " obs " << obs[c]
           << " exp " << expd[c] << "]";
    }
    r.detail = os.str();
    return r;
}

}  // namespace vbme_test

#endif
