// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The tracker on phone-like footage rendered by Blender (scripts/blender/track_ball_clip.py,
// made into H.264 phone media by scripts/blender/phone_media.sh): a pale ball rolling away on
// a glossy warm-brown table that mirrors it, with motion blur, noise, a same-hue bat, a box
// hiding the ball for a stretch, and the same file stored portrait with a rotation flag. The
// truth (disk at mid-exposure, visible fraction) comes from Blender's camera, not from vbme.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/track.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {

const std::string kData = VBME_TEST_DATA_DIR;

// Visible: at least this fraction of the truth disk shows in Blender's object-index mask (motion
// blur alone takes up to ~12 % off a fast ball's mask). Hidden: at most this fraction shows.
constexpr double kVisible = 0.85, kHidden = 0.02;

struct Truth {
    Disk disk;
    double visible = 0;
};

std::vector<Truth> readTruth(const std::string& path) {
    std::ifstream in(path);
    EXPECT_TRUE(in.good()) << path;
    std::string line;
    std::getline(in, line);  // header
    std::vector<Truth> t;
    while (std::getline(in, line)) {
        std::stringstream ss(line);
        std::string v[5];
        for (auto& s : v)
            std::getline(ss, s, ',');
        Truth x;
        x.disk = Disk(Point2f(std::stof(v[1]), std::stof(v[2])), std::stof(v[3]));
        x.visible = std::stod(v[4]);
        t.push_back(x);
    }
    return t;
}

// Landscape truth (coded W×H) as shown after a 90° clockwise display rotation (H×W).
Truth rotateCW(const Truth& t, Size coded) {
    Truth r = t;
    r.disk.center = Point2f(coded.height - 1 - t.disk.center.y, t.disk.center.x);
    return r;
}

struct Score {
    std::vector<ObjectTracker::Result> results;
    std::vector<double> iou, err;  // err in units of the true radius
    int visible = 0, visible_ok = 0, hidden = 0, hidden_lost = 0, lost = 0;
    double mean_iou = 0, mean_err = 0, mean_conf_visible = 0, mean_conf_hidden = 0;
    double seconds = 0;
};

Score trackFile(const std::string& video, const Mat& first_mask, const std::vector<Truth>& truth,
                const ObjectTracker::Params& p, const char* tag) {
    Score s;
    VideoReader reader(video);
    Ptr<ObjectTracker> t = ObjectTracker::create(p);
    Mat frame, mask, tmask;
    int i = 0;
    TickMeter tm;
    while (reader.read(frame)) {
        EXPECT_LT(i, (int)truth.size());
        if (i >= (int)truth.size()) break;
        tm.start();
        if (i == 0) {
            t->init(frame, first_mask);
            std::printf("%s: %s\n", tag, t->initReport().c_str());
        }
        const ObjectTracker::Result r = t->update(frame, mask);
        tm.stop();
        s.results.push_back(r);
        const Truth& tr = truth[i];
        diskMask(frame.size(), tr.disk, tmask);
        const double iou = r.found ? maskIoU(mask, tmask) : 0.0;
        const double err = r.found ? norm(r.disk.center - tr.disk.center) / tr.disk.radius : 1e9;
        s.iou.push_back(iou);
        s.err.push_back(err);
        if (!r.found) ++s.lost;
        if (tr.visible >= kVisible) {
            ++s.visible;
            s.mean_iou += iou;
            s.mean_err += std::min(err, 10.0);
            s.mean_conf_visible += r.confidence;
            if (iou >= 0.9 && err <= 0.1) ++s.visible_ok;
        } else if (tr.visible <= kHidden) {
            ++s.hidden;
            s.mean_conf_hidden += r.confidence;
            if (!r.found) ++s.hidden_lost;
        }
        if (std::getenv("VBME_KEEP_TEST_FILES")) {
            Mat o = frame.clone();
            circle(o, tr.disk.center, cvRound(tr.disk.radius), Scalar(255, 0, 0), 1, LINE_AA);
            drawTrackingOverlay(o, r, t->lastSearchWindow(), i);
            imwrite(format("/tmp/vbme_phone_%s_%03d.png", tag, i), o);
        }
        ++i;
    }
    EXPECT_EQ(i, (int)truth.size()) << video << ": frame count";
    s.seconds = tm.getTimeSec();
    s.mean_iou /= std::max(1, s.visible);
    s.mean_err /= std::max(1, s.visible);
    s.mean_conf_visible /= std::max(1, s.visible);
    s.mean_conf_hidden /= std::max(1, s.hidden);
    std::printf(
        "%-28s visible %2d: within IoU>=0.9 & err<=0.1r %2d, mean IoU %.3f, mean centre err "
        "%.3f r, conf %.2f | hidden %d: lost %d, conf %.2f | lost total %d | %.0f frames/s\n",
        tag, s.visible, s.visible_ok, s.mean_iou, s.mean_err, s.mean_conf_visible, s.hidden,
        s.hidden_lost, s.mean_conf_hidden, s.lost, (double)s.results.size() / s.seconds);
    return s;
}

// The thesis-era tracker as it was before the joint colour models: HS histograms, IoU
// confidence, no prediction, no radius bound, no re-detection.
ObjectTracker::Params thesisParams() {
    ObjectTracker::Params p;
    p.colour_model = TRACK_COLOUR_HS;
    p.evidence_confidence = false;
    p.predict_motion = false;
    p.max_radius_change = 0;
    p.redetect = false;
    p.edge_refine = false;
    p.min_init_iou = 0;
    return p;
}

