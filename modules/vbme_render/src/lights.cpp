// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/render/lights.hpp"

#include <cmath>
#include <limits>

#include "opencv2/vbme/render/environment.hpp"
#include "sampling.hpp"

namespace cv {
namespace vbme {

Emitter::~Emitter() = default;

namespace {

using sampling::kPi;

inline float luminance(const Vec3f& c) {
    return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2];
}
constexpr float kInf = std::numeric_limits<float>::infinity();

class PolygonEmitter : public Emitter {
public:
    PolygonEmitter(const Light& l, const std::string& field) : radiance_(l.radiance) {
        const Vec3d n = l.polygonNormal();
        normal_ = Vec3f(n);
        std::vector<float> areas;
        for (size_t i = 1; i + 1 < l.corners.size(); ++i) {
            const Vec3f a(l.corners[0]), b(l.corners[i]), c(l.corners[i + 1]);
            const float area = 0.5f * float(norm((b - a).cross(c - a)));
            v0_.push_back(a);
            e1_.push_back(b - a);
            e2_.push_back(c - a);
            areas.push_back(area);
            area_ += area;
        }
        if (!(area_ > 0.f)) CV_Error(Error::StsBadArg, field + ".corners: polygon has no area");
        dist_.build(areas.data(), (int)areas.size());
    }
    Light::Type type() const override { return Light::POLYGON; }
    bool sample(const Vec3f& p, const Vec2f& u, EmitterSample& s) const override {
        float pmf, u0;
        const int t = dist_.sampleDiscrete(u[0], pmf, u0);
        const Vec2f b = sampling::squareToUniformTriangle(Vec2f(u0, u[1]));
        const Vec3f q = v0_[t] + e1_[t] * b[0] + e2_[t] * b[1];
        Vec3f d = q - p;
        const float d2 = d.dot(d);
        if (!(d2 > 0.f)) return false;
        const float dist = std::sqrt(d2);
        d *= 1.f / dist;
        const float cos_l = -normal_.dot(d);
        if (cos_l <= 0.f) return false;
        s.wi = d;
        s.dist = dist;
        s.pdf = d2 / (area_ * cos_l);
        s.L = radiance_;
        s.delta = false;
        return true;
    }
    float pdfHit(const Vec3f&, const Vec3f& wi, float dist) const override {
        const float cos_l = -normal_.dot(wi);
        return cos_l > 0.f ? dist * dist / (area_ * cos_l) : 0.f;
    }
    Vec3f radianceHit(const Vec3f& wi) const override {
        return normal_.dot(wi) < 0.f ? radiance_ : Vec3f(0, 0, 0);
    }
    float power(float) const override { return kPi * area_ * luminance(radiance_); }

private:
    Vec3f radiance_, normal_;
    std::vector<Vec3f> v0_, e1_, e2_;
    float area_ = 0.f;
    sampling::Distribution1D dist_;
};

class PointEmitter : public Emitter {
public:
    explicit PointEmitter(const Light& l) : pos_(l.position), intensity_(l.intensity) {}
    Light::Type type() const override { return Light::POINT; }
    bool sample(const Vec3f& p, const Vec2f&, EmitterSample& s) const override {
        Vec3f d = pos_ - p;
        const float d2 = d.dot(d);
        if (!(d2 > 0.f)) return false;
        const float dist = std::sqrt(d2);
        s.wi = d * (1.f / dist);
        s.dist = dist;
        s.pdf = 1.f;
        s.L = intensity_ * (1.f / d2);
        s.delta = true;
        return true;
    }
    bool isDelta() const override { return true; }
    float power(float) const override { return 4.f * kPi * luminance(intensity_); }

private:
    Vec3f pos_, intensity_;
};

class DistantEmitter : public Emitter {
public:
    explicit DistantEmitter(const Light& l)
        : dir_(normalize(Vec3f(l.to_light))), radiance_(l.radiance), frame_(dir_) {
        const double half = std::min(std::max(l.half_angle_deg, 0.0), 90.0) * CV_PI / 180.0;
        cos_max_ = float(std::cos(half));
        delta_ = !(half > 0.0) || cos_max_ >= 1.f;
        if (delta_) cos_max_ = 1.f;
    }
    Light::Type type() const override { return Light::DISTANT; }
    bool sample(const Vec3f&, const Vec2f& u, EmitterSample& s) const override {
        s.dist = kInf;
        s.L = radiance_;
        if (delta_) {
            s.wi = dir_;
            s.pdf = 1.f;
            s.delta = true;
            return true;
        }
        s.wi = normalize(frame_.toWorld(sampling::squareToUniformCone(u, cos_max_)));
        s.pdf = 1.f / (2.f * kPi * (1.f - cos_max_));
        s.delta = false;
        return true;
    }
    Vec3f radianceEscaped(const Vec3f& d) const override {
        return !delta_ && d.dot(dir_) >= cos_max_ ? radiance_ : Vec3f(0, 0, 0);
    }
    float pdfEscaped(const Vec3f& d) const override {
        return !delta_ && d.dot(dir_) >= cos_max_ ? 1.f / (2.f * kPi * (1.f - cos_max_)) : 0.f;
    }
    bool isDelta() const override { return delta_; }
    bool isInfinite() const override { return true; }
    float power(float r) const override {
        const float e = delta_ ? luminance(radiance_)
                               : luminance(radiance_) * kPi * (1.f - cos_max_ * cos_max_);
        return kPi * r * r * e;
    }

private:
    Vec3f dir_, radiance_;
    sampling::Frame frame_;
    float cos_max_ = 1.f;
    bool delta_ = true;
};

class EnvironmentEmitter : public Emitter {
public:
    explicit EnvironmentEmitter(EnvironmentMap&& env) : env_(std::move(env)) {}
    Light::Type type() const override { return Light::ENVIRONMENT; }
    bool sample(const Vec3f&, const Vec2f& u, EmitterSample& s) const override {
        s.L = env_.sample(u, s.wi, s.pdf);
        s.dist = kInf;
        s.delta = false;
        return s.pdf > 0.f;
    }
    Vec3f radianceEscaped(const Vec3f& d) const override { return env_.eval(d); }
    float pdfEscaped(const Vec3f& d) const override { return env_.pdf(d); }
    bool isInfinite() const override { return true; }
    float power(float r) const override {
        // Mean radiance over the sphere (deterministic midpoint sampling of directions).
        double sum = 0;
        const int n = 32;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j)
                sum += luminance(env_.eval(
                    sampling::squareToUniformSphere(Vec2f((i + 0.5f) / n, (j + 0.5f) / n))));
        return float(sum / (n * n)) * kPi * kPi * r * r * 4.f;
    }

private:
    EnvironmentMap env_;
};

}  // namespace

Ptr<Emitter> Emitter::create(const Light& light, const std::string& field) {
    switch (light.type) {
        case Light::POLYGON:
            if (light.corners.size() < 3)
                CV_Error(Error::StsBadArg, field + ".corners: expected at least 3 corners");
            return makePtr<PolygonEmitter>(light, field);
        case Light::POINT:
            return makePtr<PointEmitter>(light);
        case Light::DISTANT:
            if (norm(light.to_light) == 0)
                CV_Error(Error::StsBadArg, field + ".to_light: must be non-zero");
            return makePtr<DistantEmitter>(light);
        case Light::ENVIRONMENT:
            if (!light.image.empty()) {
                try {
                    return Ptr<Emitter>(new EnvironmentEmitter(EnvironmentMap::load(
                        light.image, Matx33f(light.world_from_env), float(light.scale))));
                } catch (const cv::Exception& e) {
                    CV_Error(Error::StsError, field + ".image: " + e.err);
                }
            }
            return Ptr<Emitter>(new EnvironmentEmitter(EnvironmentMap(Vec3f(light.radiance))));
    }
    CV_Error(Error::StsBadArg, field + ".type: unknown light type");
}

}  // namespace vbme
}  // namespace cv
