// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Automatic calibration on realistic renders of furnished rooms and corridors (Blender Cycles,
// scripts/blender/calib_rooms.py; test/data/calib_rooms/truth.csv holds each image's focal
// length, rotation and radial distortion): focal-length error percentiles and vanishing-
// direction accuracy AA@3/5/10 of the GLOBAL search, against the previous RANSAC search on the
// same images; the same with a focal prior as EXIF would give it; whether the confidence and
// the "ambiguous" flag tell right answers from wrong ones; plumb-line distortion k1 on the
// distorted renders. VBME_CALIB_ROOMS_DUMP=dir writes an annotated overlay per image.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <numeric>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/calib.hpp>

#include "manhattan.hpp"  // white-box: the refinement started from the true frame

using namespace cv;
using namespace cv::vbme;

namespace {

struct Truth {
    std::string name, kind;
    Size size;
    double f = 0, k1 = 0;
    Point2d c;
    Matx33d R;
};

std::vector<Truth> readTruth() {
    const std::string dir = std::string(VBME_TEST_DATA_DIR) + "/calib_rooms/";
    std::ifstream in(dir + "truth.csv");
    std::vector<Truth> out;
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
        if (line.empty()) continue;
        std::stringstream ss(line);
        std::vector<std::string> t;
        std::string x;
        while (std::getline(ss, x, ','))
            t.push_back(x);
        if (t.size() != 18) continue;
        Truth tr;
        tr.name = dir + t[0];
        tr.kind = t[1];
        tr.size = Size(std::stoi(t[2]), std::stoi(t[3]));
        tr.f = std::stod(t[4]);
        tr.c = Point2d(std::stod(t[5]), std::stod(t[6]));
        tr.k1 = std::stod(t[7]);
        for (int k = 0; k < 9; ++k)
            tr.R(k / 3, k % 3) = std::stod(t[9 + k]);
        out.push_back(tr);
    }
    return out;
}

/** One method's errors on one image: relative focal error (1 when it failed) and, for each
true Manhattan direction, the angle (degrees) to the nearest estimated vanishing point seen
through the true intrinsics (90 when it failed). */
struct Outcome {
    bool ok = false;
    double focal_err = 1;
    double dir_err[3] = {90, 90, 90};
    double confidence = 0;
    double proposal_confidence = 0;  // the first proposal's ranked confidence (GLOBAL)
    double k1 = 0;
    double sigma = 0;
    std::string support;
    std::string error;
};

Outcome evaluate(const Truth& t, const FrameCalibration& fc) {
    Outcome o;
    o.ok = true;
    o.focal_err = std::abs(fc.focal() / t.f - 1);
    const Matx33d K(t.f, 0, t.c.x, 0, t.f, t.c.y, 0, 0, 1);
    const Matx33d Kinv = K.inv();
    for (int a = 0; a < 3; ++a) {
        const Vec3d g(t.R(0, a), t.R(1, a), t.R(2, a));
        double best = 90;
        for (int b = 0; b < 3; ++b) {
            const Vec3d d = normalize(Kinv * fc.vanishing_points[b]);
            best = std::min(best, std::acos(std::min(1.0, std::abs(d.dot(g)))) * 180 / CV_PI);
        }
        o.dir_err[a] = best;
    }
    o.confidence = fc.confidence;
    o.sigma = fc.focal_rel_sigma;
    o.support = format("%d/%d/%d", fc.support[0], fc.support[1], fc.support[2]);
    o.k1 = fc.k1;
    return o;
}

/** Area under the recall curve of the angular errors up to @p t degrees, in percent. */
double aa(const std::vector<double>& e, double t) {
    double s = 0;
    for (double x : e)
        s += std::max(0.0, t - x);
    return 100 * s / (t * e.size());
}

double percentile(std::vector<double> v, double q) {
    std::sort(v.begin(), v.end());
    const double pos = q * (v.size() - 1);
    const size_t i = (size_t)pos;
    return i + 1 < v.size() ? v[i] + (pos - i) * (v[i + 1] - v[i]) : v.back();
}

struct Summary {
    double p50 = 0, p75 = 0, p90 = 0, aa3 = 0, aa5 = 0, aa10 = 0;
    int failed = 0, over10 = 0;
};

