// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The renderer with Params::threads = 0 runs in the caller's TBB arena, so cv::vbme::runLimited
// bounds its threads without the process-wide cv::setNumThreads; the image does not change.
#include <gtest/gtest.h>

#include <mutex>
#include <set>
#include <thread>

#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/render.hpp>
#include <tbb/task_scheduler_observer.h>

#include "test_render_util.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

// Records every thread that enters any TBB arena while it observes.
class ThreadRecorder : public tbb::task_scheduler_observer {
public:
    ThreadRecorder() { observe(true); }
    ~ThreadRecorder() override { observe(false); }
    void on_scheduler_entry(bool) override {
        std::lock_guard<std::mutex> l(m_);
        ids_.insert(std::this_thread::get_id());
    }
    size_t count() {
        std::lock_guard<std::mutex> l(m_);
        return ids_.size();
    }

private:
    std::mutex m_;
    std::set<std::thread::id> ids_;
};

Scene litRoom() {
    Scene s;
    s.image_size = Size(96, 64);
    s.has_room = true;
    s.room.min = Vec3d(-2, -2, 0);
    s.room.max = Vec3d(2, 3, 2.5);
    Light l;
    l.type = Light::POINT;
    l.position = Vec3d(0.3, 0.5, 2.0);
    l.intensity = Vec3d(6, 6, 5);
    s.lights = {l};
    s.camera = vbme_test::lookAt(Vec3d(0, -1.5, 1.2), Vec3d(0.2, 2, 0.8), 60, s.image_size);
    s.camera.response = Response::LINEAR;
    return s;
}

}  // namespace

TEST(RenderThreads, RunLimitedBoundsTheDefaultThreadCount) {
    const Scene s = litRoom();
    Ptr<RenderScene> rs = RenderScene::create(s);
    Renderer::Params p;
    p.spp = 8;
    p.max_depth = 2;
    p.threads = 0;
    Ptr<Renderer> r = Renderer::create(p);
    RenderImages free_img, limited_img;
    size_t free_threads = 0, limited_threads = 0;
    {
        ThreadRecorder rec;
        r->render(*rs, s.camera, free_img);
        free_threads = rec.count();
    }
    const int cv_threads = getNumThreads();
    runLimited(1, [&] {
        ThreadRecorder rec;
        r->render(*rs, s.camera, limited_img);
        limited_threads = rec.count();
    });
    std::printf("[ MEASURED ] renderer threads: %zu free (concurrency %d), %zu in runLimited(1)\n",
                free_threads, currentConcurrency(), limited_threads);
    EXPECT_EQ(limited_threads, 1u);
    if (currentConcurrency() >= 2) {
        EXPECT_GE(free_threads, 2u);
    }
    EXPECT_EQ(getNumThreads(), cv_threads);
    // Bitwise the same image for any thread count (DESIGN, randomness).
    ASSERT_GT(norm(free_img.color, NORM_L1), 0.0);
    EXPECT_EQ(norm(free_img.color, limited_img.color, NORM_INF), 0.0);
}
