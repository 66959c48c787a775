// Speed of the fixed-point conversions to RGB24, per frame, at the sizes the rig uses (640x480 and
// the IMX296 global-shutter sensor's 1456x1088). Run: build/<preset>/bin/edge_pixconv_bench
#include <benchmark/benchmark.h>

#include <cstdint>
#include <vector>

#include "voxcap/edge/pixconv.h"

namespace {

void convert(benchmark::State& state, vc_pixfmt fmt) {
  const int w = (int)state.range(0), h = (int)state.range(1);
  const size_t src_stride = (size_t)w * vc_pixfmt_bytes_per_pixel(fmt), dst_stride = (size_t)w * 3;
  std::vector<uint8_t> src(src_stride * (size_t)h), dst(dst_stride * (size_t)h);
  for (size_t i = 0; i < src.size(); i++) src[i] = (uint8_t)(i * 2654435761u >> 24);
  vc_yuv_coeffs c;
  vc_yuv_coeffs_init(&c, VC_YUV_BT601, false);
  for (auto _ : state) {
    vc_pixconv_to_rgb(fmt, src.data(), src_stride, dst.data(), dst_stride, w, h, &c);
    benchmark::DoNotOptimize(dst.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * (int64_t)w * h);
  state.counters["ns_per_pixel"] = benchmark::Counter((double)w * h, benchmark::Counter::kIsIterationInvariantRate |
                                                                          benchmark::Counter::kInvert);
}

void BM_Yuyv(benchmark::State& s) { convert(s, VC_PIXFMT_YUYV); }
void BM_Grey(benchmark::State& s) { convert(s, VC_PIXFMT_GREY); }
void BM_Rgb24(benchmark::State& s) { convert(s, VC_PIXFMT_RGB24); }
void BM_Bgr24(benchmark::State& s) { convert(s, VC_PIXFMT_BGR24); }

#define SIZES Args({640, 480})->Args({1456, 1088})->Unit(benchmark::kMicrosecond)
BENCHMARK(BM_Yuyv)->SIZES;
BENCHMARK(BM_Grey)->SIZES;
BENCHMARK(BM_Rgb24)->SIZES;
BENCHMARK(BM_Bgr24)->SIZES;

}  // namespace

BENCHMARK_MAIN();