Summary summarise(const std::vector<Outcome>& o) {
    Summary s;
    std::vector<double> fe, de;
    for (const auto& x : o) {
        fe.push_back(x.focal_err);
        for (double d : x.dir_err)
            de.push_back(d);
        s.failed += !x.ok;
        s.over10 += x.focal_err > 0.1;
    }
    s.p50 = 100 * percentile(fe, 0.5);
    s.p75 = 100 * percentile(fe, 0.75);
    s.p90 = 100 * percentile(fe, 0.9);
    s.aa3 = aa(de, 3);
    s.aa5 = aa(de, 5);
    s.aa10 = aa(de, 10);
    return s;
}

void print(const char* name, const Summary& s, size_t n) {
    std::printf(
        "%-9s focal error median %.2f %%, p75 %.2f %%, p90 %.2f %%; >10 %%: %d of %d; failed %d; "
        "AA@3/5/10 %.1f / %.1f / %.1f\n",
        name, s.p50, s.p75, s.p90, s.over10, (int)n, s.failed, s.aa3, s.aa5, s.aa10);
}

/** Annotated overlay for looking at failures (VBME_CALIB_ROOMS_DUMP=dir): the image inside a
margin of half its size; segments coloured by the estimated world axis (x red, y green, z
blue, outliers grey); true vanishing points as rings and true horizon white, estimated
vanishing points as crosses and estimated horizon yellow (points outside the canvas are drawn
at its border). */
void dumpOverlay(const std::string& dir, const Truth& t, const Mat& img, const FrameCalibration& c,
                 bool found = true, const std::string& suffix = "") {
    const int mx = img.cols / 2, my = img.rows / 2;
    Mat ov(img.rows + 2 * my, img.cols + 2 * mx, CV_8UC3, Scalar(40, 40, 40));
    img.copyTo(ov(Rect(mx, my, img.cols, img.rows)));
    const Point2d o(mx, my);
    const Scalar col[4] = {Scalar(150, 150, 150), Scalar(0, 0, 255), Scalar(0, 200, 0),
                           Scalar(255, 80, 0)};
    for (size_t i = 0; i < c.segments.size(); ++i)
        line(ov, o + Point2d(c.segments[i][0], c.segments[i][1]),
             o + Point2d(c.segments[i][2], c.segments[i][3]), col[c.labels[i] + 1],
             c.labels[i] < 0 ? 1 : 2);
    auto clampPt = [&](Vec3d v) {
        if (v[2] < 0) v = -v;
        Point2d p = std::abs(v[2]) < 1e-9 ? Point2d(v[0] * 1e9, v[1] * 1e9)
                                          : Point2d(v[0] / v[2], v[1] / v[2]);
        p += o;
        const Point2d ctr(ov.cols / 2.0, ov.rows / 2.0);
        const double s =
            std::max(std::abs(p.x - ctr.x) / (ctr.x - 8), std::abs(p.y - ctr.y) / (ctr.y - 8));
        return s > 1 ? ctr + (p - ctr) * (1 / s) : p;
    };
    auto horizon = [&](const Matx33d& K, const Matx33d& R, const Scalar& cl) {
        const Vec3d up(R(0, 2), R(1, 2), R(2, 2));
        const Vec3d l =
            K.inv().t() * up;  // image line of the vanishing points of horizontal directions
        std::vector<Point2d> pts;
        if (std::abs(l[1]) > std::abs(l[0])) {
            for (double x : {-(double)mx, (double)img.cols + mx})
                pts.emplace_back(x, -(l[0] * x + l[2]) / l[1]);
        } else {
            for (double y : {-(double)my, (double)img.rows + my})
                pts.emplace_back(-(l[1] * y + l[2]) / l[0], y);
        }
        line(ov, o + pts[0], o + pts[1], cl, 1, LINE_AA);
    };
    const Matx33d Kt(t.f, 0, t.c.x, 0, t.f, t.c.y, 0, 0, 1);
    horizon(Kt, t.R, Scalar(255, 255, 255));
    if (found) horizon(c.K, c.R, Scalar(0, 255, 255));
    for (int a = 0; a < 3; ++a) {
        const Vec3d tv = Kt * Vec3d(t.R(0, a), t.R(1, a), t.R(2, a));
        circle(ov, clampPt(tv), 9, col[a + 1], 2, LINE_AA);
        circle(ov, clampPt(tv), 11, Scalar(255, 255, 255), 1, LINE_AA);
        if (found) drawMarker(ov, clampPt(c.vanishing_points[a]), col[a + 1], MARKER_CROSS, 22, 3);
    }
    putText(ov,
            format("f true %.0f est %.0f (%.1f %%) conf %.2f  segs %d", t.f, c.focal(),
                   100 * (c.focal() / t.f - 1), c.confidence, (int)c.segments.size()),
            Point(10, 24), FONT_HERSHEY_SIMPLEX, 0.7, Scalar(255, 255, 255), 2);
    const std::string base = t.name.substr(t.name.rfind('/') + 1);
    imwrite(dir + "/" + base + suffix + ".png", ov);
}

