// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Irradiance albedo with the lights' common scale fixed by the room's white point.
#include <algorithm>
#include <cmath>
#include <vector>

#include "opencv2/vbme/render/albedo.hpp"
#include "opencv2/vbme/render/light_estimation.hpp"

namespace cv {
namespace vbme {

double irradianceAlbedoWhitePoint(Scene& scene, const std::map<std::string, Mat>& radiance,
                                  const std::map<std::string, Mat>& seen,
                                  std::map<std::string, Mat>& albedo, double white,
                                  const IrradianceAlbedoParams& p, int max_iterations) {
    CV_Assert(max_iterations >= 1 && white <= 1);
    double scale = 1;
    for (int it = 0; it < max_iterations; ++it) {
        std::map<std::string, Mat> irr;
        irradianceAlbedo(scene, radiance, seen, albedo, p, &irr);
        if (!(white > 0)) break;
        // the raw π·L/E of every seen texel, largest channel; clipped texels (the lights
        // themselves, highlights) say nothing about albedo: their L is a lower bound
        std::vector<float> raw;
        for (const auto& kv : radiance) {
            const Mat& L = kv.second;
            const auto e_it = irr.find(kv.first);
            const auto s_it = seen.find(kv.first);
            if (e_it == irr.end() || s_it == seen.end()) continue;
            const Mat &E = e_it->second, &sn = s_it->second;
            for (int y = 0; y < L.rows; ++y)
                for (int x = 0; x < L.cols; ++x) {
                    if (!sn.at<uchar>(y, x)) continue;
                    const Vec3f l = L.at<Vec3f>(y, x), e = E.at<Vec3f>(y, x);
                    if (std::max({l[0], l[1], l[2]}) >= 0.95f) continue;
                    float m = 0;
                    for (int c = 0; c < 3; ++c)
                        if (e[c] > 0) m = std::max(m, float(CV_PI) * l[c] / e[c]);
                    raw.push_back(m);
                }
        }
        if (raw.empty()) break;
        std::nth_element(raw.begin(), raw.begin() + raw.size() * 99 / 100, raw.end());
        const double q = raw[raw.size() * 99 / 100];
        if (!(q > 0)) break;
        // lights × k brings the white point to `white`; but only ever up: the scene's light
        // powers are a lower bound (clipped LDR pixels) or exact, never too bright, and a room
        // whose whitest surfaces are darker than `white` is common (grey walls)
        double k = q / white;
        if (scale * k < 1) k = 1 / scale;
        scale *= k;
        if (std::abs(k - 1) < 0.01) break;
        LightEstimate uniform;
        uniform.scale.assign(scene.lights.size(), Vec3d(k, k, k));
        applyLightEstimate(scene, uniform);
    }
    return scale;
}

}  // namespace vbme
}  // namespace cv
