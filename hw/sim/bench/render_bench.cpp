// Rendering speed of the virtual rig (Google Benchmark). CTest only smoke-runs it (label bench);
// the figures come from a release build: build/<dir>/bin/sim_render_bench.
#include <benchmark/benchmark.h>

#include <memory>

#include "voxcap/sim/scene.hpp"

namespace {

using vc::sim::Scene;
using vc::sim::SceneOptions;

std::unique_ptr<Scene> make_scene(const char* motion, int width, int height, bool distortion, bool shadows = true) {
  SceneOptions o;
  o.shadows = shadows;
  o.motion.source = motion;
  o.rig.width = width;
  o.rig.height = height;
  o.rig.distortion = distortion;
  o.noise_sigma = 2.0;
  o.flicker = 0.03;
  auto s = std::make_unique<Scene>(o);
  cv::Mat warm;
  for (int c = 0; c < s->camera_count(); ++c) s->render_background_clean(c, warm);  // build the caches
  return s;
}

// One camera frame with noise and flicker, cycling over frames and the 6 cameras.
void BM_RenderFrame(benchmark::State& state) {
  const char* motions[] = {"walk", "arms-close", "squat"};
  auto scene = make_scene(motions[state.range(2)], static_cast<int>(state.range(0)), static_cast<int>(state.range(1)), true);
  cv::Mat rgb, sil;
  int i = 0;
  for (auto _ : state) {
    scene->render(90 + i / 6, i % 6, rgb, &sil);
    ++i;
    benchmark::DoNotOptimize(rgb.data);
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(motions[state.range(2)]);
}
BENCHMARK(BM_RenderFrame)->Args({640, 480, 0})->Args({640, 480, 1})->Args({640, 480, 2})->Args({320, 240, 0})
    ->Unit(benchmark::kMillisecond);

void BM_RenderClean(benchmark::State& state) {
  auto scene = make_scene("walk", 640, 480, true, state.range(0) != 0);
  cv::Mat rgb;
  int i = 0;
  for (auto _ : state) {
    scene->render_clean(90 + i / 6, i % 6, rgb);
    ++i;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RenderClean)->Arg(1)->Arg(0)->ArgName("shadows")->Unit(benchmark::kMillisecond);

void BM_RenderBackground(benchmark::State& state) {
  auto scene = make_scene("walk", 640, 480, true);
  cv::Mat rgb;
  int i = 0;
  for (auto _ : state) {
    scene->render_background(i % 6, i, rgb);
    ++i;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RenderBackground)->Unit(benchmark::kMillisecond);

// The per-camera precomputation (rays, room image): paid once per camera, on first use.
void BM_CameraCache(benchmark::State& state) {
  for (auto _ : state) {
    SceneOptions o;
    o.rig.distortion = true;
    o.rig.cameras = 2;
    Scene s(o);
    cv::Mat rgb;
    s.render_background_clean(0, rgb);
  }
}
BENCHMARK(BM_CameraCache)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_Occupancy(benchmark::State& state) {
  auto scene = make_scene("walk", 64, 48, false);
  const auto grid = *scene->calibration().grid;  // 2 cm voxels over the volume
  std::vector<std::uint8_t> bits;
  int i = 0;
  for (auto _ : state) scene->occupancy(grid, 90 + i++, &bits);
  state.SetLabel(std::to_string(grid.nx) + "x" + std::to_string(grid.ny) + "x" + std::to_string(grid.nz));
}
BENCHMARK(BM_Occupancy)->Unit(benchmark::kMillisecond);

void BM_Features(benchmark::State& state) {
  auto scene = make_scene("walk", 64, 48, false);
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(scene->features(90 + i / 6, i % 6));
    ++i;
  }
}
BENCHMARK(BM_Features)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