/** The detected segments labelled by the TRUE frame, as the search labels them: each segment
goes to the true vanishing point it points at most nearly, if within its inlier angle
(3 × (√2·0.5 px / L + 0.1°), clamped to 0.45°–3°, the detector's rule for the default 1.5°).
Drawn next to the chosen frame's overlay, it shows which segments make a wrong frame outscore
the true one. */
FrameCalibration trueFrameLabels(const Truth& t, const std::vector<Vec4f>& segments) {
    FrameCalibration c;
    c.image_size = t.size;
    c.K = Matx33d(t.f, 0, t.c.x, 0, t.f, t.c.y, 0, 0, 1);
    c.R = t.R;
    c.segments = segments;
    c.labels.assign(segments.size(), -1);
    for (int a = 0; a < 3; ++a)
        c.vanishing_points[a] = c.K * Vec3d(t.R(0, a), t.R(1, a), t.R(2, a));
    for (size_t i = 0; i < segments.size(); ++i) {
        const Vec4f& s = segments[i];
        const Vec2d m((s[0] + s[2]) / 2, (s[1] + s[3]) / 2), d(s[2] - s[0], s[3] - s[1]);
        const double L = norm(d);
        if (L <= 0) continue;
        const double sig = std::sqrt(2.0) * 0.5 / L + 0.1 * CV_PI / 180;
        double best = std::sin(std::min(3.0 * CV_PI / 180, std::max(0.45 * CV_PI / 180, 3 * sig)));
        for (int a = 0; a < 3; ++a) {
            const Vec3d& v = c.vanishing_points[a];
            const double tx = v[0] - m[0] * v[2], ty = v[1] - m[1] * v[2];
            const double tn = std::hypot(tx, ty);
            if (tn <= 0) continue;
            const double sa = std::abs(d[0] * ty - d[1] * tx) / (L * tn);
            if (sa < best) {
                best = sa;
                c.labels[i] = a;
            }
        }
    }
    return c;
}

/** Every image is processed once (both methods, proposals, distortion), then the tests look
at the results. */
struct Results {
    std::vector<Truth> plain, distorted;
    std::vector<Outcome> global, ransac, dist_k1, dist_nok1;
    // GLOBAL on the LSD segments alone (Params::fld_pass off; the method before session 9), and
    // the confidences of its right and wrong first proposals.
    std::vector<Outcome> lsd_only;
    std::vector<double> lsd_first_right, lsd_first_wrong;
    // GLOBAL with a focal prior as EXIF would give it (PNG/JPEG renders carry no EXIF): the
    // true focal length off by +5 % and −5 % on alternate images, with the default prior σ.
    std::vector<Outcome> prior;
    // Confidence of proposals that are right (focal within 5 %, directions within 3°) and wrong.
    std::vector<double> conf_right, conf_wrong;
    // The same for the first proposal only (what detect() returns), and how often it is flagged
    // ambiguous when right and when wrong.
    std::vector<double> first_right, first_wrong;
    int ambiguous = 0, amb_right = 0, amb_wrong = 0;
    // Proposals after the first, and those whose segments or labels are not the first's (the
    // annotator regroups the first proposal's segments by the one the user chooses).
    int later_proposals = 0, later_off_segments = 0;
    // The GLOBAL refinement started from the true frame on the detected segments: signed
    // relative focal drift and the refinement's own relative focal sigma, per image where the
    // search answered.
    std::vector<double> truth_drift, truth_sigma;
    // The same search with the edge-pixel likelihood (Params::edgel_scoring), without and with
    // the prior, and the confidence of its first proposals when right and when wrong.
    std::vector<Outcome> edgels, edgels_prior;
    std::vector<double> edg_first_right, edg_first_wrong;
};

