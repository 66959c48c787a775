// Cost of one segmentation (edge/segment) per camera: the true silhouette of wave's initialization
// frame from hw/sim's front camera (0) and a side camera (2) at 320x240, 640x480 and 1456x1088. It runs
// at initialization and on re-acquisition, not per frame. CTest only smoke-runs it (label bench).
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>

#include "voxcap/edge/segment.hpp"
#include "voxcap/sim/scene.hpp"

namespace {

cv::Mat1b init_mask(int width, int height, int cam) {
  vc::sim::SceneOptions o;
  o.motion.source = "wave";
  o.rig.width = width;
  o.rig.height = height;
  const vc::sim::Scene scene(o);
  cv::Mat rgb, sil;
  scene.render_clean(0, cam, rgb, &sil);
  return sil;
}

void BM_Segment(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const cv::Mat1b mask = init_mask(w, h, static_cast<int>(state.range(2)));
  bool ok = true;
  for (auto _ : state) {
    (void)_;
    const vc::segment::Segmentation s = vc::segment::segment(mask);
    ok = ok && s.ok;
    benchmark::DoNotOptimize(s.point);
  }
  if (!ok) state.SkipWithError("segmentation failed");
  state.SetLabel("camera " + std::to_string(state.range(2)));
}
BENCHMARK(BM_Segment)
    ->Args({320, 240, 0})
    ->Args({640, 480, 0})
    ->Args({640, 480, 2})
    ->Args({1456, 1088, 0})
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
