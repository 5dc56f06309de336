// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/render/camera.hpp"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace cv {
namespace vbme {

PinholeCamera::PinholeCamera() : PinholeCamera(Camera::fromFocal(1.0, Size(1, 1))) {}

PinholeCamera::PinholeCamera(const Camera& camera) : camera_(camera) {
    if (camera.image_size.width <= 0 || camera.image_size.height <= 0)
        CV_Error(Error::StsBadArg, "PinholeCamera: the camera's image_size must be positive");
    if (std::abs(determinant(camera.K)) < 1e-12)
        CV_Error(Error::StsBadArg,
                 "PinholeCamera: K is singular (expected positive focal lengths)");
    world_from_pixel_ = Matx33f(camera.R.t() * camera.K.inv());
    origin_ = Vec3f(camera.center());
}

void PinholeCamera::generateRay(const Point2f& px, Vec3f& origin, Vec3f& dir) const {
    origin = origin_;
    const Vec3f d = world_from_pixel_ * Vec3f(px.x, px.y, 1.f);
    dir = d * (1.f / std::sqrt(d.dot(d)));
}

void PinholeCamera::generateRays(const Point2f* px, int n, Vec3f* dirs) const {
    const Matx33f& m = world_from_pixel_;
    int i = 0;
#if defined(__SSE2__)
    // generateRay's operations lane by lane, in its order: Matx·Vec sums from 0 (0 + a·x keeps
    // the sign rules of the scalar sum), the z coordinate 1 multiplies exactly, Vec::dot sums
    // from 0 too, then 1/√ and the scale.
    const __m128 zero = _mm_setzero_ps();
    for (; i + 4 <= n; i += 4) {
        const __m128 x = _mm_setr_ps(px[i].x, px[i + 1].x, px[i + 2].x, px[i + 3].x);
        const __m128 y = _mm_setr_ps(px[i].y, px[i + 1].y, px[i + 2].y, px[i + 3].y);
        __m128 d[3];
        for (int r = 0; r < 3; ++r) {
            __m128 s = _mm_add_ps(zero, _mm_mul_ps(_mm_set1_ps(m(r, 0)), x));
            s = _mm_add_ps(s, _mm_mul_ps(_mm_set1_ps(m(r, 1)), y));
            d[r] = _mm_add_ps(s, _mm_set1_ps(m(r, 2)));
        }
        __m128 dd = _mm_add_ps(zero, _mm_mul_ps(d[0], d[0]));
        dd = _mm_add_ps(dd, _mm_mul_ps(d[1], d[1]));
        dd = _mm_add_ps(dd, _mm_mul_ps(d[2], d[2]));
        const __m128 inv = _mm_div_ps(_mm_set1_ps(1.f), _mm_sqrt_ps(dd));
        alignas(16) float out[3][4];
        for (int r = 0; r < 3; ++r)
            _mm_store_ps(out[r], _mm_mul_ps(d[r], inv));
        for (int k = 0; k < 4; ++k)
            dirs[i + k] = Vec3f(out[0][k], out[1][k], out[2][k]);
    }
#endif
    for (; i < n; ++i) {
        Vec3f o;
        generateRay(px[i], o, dirs[i]);
    }
}

}  // namespace vbme
}  // namespace cv