const Results& results() {
    static const Results r = [] {
        Results r;
        for (const auto& t : readTruth())
            (t.k1 == 0 ? r.plain : r.distorted).push_back(t);
        VanishingPointCalibrator::Params pg, pr;
        pr.method = VanishingPointCalibrator::Params::RANSAC;
        auto cal_g = VanishingPointCalibrator::create(pg);
        auto cal_r = VanishingPointCalibrator::create(pr);
        for (const auto& t : r.plain) {
            const Mat img = imread(t.name, IMREAD_COLOR);
            if (img.empty()) ADD_FAILURE() << "cannot read " << t.name;
            Outcome og, orr;
            try {
                const auto props = detectManhattanProposals(img, pg, 3);
                og = evaluate(t, props[0].calibration);
                og.proposal_confidence = props[0].confidence;
                double sig = 0;
                const double f = cv::vbme::detail::refineManhattanFrameFrom(
                    props[0].calibration.segments, img.size(), pg, t.f, t.R, &sig);
                r.truth_drift.push_back(f / t.f - 1);
                r.truth_sigma.push_back(sig);
                std::printf("%s: refinement from the true frame: f %+.2f %% (sigma %.2f %%)\n",
                            t.name.substr(t.name.rfind('/') + 1).c_str(),
                            100 * r.truth_drift.back(), 100 * sig);
                if (const char* dump = std::getenv("VBME_CALIB_ROOMS_DUMP")) {
                    dumpOverlay(std::string(dump), t, img, props[0].calibration);
                    FrameCalibration tc = trueFrameLabels(t, props[0].calibration.segments);
                    tc.confidence = props[0].calibration.confidence;
                    dumpOverlay(std::string(dump), t, img, tc, false, ".true");
                }
                for (size_t k = 0; k < props.size(); ++k) {
                    const ManhattanProposal& p = props[k];
                    const Outcome o = evaluate(t, p.calibration);
                    const bool right = o.focal_err < 0.05 &&
                                       std::max({o.dir_err[0], o.dir_err[1], o.dir_err[2]}) < 3;
                    (right ? r.conf_right : r.conf_wrong).push_back(p.confidence);
                    if (k == 0) {
                        (right ? r.first_right : r.first_wrong).push_back(p.confidence);
                        (right ? r.amb_right : r.amb_wrong) += p.ambiguous;
                    }
                    r.ambiguous += p.ambiguous;
                    if (k > 0) {
                        ++r.later_proposals;
                        r.later_off_segments +=
                            p.calibration.segments != props[0].calibration.segments ||
                            p.calibration.labels.size() != props[0].calibration.segments.size();
                    }
                }
            } catch (const cv::Exception& e) {
                og.error = e.err;
                if (const char* dump = std::getenv("VBME_CALIB_ROOMS_DUMP")) {
                    // No frame: the detected segments alone (grey), the truth drawn as usual.
                    FrameCalibration none;
                    none.K = Matx33d(t.f, 0, t.c.x, 0, t.f, t.c.y, 0, 0, 1);
                    none.R = t.R;
                    cal_g->detectSegments(img, none.segments);
                    none.labels.assign(none.segments.size(), -1);
                    dumpOverlay(std::string(dump), t, img, none, false);
                }
            }
            Outcome ol;
            try {
                VanishingPointCalibrator::Params pl = pg;
                pl.fld_pass = false;
                const auto props = detectManhattanProposals(img, pl, 3);
                ol = evaluate(t, props[0].calibration);
                const bool right = ol.focal_err < 0.05 &&
                                   std::max({ol.dir_err[0], ol.dir_err[1], ol.dir_err[2]}) < 3;
                (right ? r.lsd_first_right : r.lsd_first_wrong).push_back(props[0].confidence);
            } catch (const cv::Exception& e) {
                ol.error = e.err;
            }
            r.lsd_only.push_back(ol);
            std::printf("%s: LSD only: f err %.2f %% dir %.2f/%.2f/%.2f conf %.2f %s\n",
                        t.name.substr(t.name.rfind('/') + 1).c_str(), 100 * ol.focal_err,
                        ol.dir_err[0], ol.dir_err[1], ol.dir_err[2], ol.confidence,
                        ol.error.c_str());
            {
                VanishingPointCalibrator::Params pe = pg;
                pe.edgel_scoring = true;
                Outcome oe, oep;
                try {
                    const auto props = detectManhattanProposals(img, pe, 3);
                    oe = evaluate(t, props[0].calibration);
                    const bool right = oe.focal_err < 0.05 &&
                                       std::max({oe.dir_err[0], oe.dir_err[1], oe.dir_err[2]}) < 3;
                    (right ? r.edg_first_right : r.edg_first_wrong).push_back(props[0].confidence);
                    oe.confidence = props[0].confidence;  // printed: the ranked confidence
                } catch (const cv::Exception& e) {
                    oe.error = e.err;
                }
                try {
                    pe.focal_prior = t.f * (r.edgels_prior.size() % 2 ? 0.95 : 1.05);
                    oep = evaluate(t, detectManhattanProposals(img, pe, 1)[0].calibration);
                } catch (const cv::Exception& e) {
                    oep.error = e.err;
                }
                std::printf(
                    "%s: with edgels f err %.2f %% dir %.2f/%.2f/%.2f conf %.2f; with the "
                    "prior f err %.2f %% dir %.2f/%.2f/%.2f %s\n",
                    t.name.substr(t.name.rfind('/') + 1).c_str(), 100 * oe.focal_err, oe.dir_err[0],
                    oe.dir_err[1], oe.dir_err[2], oe.confidence, 100 * oep.focal_err,
                    oep.dir_err[0], oep.dir_err[1], oep.dir_err[2],
                    (oe.error + " " + oep.error).c_str());
                r.edgels.push_back(oe);
                r.edgels_prior.push_back(oep);
            }
            Outcome op;
            try {
                VanishingPointCalibrator::Params pp = pg;
                pp.focal_prior = t.f * (r.prior.size() % 2 ? 0.95 : 1.05);
                op = evaluate(t, detectManhattanProposals(img, pp, 1)[0].calibration);
            } catch (const cv::Exception& e) {
                op.error = e.err;
            }
            r.prior.push_back(op);
            std::printf("%s: with a focal prior %+.0f %%: f err %.2f %% dir %.2f/%.2f/%.2f %s\n",
                        t.name.substr(t.name.rfind('/') + 1).c_str(),
                        r.prior.size() % 2 ? 5.0 : -5.0, 100 * op.focal_err, op.dir_err[0],
                        op.dir_err[1], op.dir_err[2], op.error.c_str());
            try {
                orr = evaluate(t, cal_r->detect(img));
            } catch (const cv::Exception& e) {
                orr.error = e.err;
            }
            std::printf(
                "%s: global f err %.2f %% (sigma %.2f %%) dir %.2f/%.2f/%.2f conf %.2f (ranked "
                "%.2f) "
                "support %s "
                "| ransac f err "
                "%.2f %% dir %.2f/%.2f/%.2f %s\n",
                t.name.substr(t.name.rfind('/') + 1).c_str(), 100 * og.focal_err, 100 * og.sigma,
                og.dir_err[0], og.dir_err[1], og.dir_err[2], og.confidence, og.proposal_confidence,
                og.support.c_str(), 100 * orr.focal_err, orr.dir_err[0], orr.dir_err[1],
                orr.dir_err[2], (og.error + " " + orr.error).c_str());
            r.global.push_back(og);
            r.ransac.push_back(orr);
        }
        VanishingPointCalibrator::Params pk = pg;
        pk.estimate_distortion = true;
        auto cal_k = VanishingPointCalibrator::create(pk);
        for (const auto& t : r.distorted) {
            const Mat img = imread(t.name, IMREAD_COLOR);
            Outcome ok, on;
            try {
                ok = evaluate(t, cal_k->detect(img));
            } catch (const cv::Exception& e) {
                ok.error = e.err;
            }
            try {
                on = evaluate(t, cal_g->detect(img));
            } catch (const cv::Exception& e) {
                on.error = e.err;
            }
            std::printf(
                "%s: k1 true %.4f estimated %.4f (%.1f %%); focal err %.2f %% with k1, "
                "%.2f %% without %s\n",
                t.name.substr(t.name.rfind('/') + 1).c_str(), t.k1, ok.k1,
                100 * std::abs(ok.k1 / t.k1 - 1), 100 * ok.focal_err, 100 * on.focal_err,
                (ok.error + " " + on.error).c_str());
            r.dist_k1.push_back(ok);
            r.dist_nok1.push_back(on);
        }
        return r;
    }();
    return r;
}

