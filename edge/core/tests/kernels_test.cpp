// Every kernel variant other than the portable C ("avx2" on x86-64, "neon" on aarch64) against the
// portable C ("generic") on the same inputs, bit for bit: subtraction (masks and counts), the 3x3
// clean-up and carving (the bitset and its counts, every rule, leaves with 16-bit and with full
// pixel offsets). Random inputs and the edges: every width from 1 to 70 (each tail length of a 16-
// and 32-pixel step), the Pi Global Shutter camera's 1456, bytes at 0 and 255, thresholds that
// saturate. A variant this CPU cannot run is skipped; the arm64 build runs "neon" under qemu-aarch64.
#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "synth.hpp"
#include "voxcap/edge/bgmodel.h"
#include "voxcap/edge/carver.h"
#include "voxcap/edge/cleanup.h"

namespace {

class KernelVariant : public ::testing::TestWithParam<const char*> {
 protected:
  void SetUp() override {
    const int err = vc_edge_kernel_select(GetParam());
    if (err == -ENOTSUP) GTEST_SKIP() << GetParam() << " kernels do not run on this CPU";
    ASSERT_EQ(err, 0);
  }
  void TearDown() override { vc_edge_kernel_select("auto"); }
  // Runs f under "generic" and under the variant; f returns what must be equal.
  template <class F>
  void expect_same(F f, const std::string& what) {
    ASSERT_EQ(vc_edge_kernel_select("generic"), 0);
    const auto want = f();
    ASSERT_EQ(vc_edge_kernel_select(GetParam()), 0);
    ASSERT_STREQ(vc_edge_kernel_name(), GetParam());
    const auto got = f();
    EXPECT_TRUE(got == want) << what << ": " << GetParam() << " differs from generic";
  }
};

struct ModelDeleter {
  void operator()(vc_bgmodel* m) const { vc_bgmodel_free(m); }
};
using ModelPtr = std::unique_ptr<vc_bgmodel, ModelDeleter>;

// A model of w x h learnt from `frames` random frames around a random background (noise up to
// +-amp grey levels; some pixels pinned at 0 or 255, where the thresholds saturate).
ModelPtr random_model(int w, int h, int frames, int amp, std::mt19937& rng) {
  vc_bgmodel* raw = nullptr;
  char why[200];
  EXPECT_EQ(vc_bgmodel_new(w, h, &raw, why, sizeof why), 0) << why;
  ModelPtr m(raw);
  const size_t n = static_cast<size_t>(w) * h * 3;
  std::vector<uint8_t> bg(n), f(n);
  std::uniform_int_distribution<int> byte(0, 255), noise(-amp, amp), pick(0, 15);
  for (auto& v : bg) {
    const int p = pick(rng);
    v = static_cast<uint8_t>(p == 0 ? 0 : p == 1 ? 255 : byte(rng));
  }
  for (int k = 0; k < frames; k++) {
    for (size_t i = 0; i < n; i++) f[i] = static_cast<uint8_t>(std::clamp(bg[i] + noise(rng), 0, 255));
    EXPECT_EQ(vc_bgmodel_learn(m.get(), f.data(), static_cast<size_t>(w) * 3), 0);
  }
  EXPECT_EQ(vc_bgmodel_finish(m.get()), 0);
  return m;
}

// A frame over the model's mean: background with noise, shadowed patches (scaled down), foreground
// of random colour, and extremes; stride with padding.
std::vector<uint8_t> random_frame(const vc_bgmodel* m, size_t stride, std::mt19937& rng) {
  const int w = vc_bgmodel_width(m), h = vc_bgmodel_height(m);
  const uint8_t* mean = vc_bgmodel_mean(m);
  std::vector<uint8_t> f(stride * static_cast<size_t>(h), 0xA5);
  std::uniform_int_distribution<int> byte(0, 255), noise(-6, 6), kind(0, 9);
  std::uniform_real_distribution<double> gain(0.2, 1.0);
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++) {
      const int k = kind(rng);
      const double g = gain(rng);
      for (int c = 0; c < 3; c++) {
        const int mu = mean[(static_cast<size_t>(y) * w + x) * 3 + c];
        int v = mu + noise(rng);
        if (k == 0) v = byte(rng);                                        // foreground
        if (k == 1 || k == 2) v = static_cast<int>(mu * g) + noise(rng);  // shadow-like
        if (k == 3) v = c == 0 ? 0 : 255;                                 // extremes
        f[static_cast<size_t>(y) * stride + static_cast<size_t>(x) * 3 + c] =
            static_cast<uint8_t>(std::clamp(v, 0, 255));
      }
    }
  return f;
}