// The oracles of issue 13 on one clip.
void expectOracles(const Score& s, const std::vector<Truth>& truth) {
    ASSERT_EQ(s.results.size(), truth.size());
    ASSERT_GT(s.visible, 20);
    ASSERT_GT(s.hidden, 0);
    int reappear = -1;
    for (size_t i = 0; i < truth.size(); ++i) {
        if (truth[i].visible >= kVisible) {
            EXPECT_TRUE(s.results[i].found) << "frame " << i;
            // Issue 13's per-frame oracle, on every visible frame.
            EXPECT_GE(s.iou[i], 0.9) << "visible frame " << i;
            EXPECT_LE(s.err[i], 0.1) << "visible frame " << i << " (centre error / r)";
        } else if (truth[i].visible <= kHidden) {
            EXPECT_FALSE(s.results[i].found) << "hidden frame " << i;
            EXPECT_LT(s.results[i].confidence, 0.5f) << "hidden frame " << i;
        }
        // Reappearing: the first frame after the hidden stretch with half the ball in view.
        if (reappear < 0 && truth[i].visible >= 0.5 && i > 0 && s.hidden > 0) {
            bool after_hidden = false;
            for (size_t j = 0; j < i; ++j)
                after_hidden = after_hidden || truth[j].visible <= kHidden;
            if (after_hidden) reappear = (int)i;
        }
    }
    // The margin: the worst visible frames.
    double min_iou = 1, max_err = 0;
    int at_iou = -1, at_err = -1;
    for (size_t i = 0; i < truth.size(); ++i)
        if (truth[i].visible >= kVisible) {
            if (s.iou[i] < min_iou) min_iou = s.iou[i], at_iou = (int)i;
            if (s.err[i] > max_err) max_err = s.err[i], at_err = (int)i;
        }
    std::printf("  worst visible frames: IoU %.3f (frame %d), centre error %.3f r (frame %d)\n",
                min_iou, at_iou, max_err, at_err);
    EXPECT_EQ(s.visible_ok, s.visible);
    EXPECT_GE(s.mean_iou, 0.9);
    EXPECT_LE(s.mean_err, 0.1);
    ASSERT_GE(reappear, 0);
    bool refound = false;
    for (int i = reappear; i <= reappear + 3 && i < (int)truth.size(); ++i)
        refound = refound || (s.results[i].found && s.err[i] <= 0.25);
    EXPECT_TRUE(refound) << "not re-found within 3 frames of reappearing at frame " << reappear;
}

}  // namespace

TEST(TrackPhone, PaleBallOnGlossyTableLandscape) {
    const std::string dir = kData + "/track_pale_ball/";
    const std::vector<Truth> truth = readTruth(dir + "truth.csv");
    const Mat first = imread(dir + "first_mask.png", IMREAD_GRAYSCALE);
    ASSERT_FALSE(first.empty());
    ASSERT_GE(truth.front().disk.radius / truth.back().disk.radius, 3.0);  // shrink ≥ 3×
    const Score s = trackFile(dir + "clip.mp4", first, truth, ObjectTracker::Params(), "landscape");
    const Score old =
        trackFile(dir + "clip.mp4", first, truth, thesisParams(), "landscape thesis HS");
    expectOracles(s, truth);
    // The thesis's model fails here and does not say so (the report).
    EXPECT_LT(old.visible_ok, s.visible_ok);
}

TEST(TrackPhone, PaleBallPortraitWithRotationFlag) {
    const std::string dir = kData + "/track_pale_ball/";
    std::vector<Truth> truth = readTruth(dir + "truth.csv");
    Mat first = imread(dir + "first_mask.png", IMREAD_GRAYSCALE);
    ASSERT_FALSE(first.empty());
    const Size coded = first.size();
    // The portrait file shows the landscape frames turned 90° clockwise.
    VideoReader land(dir + "clip.mp4"), port(dir + "portrait.mp4");
    ASSERT_EQ(port.frameSize(), Size(coded.height, coded.width));
    Mat fl, fp, rl;
    ASSERT_TRUE(land.read(fl) && port.read(fp));
    rotate(fl, rl, ROTATE_90_CLOCKWISE);
    EXPECT_EQ(norm(rl, fp, NORM_INF), 0) << "portrait frame 0 is not landscape frame 0 turned CW";
    rotate(first, first, ROTATE_90_CLOCKWISE);
    for (Truth& t : truth)
        t = rotateCW(t, coded);
    const Score s =
        trackFile(dir + "portrait.mp4", first, truth, ObjectTracker::Params(), "portrait");
    expectOracles(s, truth);
}

TEST(TrackPhone, InseparableBallIsRefusedOnFrameZero) {
    // The ball is made of the table's own varnished wood: no colour model can separate it.
    const std::string dir = kData + "/track_inseparable/";
    VideoReader reader(dir + "clip.mp4");
    Mat frame;
    ASSERT_TRUE(reader.read(frame));
    const Mat first = imread(dir + "first_mask.png", IMREAD_GRAYSCALE);
    ASSERT_EQ(first.size(), frame.size());
    Ptr<ObjectTracker> t = ObjectTracker::create();
    std::string msg;
    try {
        t->init(frame, first);
    } catch (const cv::Exception& e) {
        msg = e.err;
    }
    std::printf("inseparable: %s\n", msg.empty() ? t->initReport().c_str() : msg.c_str());
    EXPECT_NE(msg.find("cannot be told from its background"), std::string::npos) << msg;
    // The separable clip's frame 0 passes the same check.
    const std::string good = kData + "/track_pale_ball/";
    VideoReader r2(good + "clip.mp4");
    ASSERT_TRUE(r2.read(frame));
    Ptr<ObjectTracker> t2 = ObjectTracker::create();
    EXPECT_NO_THROW(t2->init(frame, imread(good + "first_mask.png", IMREAD_GRAYSCALE)));
    std::printf("pale ball: %s\n", t2->initReport().c_str());
    EXPECT_GE(t2->initSelfCheckIoU(), 0.5);
}