// The aims (median focal error ≤ 2 %, AA@3/5/10 ≥ 70/88/96) are printed; the median
// aim is asserted (measured 1.33 %), the AA aims are not reached at 5° and 10° on these renders
// (see doc/vbme_calib.md). Also asserted: the GLOBAL search beats the previous RANSAC search on
// every figure, on the same images.
TEST(CalibRooms, GlobalSearchBeatsRansacOnRenderedRooms) {
    const Results& r = results();
    ASSERT_GE(r.plain.size(), 20u) << "test/data/calib_rooms/truth.csv missing or short";
    const Summary g = summarise(r.global), o = summarise(r.ransac);
    print("global", g, r.plain.size());
    print("ransac", o, r.plain.size());
    std::printf("aims: median focal error <= 2 %% (%s), AA@3/5/10 >= 70/88/96 (%s)\n",
                g.p50 <= 2 ? "met" : "NOT met",
                g.aa3 >= 70 && g.aa5 >= 88 && g.aa10 >= 96 ? "met" : "NOT met");
    // What AA could reach on this set: every answered image as good as the average right one
    // (focal within 5 %, every direction within 3°), the refused ones still refused. A refusal
    // costs its three directions at every threshold (room_030, one wall corner).
    {
        double sum = 0;
        int nright = 0, answered = 0;
        for (const auto& x : r.global) {
            answered += x.ok;
            if (x.ok && x.focal_err < 0.05 &&
                std::max({x.dir_err[0], x.dir_err[1], x.dir_err[2]}) < 3) {
                sum += x.dir_err[0] + x.dir_err[1] + x.dir_err[2];
                nright += 3;
            }
        }
        const double m = nright ? sum / nright : 0;
        const int n = 3 * (int)r.global.size();
        auto bound = [&](double t) {
            return 100 *
                   (1 - (3 * (n / 3 - answered) * t + 3 * answered * std::min(m, t)) / (n * t));
        };
        std::printf(
            "AA@3/5/10 if every answered image were as good as the %d right ones (%.2f deg per "
            "direction on average), %d refused: %.1f / %.1f / %.1f\n",
            nright / 3, m, n / 3 - answered, bound(3), bound(5), bound(10));
    }
    EXPECT_LE(g.p50, 2.0);
    EXPECT_LT(g.p50, o.p50);
    EXPECT_LT(g.p75, o.p75);
    EXPECT_LT(g.p90, o.p90);
    EXPECT_LE(g.failed, o.failed);
    EXPECT_GT(g.aa3, o.aa3);
    EXPECT_GT(g.aa5, o.aa5);
    EXPECT_GT(g.aa10, o.aa10);
}