TEST_P(KernelVariant, SubtractEqualsGenericBitForBit) {
  std::mt19937 rng(1601);
  std::vector<std::pair<int, int>> sizes;
  for (int w = 1; w <= 70; w++) sizes.emplace_back(w, 1 + w % 4);
  for (auto s : {std::pair{127, 9}, {128, 5}, {129, 7}, {640, 6}, {1456, 4}}) sizes.push_back(s);
  for (const auto& size : sizes) {
    const int w = size.first, h = size.second;
    ModelPtr m = random_model(w, h, 6, 5, rng);
    vc_subtract_params p;
    vc_subtract_params_default(&p);
    std::uniform_real_distribution<double> tl(0.5, 4.0), tu(4.0, 80.0);
    for (int round = 0; round < 3; round++) {
      if (round > 0) {  // vary the thresholds, the texture tests on and off
        p.t_lower = tl(rng);
        p.t_upper = tu(rng);
        p.shadow_texture_k = round == 1 ? 0.0 : 1.5;
        p.shadow_flat_margin = round == 1 ? 0.0 : 0.1;
      }
      ASSERT_EQ(vc_bgmodel_set_params(m.get(), &p), 0);
      const size_t stride = static_cast<size_t>(w) * 3 + static_cast<size_t>(round) * 5;
      const std::vector<uint8_t> frame = random_frame(m.get(), stride, rng);
      expect_same(
          [&] {
            std::vector<uint8_t> mask(static_cast<size_t>(w) * h, 0x5A);
            vc_subtract_stats st{};
            EXPECT_EQ(vc_subtract(m.get(), frame.data(), stride, mask.data(), &st), 0);
            return std::make_pair(mask, std::make_pair(st.band, st.shadow));
          },
          "subtract " + std::to_string(w) + "x" + std::to_string(h) + " round " + std::to_string(round));
    }
  }
}

TEST_P(KernelVariant, CleanupEqualsGenericBitForBit) {
  std::mt19937 rng(1602);
  for (int w = 1; w <= 70; w += 3)
    for (double density : {0.05, 0.5, 0.95}) {
      const int h = 1 + w % 7;
      std::bernoulli_distribution on(density);
      std::vector<uint8_t> in(static_cast<size_t>(w) * h);
      for (auto& v : in) v = on(rng) ? static_cast<uint8_t>(1 + rng() % 255) : 0;
      for (int it : {0, 1, 2}) {
        expect_same(
            [&] {
              std::vector<uint8_t> m = in, scratch(vc_cleanup_scratch_size(w));
              EXPECT_EQ(vc_cleanup(m.data(), w, h, it, scratch.data(), scratch.size()), 0);
              return m;
            },
            "cleanup " + std::to_string(w) + "x" + std::to_string(h));
      }
    }
}

struct CarverDeleter {
  void operator()(vc_carver* c) const { vc_carver_free(c); }
};

