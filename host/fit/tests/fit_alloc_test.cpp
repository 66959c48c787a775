// The fitter's per-frame path allocates nothing once warmed up: operator new is counted around
// fit() calls on a whole motion (this test binary replaces the global operator new/delete).
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <random>

#include "voxcap/fit/fitter.hpp"
#include "voxcap/fit/synthetic.hpp"

namespace {
std::atomic<long> g_news{0};
}

void* operator new(std::size_t n) {
  g_news.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
  g_news.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete[](void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  std::free(p);
}

namespace vc::fit {
namespace {

TEST(FitAllocation, NoAllocationPerFrameAfterWarmUp) {
  for (const char* motion : {"cross", "turn"}) {
    SCOPED_TRACE(motion);
    sim::SceneOptions so;
    so.motion.source = motion;
    const sim::Scene scene(so);
    const rig::VoxelGrid grid = *scene.calibration().grid;
    config::FittingOptions opt;
    opt.smoothing = config::Smoothing::OneEuro;
    Fitter fitter(grid, opt, 60);
    std::mt19937_64 rng(3);
    testing::FeatureNoise noise;
    noise.drop_feature = VC_FEATURE_LEFT_HAND;  // the prediction path too
    noise.drop_from = 150;
    noise.drop_to = 170;
    long during = 0, warm_up = 0;
    int fitted = 0;
    for (int frame = 0; frame < 260; ++frame) {
      const pipeline::Frame f = testing::synthetic_frame(scene, grid, frame, noise, rng);
      const long before = g_news.load();
      const pipeline::Pose pose = fitter.fit(f);
      const long n = g_news.load() - before;
      (frame >= 30 ? during : warm_up) += n;  // initialization (frames 0..9) allocates
      fitted += pose.valid() ? 1 : 0;
    }
    EXPECT_GT(fitted, 240);
    EXPECT_GT(warm_up, 0);  // the counter sees the initialization's measurements
    EXPECT_EQ(during, 0);
  }
}

}  // namespace
}  // namespace vc::fit