// The FastLineDetector pass (Params::fld_pass, a second search on LSD + FLD segments, its
// frame taken when the two disagree, at half the confidence) against the LSD segments alone on
// the same images: vanishing directions more accurate at every threshold, fewer large focal
// errors, and no wrong first proposal more confident than the LSD-only search's most confident
// wrong one.
TEST(CalibRooms, FastLineDetectorPassImprovesEveryThreshold) {
    const Results& r = results();
    ASSERT_EQ(r.lsd_only.size(), r.global.size());
    const Summary g = summarise(r.global), l = summarise(r.lsd_only);
    print("lsd+fld", g, r.plain.size());
    print("lsd", l, r.plain.size());
    auto maxOf = [](const std::vector<double>& v) {
        return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
    };
    std::printf(
        "wrong first proposals: LSD + FLD %d (highest confidence %.3f), LSD only %d "
        "(highest %.3f)\n",
        (int)r.first_wrong.size(), maxOf(r.first_wrong), (int)r.lsd_first_wrong.size(),
        maxOf(r.lsd_first_wrong));
    EXPECT_GT(g.aa3, l.aa3);
    EXPECT_GT(g.aa5, l.aa5);
    EXPECT_GT(g.aa10, l.aa10);
    EXPECT_LE(g.p75, l.p75);
    EXPECT_LE(g.p90, l.p90);
    EXPECT_LE(g.over10, l.over10);
    EXPECT_LE(g.failed, l.failed);
    EXPECT_LE(maxOf(r.first_wrong), maxOf(r.lsd_first_wrong));
}

// A focal prior (EXIF) 5 % off the truth narrows the search and the refinement: fewer large
// focal errors (p75, p90), more accurate directions, and no more images refused. (The median is
// not asserted: a prior 5 % off pulls images already within 1–2 % towards 5 %. Measured 1.52 %
// with the prior against 1.33 % without; with the prior, the LSD pass's frame of room_023 had
// its focal length within 0.6 % but two directions 4.1–4.6° off, and the FLD pass's frame now
// taken is 3.0 % off with every direction within 1.3°.)
TEST(CalibRooms, FocalPriorFivePercentOffHelps) {
    const Results& r = results();
    ASSERT_EQ(r.prior.size(), r.global.size());
    const Summary g = summarise(r.global), w = summarise(r.prior);
    print("global", g, r.plain.size());
    print("+prior", w, r.plain.size());
    EXPECT_LT(w.p75, g.p75);
    EXPECT_LT(w.p90, g.p90);
    EXPECT_GE(w.aa3, g.aa3);
    EXPECT_GE(w.aa5, g.aa5);
    EXPECT_GE(w.aa10, g.aa10);
    // The prior must not cost an answer: before refused frames led to more refinements, the
    // bare corner room_016 was refused with the prior (2 refusals against 1 without).
    EXPECT_LE(w.failed, g.failed);
}