// A mask of blobs (whole tiles in and out) with speckle noise (partial leaves everywhere).
std::vector<uint8_t> blob_mask(int w, int h, std::mt19937& rng) {
  std::vector<uint8_t> m(static_cast<size_t>(w) * h, 0);
  std::uniform_real_distribution<double> u(0, 1);
  const double cx = w * (0.3 + 0.4 * u(rng)), cy = h * (0.3 + 0.4 * u(rng)), r = 0.25 * std::min(w, h);
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++) {
      const bool in = (x - cx) * (x - cx) + (y - cy) * (y - cy) < r * r;
      const double flip = u(rng);
      m[static_cast<size_t>(y) * w + x] = (in ? flip > 0.1 : flip < 0.08) ? 255 : 0;
    }
  return m;
}

TEST_P(KernelVariant, CarveEqualsGenericBitForBit) {
  std::mt19937 rng(1603);
  const double none[5] = {0, 0, 0, 0, 0}, barrel[5] = {-0.12, 0.03, 0.001, -0.001, 0};
  const double target[3] = {0, 0, 0.9};
  struct Case {
    double eye0[3], eye1[3];
    int w, h;
    const double* dist;
  };
  // Far cameras (16-bit leaf offsets) and one close, wide camera at the GS camera's native size
  // (leaves whose pixels spread too far for 16 bits: full indices).
  const Case cases[] = {{{3.0, 0.2, 1.2}, {0.3, 3.1, 1.4}, 320, 240, none},
                        {{-2.5, 1.5, 1.0}, {2.0, -2.2, 1.6}, 160, 120, barrel},
                        {{1.1, 0.1, 1.0}, {0.1, 1.2, 1.1}, 1456, 1088, barrel}};
  const vc_voxel_grid grid{32, 32, 32, {-0.8, -0.8, 0.1}, 1.6 / 32};
  for (const Case& c : cases)
    for (vc_carve_rule rule : {VC_CARVE_CENTRE, VC_CARVE_FOOTPRINT, VC_CARVE_SUBPIXEL}) {
      const vc_camera cam0 = vc::edge_test::look_at(c.eye0, target, c.w, c.h, 0.9 * c.w, c.dist);
      const vc_camera cam1 = vc::edge_test::look_at(c.eye1, target, c.w, c.h, 0.9 * c.w, c.dist);
      vc_carver* raw = nullptr;
      char why[200];
      ASSERT_EQ(vc_carver_new(&grid, &cam0, &cam1, rule, &raw, why, sizeof why), 0) << why;
      std::unique_ptr<vc_carver, CarverDeleter> cv(raw);
      for (int frame = 0; frame < (c.w > 1000 ? 1 : 2); frame++) {
        const std::vector<uint8_t> m0 = blob_mask(c.w, c.h, rng), m1 = blob_mask(c.w, c.h, rng);
        expect_same(
            [&] {
              std::vector<uint8_t> bits(vc_carver_bitset_bytes(cv.get()), 0xEE);
              vc_carve_stats st{};
              EXPECT_EQ(vc_carver_run(cv.get(), m0.data(), m1.data(), bits.data(), &st), 0);
              return std::make_pair(bits, std::vector<uint64_t>{st.occupied, st.blocks_skipped,
                                                                st.blocks_filled, st.leaves_tested});
            },
            "carve " + std::to_string(c.w) + "x" + std::to_string(c.h) + " rule " + std::to_string(rule));
      }
    }
}

INSTANTIATE_TEST_SUITE_P(Kernels, KernelVariant, ::testing::Values("avx2", "neon"),
                         [](const auto& p) { return std::string(p.param); });

TEST(EdgeKernels, AutoPicksTheVectorVariantOfThisCpu) {
  ASSERT_EQ(vc_edge_kernel_select("auto"), 0);
  const std::string name = vc_edge_kernel_name();
#if defined(__aarch64__)
  EXPECT_EQ(name, "neon");
#elif defined(__x86_64__)
  EXPECT_TRUE(name == "avx2" || name == "generic") << name;
  EXPECT_EQ(vc_edge_kernel_select("neon"), -ENOTSUP);
#endif
}

}  // namespace
