// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// A small dense Levenberg–Marquardt with central-difference Jacobians, for the few-parameter
// refinements of this module (a vanishing point on the sphere, a camera's rotation + focal).
#ifndef VBME_CALIB_LM_HPP
#define VBME_CALIB_LM_HPP

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace cv {
namespace vbme {
namespace detail {

/** @brief Minimises |r(x)|² where @p f(x, r) fills the m residuals r. Returns the final cost. */
template <class F>
double levenbergMarquardt(const F& f, Eigen::VectorXd& x, int m, int max_iter = 50) {
    const int n = static_cast<int>(x.size());
    Eigen::VectorXd r(m), r1(m), r2(m), xn(n), dx(n), g(n);
    Eigen::MatrixXd J(m, n), A(n, n), Al(n, n);
    f(x, r);
    double cost = r.squaredNorm();
    double lambda = 1e-4;
    for (int it = 0; it < max_iter; ++it) {
        for (int j = 0; j < n; ++j) {
            const double h = 1e-6 * std::max(1.0, std::abs(x[j]));
            xn = x;
            xn[j] = x[j] + h;
            f(xn, r1);
            xn[j] = x[j] - h;
            f(xn, r2);
            J.col(j) = (r1 - r2) / (2 * h);
        }
        A.noalias() = J.transpose() * J;
        g.noalias() = J.transpose() * r;
        bool accepted = false;
        for (int k = 0; k < 12 && !accepted; ++k) {
            Al = A;
            for (int j = 0; j < n; ++j)
                Al(j, j) += lambda * (A(j, j) + 1e-12);
            dx = -Al.ldlt().solve(g);
            xn = x + dx;
            f(xn, r1);
            const double c1 = r1.squaredNorm();
            if (std::isfinite(c1) && c1 <= cost) {
                const double gain = cost - c1;
                x = xn;
                r = r1;
                cost = c1;
                lambda = std::max(lambda * 0.1, 1e-12);
                accepted = true;
                if (gain <= 1e-14 * (cost + 1e-300)) return cost;
            } else {
                lambda *= 10;
            }
        }
        if (!accepted || dx.norm() <= 1e-13 * (x.norm() + 1e-13)) break;
    }
    return cost;
}

}  // namespace detail
}  // namespace vbme
}  // namespace cv

#endif