TEST(CalibRooms, ConfidenceFallsForWrongProposals) {
    const Results& r = results();
    ASSERT_FALSE(r.conf_right.empty());
    ASSERT_FALSE(r.conf_wrong.empty());
    auto mean = [](const std::vector<double>& v) {
        return std::accumulate(v.begin(), v.end(), 0.0) / v.size();
    };
    std::printf("proposals: %d right (mean confidence %.3f), %d wrong (mean %.3f), %d ambiguous\n",
                (int)r.conf_right.size(), mean(r.conf_right), (int)r.conf_wrong.size(),
                mean(r.conf_wrong), r.ambiguous);
    std::printf(
        "first proposals: %d right (mean confidence %.3f, min %.3f), %d wrong (mean %.3f, max "
        "%.3f); flagged ambiguous: %d of the right, %d of the wrong\n",
        (int)r.first_right.size(), mean(r.first_right),
        *std::min_element(r.first_right.begin(), r.first_right.end()), (int)r.first_wrong.size(),
        r.first_wrong.empty() ? 0.0 : mean(r.first_wrong),
        r.first_wrong.empty() ? 0.0 : *std::max_element(r.first_wrong.begin(), r.first_wrong.end()),
        r.amb_right, r.amb_wrong);
    EXPECT_LT(mean(r.conf_wrong), 0.5 * mean(r.conf_right));
    // The first proposal is what detect() and the annotator use: wrong ones must score lower.
    ASSERT_FALSE(r.first_wrong.empty());
    EXPECT_LT(mean(r.first_wrong), 0.5 * mean(r.first_right));
}

// "Ambiguous" is for the user to look at two frames: it must fire on a larger share of the wrong
// first proposals than of the right ones, and on few right ones.
TEST(CalibRooms, AmbiguousFlagFiresMostlyOnWrongAnswers) {
    const Results& r = results();
    ASSERT_FALSE(r.first_right.empty());
    ASSERT_FALSE(r.first_wrong.empty());
    const double fr = double(r.amb_right) / r.first_right.size(),
                 fw = double(r.amb_wrong) / r.first_wrong.size();
    std::printf("ambiguous: %d of %d right first proposals (%.0f %%), %d of %d wrong (%.0f %%)\n",
                r.amb_right, (int)r.first_right.size(), 100 * fr, r.amb_wrong,
                (int)r.first_wrong.size(), 100 * fw);
    EXPECT_GT(fw, fr);
    EXPECT_LE(fr, 0.15);
}

// Started from the true frame (true focal length and rotation) on the detected segments, the
// refinement moves the focal length by what the segments support: on most images little, on
// the few where one vanishing point rests on a handful of short segments or sits near the image
// centre (so that f is weakly determined) by up to 21 %, but never by much more than the
// uncertainty the refinement itself reports (focal_rel_sigma). So those errors come from the
// data, not from a bias of the objective, and the reported sigma (which lowers the confidence)
// is the signal for them.
TEST(CalibRooms, RefinementFromTheTrueFrameStaysWithinItsUncertainty) {
    const Results& r = results();
    ASSERT_GE(r.truth_drift.size(), 20u);
    std::vector<double> a, z;
    double z2 = 0;
    for (size_t i = 0; i < r.truth_drift.size(); ++i) {
        a.push_back(std::abs(r.truth_drift[i]));
        z.push_back(a.back() / std::max(1e-6, r.truth_sigma[i]));
        z2 += z.back() * z.back();
    }
    std::printf(
        "refinement from the true frame (%d images): |focal drift| median %.2f %%, p75 %.2f %%, "
        "p90 %.2f %%, max %.2f %%; drift / own sigma: median %.2f, max %.2f, rms %.2f\n",
        (int)a.size(), 100 * percentile(a, 0.5), 100 * percentile(a, 0.75),
        100 * percentile(a, 0.9), 100 * percentile(a, 1.0), percentile(z, 0.5), percentile(z, 1.0),
        std::sqrt(z2 / z.size()));
    EXPECT_LE(percentile(a, 0.5), 0.02);  // measured 1.05 %
    EXPECT_LE(percentile(z, 1.0), 3.0);   // measured 2.77 (room_012)
}

