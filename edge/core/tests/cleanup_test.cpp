// The 3x3 majority clean-up against a direct per-pixel reference.
#include "voxcap/edge/cleanup.h"

#include <gtest/gtest.h>

#include <cerrno>
#include <random>
#include <string>
#include <vector>

#include "voxcap/edge/bgmodel.h"

namespace {

// Direct definition: count the foreground pixels of the 3x3 neighbourhood, border replicated.
std::vector<uint8_t> reference_majority(const std::vector<uint8_t>& in, int w, int h) {
  std::vector<uint8_t> out(in.size());
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++) {
      int n = 0;
      for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
          int xx = std::clamp(x + dx, 0, w - 1), yy = std::clamp(y + dy, 0, h - 1);
          n += in[static_cast<size_t>(yy) * w + xx] != 0;
        }
      out[static_cast<size_t>(y) * w + x] = n >= 5 ? 255 : 0;
    }
  return out;
}

class CleanupVariants : public ::testing::TestWithParam<const char*> {
 protected:
  void SetUp() override {
    int err = vc_edge_kernel_select(GetParam());
    if (err == -ENOTSUP) GTEST_SKIP() << GetParam() << " kernels do not run on this CPU";
    ASSERT_EQ(err, 0);
  }
  void TearDown() override { vc_edge_kernel_select("auto"); }
};

TEST_P(CleanupVariants, EqualsTheReferenceOnRandomMasks) {
  std::mt19937 rng(11);
  for (auto [w, h] : {std::pair{1, 1}, {1, 7}, {7, 1}, {2, 2}, {33, 17}, {160, 120}}) {
    for (double density : {0.1, 0.5, 0.9}) {
      std::bernoulli_distribution on(density);
      std::vector<uint8_t> m(static_cast<size_t>(w) * h);
      for (auto& v : m) v = on(rng) ? (rng() % 2 ? 255 : 1) : 0;  // any nonzero is foreground
      std::vector<uint8_t> expect = m;
      std::vector<uint8_t> scratch(vc_cleanup_scratch_size(w));
      for (int it = 1; it <= 3; it++) {
        expect = reference_majority(expect, w, h);
        std::vector<uint8_t> got = m;
        ASSERT_EQ(vc_cleanup(got.data(), w, h, it, scratch.data(), scratch.size()), 0);
        ASSERT_EQ(got, expect) << w << "x" << h << " density " << density << " iterations " << it;
      }
    }
  }
}

TEST_P(CleanupVariants, RemovesSpecklesAndFillsHolesKeepsTheBody) {
  const int w = 64, h = 48;
  std::vector<uint8_t> m(w * h, 0);
  for (int y = 10; y < 40; y++)
    for (int x = 20; x < 44; x++) m[y * w + x] = 255;
  m[20 * w + 30] = 0;                                   // 1-pixel hole
  m[25 * w + 25] = m[25 * w + 26] = m[26 * w + 25] = m[26 * w + 26] = 0;  // 2x2 hole
  m[3 * w + 3] = 255;                                   // speckles
  m[5 * w + 50] = m[5 * w + 51] = m[6 * w + 50] = m[6 * w + 51] = 255;
  std::vector<uint8_t> scratch(vc_cleanup_scratch_size(w));
  ASSERT_EQ(vc_cleanup(m.data(), w, h, 1, scratch.data(), scratch.size()), 0);
  EXPECT_EQ(m[20 * w + 30], 255);
  EXPECT_EQ(m[25 * w + 25], 255);
  EXPECT_EQ(m[26 * w + 26], 255);
  EXPECT_EQ(m[3 * w + 3], 0);
  EXPECT_EQ(m[5 * w + 50], 0);
  int body = 0;
  for (int y = 10; y < 40; y++)
    for (int x = 20; x < 44; x++) body += m[y * w + x] != 0;
  EXPECT_EQ(body, 30 * 24 - 4);  // only the four corners round off
}

INSTANTIATE_TEST_SUITE_P(Kernels, CleanupVariants, ::testing::Values("generic", "avx2"),
                         [](const auto& p) { return std::string(p.param); });

TEST(Cleanup, ZeroIterationsNormalisesAndBadArgumentsFail) {
  std::vector<uint8_t> m = {0, 1, 7, 255}, scratch(vc_cleanup_scratch_size(4));
  ASSERT_EQ(vc_cleanup(m.data(), 4, 1, 0, scratch.data(), scratch.size()), 0);
  EXPECT_EQ(m, (std::vector<uint8_t>{0, 255, 255, 255}));
  EXPECT_EQ(vc_cleanup(m.data(), 4, 1, 1, scratch.data(), scratch.size() - 1), -EINVAL);
  EXPECT_EQ(vc_cleanup(m.data(), 0, 1, 1, scratch.data(), scratch.size()), -EINVAL);
  EXPECT_EQ(vc_cleanup(m.data(), 4, 1, -1, scratch.data(), scratch.size()), -EINVAL);
  EXPECT_EQ(vc_cleanup_scratch_size(0), 0u);
}

}  // namespace
