// Every kernel variant other than the portable C ("avx2" on x86-64, "neon" on aarch64) against the
// portable C ("generic") on the same inputs, bit for bit: subtraction (masks and counts), the 3x3
// clean-up and carving (the bitset and its counts, every rule, leaves with 16-bit and with full
// pixel offsets). Random inputs and the edges: every width from 1 to 70 (each tail length of a 16-
// and 32-pixel step), the Pi Global Shutter camera's 1456, bytes at 0 and 255, thresholds that
// saturate. A variant this CPU cannot run is skipped; the arm64 build runs "neon" under qemu-aarch64.
// The RLE of the carved bitset (proto's vc_rle_encode, NEON word skip on aarch64) against its portable
// scan, byte for byte: empty, full, alternating, long runs, runs that end at the grid's and the
// vector step's edges, random densities and a hull-like grid.
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
#include "voxcap/rle.h"

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
        p.grow_px = round == 1 ? 0.0 : 3.0;  // the limb-scale cue off and on
      }
      ASSERT_EQ(vc_bgmodel_set_params(m.get(), &p), 0);
      const size_t stride = static_cast<size_t>(w) * 3 + static_cast<size_t>(round) * 5;
      const std::vector<uint8_t> frame = random_frame(m.get(), stride, rng);
      expect_same(
          [&] {
            std::vector<uint8_t> mask(static_cast<size_t>(w) * h, 0x5A);
            std::vector<uint8_t> scratch(vc_cleanup_scratch_size(w));
            vc_subtract_stats st{};
            // The whole sequence: the cue after the clean-up, from the clean-up's bits of each variant.
            EXPECT_EQ(vc_mask_frame(m.get(), frame.data(), stride, mask.data(), 1, scratch.data(),
                                    scratch.size(), &st),
                      0);
            return std::make_pair(mask, std::make_pair(st.band, st.shadow + 1000000u * st.grown));
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

// The carve takes any non-zero mask byte as foreground (the clean-up's cue marks its pixels 128): a
// mask whose foreground bytes are 1, 0x7F, 0x80, 0xFE or 0xFF (the edge cases of the leaves' bit
// packing: no low bit set, only the top bit, all but one) carves exactly as the same mask at 255,
// under the generic kernels and the variant, for every rule and for 16-bit and full-index leaves.
TEST_P(KernelVariant, CarveTakesAnyNonZeroByteAsForeground) {
  std::mt19937 rng(1607);
  const double none[5] = {0, 0, 0, 0, 0}, target[3] = {0, 0, 0.9};
  const double eyes[][2][3] = {{{3.0, 0.2, 1.2}, {0.3, 3.1, 1.4}}, {{1.1, 0.1, 1.0}, {0.1, 1.2, 1.1}}};
  const int sizes[][2] = {{320, 240}, {1456, 1088}};  // far cameras; a close, wide one (full indices)
  const uint8_t values[] = {1, 0x7F, 0x80, 0xFE, 0xFF};
  const vc_voxel_grid grid{32, 32, 32, {-0.8, -0.8, 0.1}, 1.6 / 32};
  for (int c = 0; c < 2; c++)
    for (vc_carve_rule rule : {VC_CARVE_CENTRE, VC_CARVE_FOOTPRINT, VC_CARVE_SUBPIXEL}) {
      const int w = sizes[c][0], h = sizes[c][1];
      const vc_camera cam0 = vc::edge_test::look_at(eyes[c][0], target, w, h, 0.9 * w, none);
      const vc_camera cam1 = vc::edge_test::look_at(eyes[c][1], target, w, h, 0.9 * w, none);
      vc_carver* raw = nullptr;
      char why[200];
      ASSERT_EQ(vc_carver_new(&grid, &cam0, &cam1, rule, &raw, why, sizeof why), 0) << why;
      std::unique_ptr<vc_carver, CarverDeleter> cv(raw);
      const std::vector<uint8_t> m0 = blob_mask(w, h, rng), m1 = blob_mask(w, h, rng);
      std::vector<uint8_t> v0 = m0, v1 = m1;
      for (size_t i = 0; i < v0.size(); i++) {
        if (v0[i] != 0) v0[i] = values[rng() % 5];
        if (v1[i] != 0) v1[i] = values[rng() % 5];
      }
      for (const char* variant : {"generic", GetParam()}) {
        ASSERT_EQ(vc_edge_kernel_select(variant), 0);
        std::vector<uint8_t> want(vc_carver_bitset_bytes(cv.get())), got(want.size());
        vc_carve_stats st{};
        ASSERT_EQ(vc_carver_run(cv.get(), m0.data(), m1.data(), want.data(), &st), 0);
        ASSERT_GT(st.leaves_tested, 0u);
        ASSERT_EQ(vc_carver_run(cv.get(), v0.data(), v1.data(), got.data(), nullptr), 0);
        EXPECT_TRUE(got == want) << variant << " rule " << rule << " at " << w << "x" << h;
      }
    }
}

INSTANTIATE_TEST_SUITE_P(Kernels, KernelVariant, ::testing::Values("avx2", "neon"),
                         [](const auto& p) { return std::string(p.param); });

// nbits bits (ceil(nbits / 8) bytes) starting `offset` bytes into their buffer, so that the vector
// loads see every alignment; the padding bits past nbits are set (the encoders must ignore them).
struct Bits {
  std::vector<uint8_t> buf;
  size_t offset = 0, nbits = 0;
  const uint8_t* data() const { return buf.data() + offset; }
  void set(size_t i) { buf[offset + i / 8] |= static_cast<uint8_t>(1u << (i % 8)); }
};

Bits make_bits(size_t nbits, size_t offset) {
  Bits b;
  b.offset = offset;
  b.nbits = nbits;
  b.buf.assign(offset + (nbits + 7) / 8 + 1, 0);
  if (nbits % 8) b.buf[offset + nbits / 8] = static_cast<uint8_t>(0xFFu << (nbits % 8));
  return b;
}

// Encodes with the default scan and with the portable one: the same code, bytes, length and info,
// also when the output is one byte short (-ENOSPC, the needed size); and the stream decodes back.
void expect_rle_same(const Bits& b, const std::string& what) {
  const size_t cap = vc_rle_max_encoded_size(b.nbits) + 16;
  std::vector<uint8_t> want(cap, 0xCD), got(cap, 0xCD);
  size_t want_len = 0, got_len = 0;
  vc_rle_info want_info{}, got_info{};
  ASSERT_EQ(vc_rle_encode_info_portable(b.data(), b.nbits, want.data(), cap, &want_len, &want_info), 0)
      << what;
  ASSERT_EQ(vc_rle_encode_info(b.data(), b.nbits, got.data(), cap, &got_len, &got_info), 0) << what;
  EXPECT_EQ(got_len, want_len) << what;
  EXPECT_TRUE(got == want) << what << ": " << vc_rle_encode_impl() << " differs from portable";
  EXPECT_EQ(got_info.total, want_info.total) << what;
  EXPECT_EQ(got_info.occupied, want_info.occupied) << what;
  EXPECT_EQ(got_info.runs, want_info.runs) << what;
  if (want_len > 0) {
    size_t short_want = 0, short_got = 0;
    std::vector<uint8_t> a(want_len), c(want_len);
    EXPECT_EQ(vc_rle_encode_info_portable(b.data(), b.nbits, a.data(), want_len - 1, &short_want, nullptr),
              -ENOSPC);
    EXPECT_EQ(vc_rle_encode_info(b.data(), b.nbits, c.data(), want_len - 1, &short_got, nullptr), -ENOSPC);
    EXPECT_EQ(short_got, short_want) << what;
  }
  std::vector<uint8_t> back((b.nbits + 7) / 8 + 1, 0);
  ASSERT_EQ(vc_rle_decode(got.data(), got_len, back.data(), b.nbits), 0) << what;
  for (size_t i = 0; i < b.nbits; i++)
    ASSERT_EQ((back[i / 8] >> (i % 8)) & 1, (b.data()[i / 8] >> (i % 8)) & 1) << what << " bit " << i;
}

TEST(EdgeKernels, RleEncodeEqualsPortableByteForByte) {
#if defined(__aarch64__)
  EXPECT_STREQ(vc_rle_encode_impl(), "neon");
#else
  EXPECT_STREQ(vc_rle_encode_impl(), "portable");
#endif
  std::mt19937 rng(1604);
  // Around the word (64 bits), the scalar step (4 words) and the NEON step (8 words, 512 bits).
  std::vector<size_t> sizes = {0, 1, 2, 7, 8, 9, 63, 64, 65, 255, 256, 257, 511, 512, 513, 1023, 1024, 1025};
  for (size_t n : {2048, 4096, 5000, 32768 + 77}) sizes.push_back(n);
  for (size_t n : sizes)
    for (size_t offset : {0, 1, 3, 8}) {
      const std::string at = std::to_string(n) + " bits at +" + std::to_string(offset);
      expect_rle_same(make_bits(n, offset), "empty " + at);
      Bits full = make_bits(n, offset);
      for (size_t i = 0; i < n; i++) full.set(i);
      expect_rle_same(full, "full " + at);
      Bits alt = make_bits(n, offset), alt_words = make_bits(n, offset);
      for (size_t i = 0; i < n; i++) {
        if (i % 2) alt.set(i);
        if ((i / 64) % 2) alt_words.set(i);
      }
      expect_rle_same(alt, "alternating bits " + at);
      expect_rle_same(alt_words, "alternating words " + at);
      if (n == 0) continue;
      // One bit set, one bit clear, at both ends of the grid and at the step edges.
      for (size_t i : {size_t{0}, n - 1, n / 2, size_t{511} % n, size_t{512} % n, size_t{64} % n}) {
        Bits one = make_bits(n, offset), hole = make_bits(n, offset);
        one.set(i);
        for (size_t k = 0; k < n; k++)
          if (k != i) hole.set(k);
        expect_rle_same(one, "bit " + std::to_string(i) + " of " + at);
        expect_rle_same(hole, "hole at " + std::to_string(i) + " of " + at);
      }
      // Long runs (mean 40, 700 and 5000 bits), and random bits at three densities.
      for (double mean : {40.0, 700.0, 5000.0}) {
        Bits runs = make_bits(n, offset);
        std::geometric_distribution<size_t> len(1.0 / mean);
        bool on = rng() % 2 != 0;
        for (size_t i = 0; i < n; on = !on) {
          const size_t r = 1 + len(rng);
          for (size_t k = i; k < std::min(n, i + r); k++)
            if (on) runs.set(k);
          i += r;
        }
        expect_rle_same(runs, "runs of mean " + std::to_string(mean) + " " + at);
      }
      for (double density : {0.02, 0.5, 0.98}) {
        Bits r = make_bits(n, offset);
        std::bernoulli_distribution bit(density);
        for (size_t i = 0; i < n; i++)
          if (bit(rng)) r.set(i);
        expect_rle_same(r, "density " + std::to_string(density) + " " + at);
      }
    }
  // A hull-like grid: a body of boxes in 128^3 (a few runs per row, long empty stretches).
  const int nx = 128;
  Bits hull = make_bits(size_t{nx} * nx * nx, 0);
  for (int k = 8; k < 120; k++)
    for (int j = 40; j < 88; j++)
      for (int i = 0; i < nx; i++) {
        const bool torso = i >= 50 && i < 78 && j >= 52 && j < 76 && k >= 40 && k < 100;
        const bool legs = ((i >= 52 && i < 60) || (i >= 68 && i < 76)) && j >= 58 && j < 70 && k < 40;
        const bool arms = (i < 50 || i >= 78) && j >= 60 && j < 66 && k >= 88 && k < 96;
        if (torso || legs || arms) hull.set(i + static_cast<size_t>(nx) * (j + static_cast<size_t>(nx) * k));
      }
  expect_rle_same(hull, "hull-like 128^3");
}

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