// The edge-pixel likelihood (Params::edgel_scoring, off by default) against the segments alone,
// on the same images in the same run: frames found by every edge pixel from the strongest
// vanishing point (room_016's soft wall-ceiling edges) and frames the edgels favour among the
// hypotheses join the refined ones. Measured (on top of the FLD pass): focal median / p90
// 1.33 / 14.69 -> 1.22 / 4.26 %, AA@3/5/10 80.3 / 85.1 / 88.8 -> 82.4 / 87.9 / 92.0, images off
// by more than 10 % 3 -> 1; its wrong first proposal stays less confident (0.127 against a mean
// of 0.420 for the right ones).
TEST(CalibRooms, EdgelScoringAgainstSegmentsAlone) {
    const Results& r = results();
    ASSERT_EQ(r.edgels.size(), r.global.size());
    const Summary g = summarise(r.global), e = summarise(r.edgels), gp = summarise(r.prior),
                  ep = summarise(r.edgels_prior);
    print("segments", g, r.plain.size());
    print("+edgels", e, r.plain.size());
    print("seg+prior", gp, r.plain.size());
    print("edg+prior", ep, r.plain.size());
    auto mean = [](const std::vector<double>& v) {
        return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / v.size();
    };
    std::printf(
        "edgels, first proposals: %d right (mean confidence %.3f, min %.3f), %d wrong "
        "(mean %.3f, max %.3f)\n",
        (int)r.edg_first_right.size(), mean(r.edg_first_right),
        r.edg_first_right.empty()
            ? 0.0
            : *std::min_element(r.edg_first_right.begin(), r.edg_first_right.end()),
        (int)r.edg_first_wrong.size(), mean(r.edg_first_wrong),
        r.edg_first_wrong.empty()
            ? 0.0
            : *std::max_element(r.edg_first_wrong.begin(), r.edg_first_wrong.end()));
    EXPECT_LE(e.p50, 2.0);
    EXPECT_LT(e.p90, g.p90);
    EXPECT_LE(e.over10, g.over10);
    EXPECT_LE(e.failed, g.failed);
    EXPECT_GT(e.aa10, g.aa10);
    EXPECT_GE(e.aa5, g.aa5);
    // With the prior only the widened hypotheses act (no frames from one vanishing point): the
    // figures are the same to 0.01 (p90 4.424 vs 4.423 %, AA@10 90.6 both).
    EXPECT_LE(ep.over10, gp.over10);
    EXPECT_LE(ep.p90, gp.p90 + 0.1);
    EXPECT_GE(ep.aa10, gp.aa10 - 0.1);
    EXPECT_LT(mean(r.edg_first_wrong), 0.5 * mean(r.edg_first_right));
}

TEST(CalibRooms, PlumbLineDistortionWithinTenPercent) {
    const Results& r = results();
    ASSERT_GE(r.distorted.size(), 4u);
    // k1 is only as good as the Manhattan frame it is estimated with: the 10 % aim is asserted
    // on the images whose frame is right (focal within 10 %); all images are printed.
    std::vector<double> rel, rel_found, fk, fn;
    for (size_t i = 0; i < r.distorted.size(); ++i) {
        rel.push_back(std::abs(r.dist_k1[i].k1 / r.distorted[i].k1 - 1));
        if (r.dist_k1[i].focal_err < 0.1) rel_found.push_back(rel.back());
        fk.push_back(r.dist_k1[i].focal_err);
        fn.push_back(r.dist_nok1[i].focal_err);
    }
    std::printf(
        "distorted renders: k1 relative error median %.1f %%, max %.1f %% (all %d); "
        "median %.1f %% over the %d with focal within 10 %%; focal error median %.2f %% "
        "with k1, %.2f %% without\n",
        100 * percentile(rel, 0.5), 100 * percentile(rel, 1.0), (int)rel.size(),
        rel_found.empty() ? 100.0 : 100 * percentile(rel_found, 0.5), (int)rel_found.size(),
        100 * percentile(fk, 0.5), 100 * percentile(fn, 0.5));
    ASSERT_GE(rel_found.size(), rel.size() / 2);
    EXPECT_LE(percentile(rel_found, 0.5), 0.10);
    EXPECT_LT(percentile(fk, 0.5), percentile(fn, 0.5));
}

// The proposals of one image label the same segments (those of the first): the FLD pass's
// frame and the LSD pass's come from different segment sets, and the annotator's page can only
// regroup the segments it shows (it ignored a proposal whose labels did not match them).
TEST(CalibRooms, ProposalsLabelTheFirstProposalsSegments) {
    const Results& r = results();
    std::printf("proposals after the first: %d, on other segments: %d\n", r.later_proposals,
                r.later_off_segments);
    EXPECT_GT(r.later_proposals, 0);
    EXPECT_EQ(r.later_off_segments, 0);
}

}  // namespace
