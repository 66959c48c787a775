// The 3x3 majority clean-up against a direct per-pixel reference.
#include "voxcap/edge/cleanup.h"

#include <gtest/gtest.h>

#include <cerrno>
#include <random>
#include <string>
#include <vector>

#include "voxcap/edge/bgmodel.h"

namespace {

// Direct definition of radius r: count the foreground pixels of the (2r+1)^2 neighbourhood, border
// replicated, foreground when more than half are.
std::vector<uint8_t> reference_majority_r(const std::vector<uint8_t>& in, int w, int h, int r) {
  std::vector<uint8_t> out(in.size());
  const int side = 2 * r + 1;
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++) {
      int n = 0;
      for (int dy = -r; dy <= r; dy++)
        for (int dx = -r; dx <= r; dx++) {
          int xx = std::clamp(x + dx, 0, w - 1), yy = std::clamp(y + dy, 0, h - 1);
          n += in[static_cast<size_t>(yy) * w + xx] != 0;
        }
      out[static_cast<size_t>(y) * w + x] = 2 * n > side * side ? 255 : 0;
    }
  return out;
}

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
  m[20 * w + 30] = 0;                                                     // 1-pixel hole
  m[25 * w + 25] = m[25 * w + 26] = m[26 * w + 25] = m[26 * w + 26] = 0;  // 2x2 hole
  m[3 * w + 3] = 255;                                                     // speckles
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

TEST_P(CleanupVariants, RadiusEqualsTheReferenceOnRandomMasks) {
  std::mt19937 rng(12);
  for (auto [w, h] : {std::pair{1, 1}, {1, 9}, {9, 1}, {3, 3}, {33, 17}, {17, 40}, {96, 64}}) {
    for (double density : {0.1, 0.5, 0.9}) {
      std::bernoulli_distribution on(density);
      std::vector<uint8_t> m(static_cast<size_t>(w) * h);
      for (auto& v : m) v = on(rng) ? (rng() % 2 ? 255 : 1) : 0;  // any nonzero is foreground
      for (int r = 1; r <= VC_CLEANUP_MAX_RADIUS; r++) {
        std::vector<uint8_t> scratch(vc_cleanup_radius_scratch_size(w, r));
        std::vector<uint8_t> got = m;
        ASSERT_EQ(vc_cleanup_radius(got.data(), w, h, r, scratch.data(), scratch.size()), 0);
        ASSERT_EQ(got, reference_majority_r(m, w, h, r))
            << w << "x" << h << " density " << density << " r " << r;
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Kernels, CleanupVariants, ::testing::Values("generic", "avx2", "neon"),
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

TEST(CleanupRadius, RadiusOneIsTheThreeByThreeFilterAndZeroNormalises) {
  std::mt19937 rng(5);
  std::vector<uint8_t> m(50 * 30);
  for (auto& v : m) v = rng() % 3 ? 0 : 255;
  std::vector<uint8_t> a = m, b = m, scratch(vc_cleanup_radius_scratch_size(50, 1));
  ASSERT_EQ(scratch.size(), vc_cleanup_scratch_size(50));  // the edge's default costs what it did
  ASSERT_EQ(vc_cleanup(a.data(), 50, 30, 1, scratch.data(), scratch.size()), 0);
  ASSERT_EQ(vc_cleanup_radius(b.data(), 50, 30, 1, scratch.data(), scratch.size()), 0);
  EXPECT_EQ(a, b);
  std::vector<uint8_t> z = {0, 1, 7, 255};
  ASSERT_EQ(vc_cleanup_radius(z.data(), 4, 1, 0, scratch.data(), scratch.size()), 0);
  EXPECT_EQ(z, (std::vector<uint8_t>{0, 255, 255, 255}));
}

// The setting means what it says: every radius from 1 to the maximum removes a square speckle and
// fills a square hole of side floor((2r+1)/sqrt(2)) and leaves one pixel larger, and a larger radius
// reaches further.
TEST(CleanupRadius, LargerRadiusRemovesLargerSpecklesAndHoles) {
  for (int r = 1; r <= VC_CLEANUP_MAX_RADIUS; r++) {
    SCOPED_TRACE("r " + std::to_string(r));
    const int side = 2 * r + 1;
    int gone = 1;
    while ((gone + 1) * (gone + 1) * 2 < side * side) gone++;  // largest s with 2 s^2 < side^2
    const int w = 8 * side + 40, h = 4 * side + 40;
    std::vector<uint8_t> scratch(vc_cleanup_radius_scratch_size(w, r));
    for (bool hole : {false, true}) {
      SCOPED_TRACE(hole ? "hole" : "speckle");
      const uint8_t bg = hole ? 255 : 0, fg = hole ? 0 : 255;
      for (int s : {gone, gone + 1}) {
        std::vector<uint8_t> m(static_cast<size_t>(w) * h, bg);
        const int x0 = w / 2 - s / 2, y0 = h / 2 - s / 2;
        for (int y = y0; y < y0 + s; y++)
          for (int x = x0; x < x0 + s; x++) m[static_cast<size_t>(y) * w + x] = fg;
        ASSERT_EQ(vc_cleanup_radius(m.data(), w, h, r, scratch.data(), scratch.size()), 0);
        const bool centre_flipped = m[static_cast<size_t>(y0 + s / 2) * w + x0 + s / 2] == bg;
        EXPECT_EQ(centre_flipped, s == gone) << "square of side " << s;
      }
    }
    EXPECT_GE(gone, r + 1);  // grows with r: 2, 3, 4, 6, 7, 9, 10, 12
  }
}

TEST(CleanupRadius, BadArgumentsFail) {
  std::vector<uint8_t> m(16 * 16), scratch(vc_cleanup_radius_scratch_size(16, 3) + 2);
  EXPECT_EQ(vc_cleanup_radius_scratch_size(16, VC_CLEANUP_MAX_RADIUS + 1), 0u);
  EXPECT_EQ(vc_cleanup_radius_scratch_size(16, -1), 0u);
  EXPECT_EQ(vc_cleanup_radius_scratch_size(0, 2), 0u);
  EXPECT_EQ(vc_cleanup_radius(m.data(), 16, 16, VC_CLEANUP_MAX_RADIUS + 1, scratch.data(), scratch.size()),
            -EINVAL);
  EXPECT_EQ(vc_cleanup_radius(m.data(), 16, 16, -1, scratch.data(), scratch.size()), -EINVAL);
  EXPECT_EQ(vc_cleanup_radius(m.data(), 16, 16, 3, scratch.data(), vc_cleanup_radius_scratch_size(16, 3) - 1),
            -EINVAL);
  EXPECT_EQ(vc_cleanup_radius(m.data(), 16, 16, 3, scratch.data() + 1, scratch.size() - 1), -EINVAL);  // odd
  EXPECT_EQ(vc_cleanup_radius(nullptr, 16, 16, 3, scratch.data(), scratch.size()), -EINVAL);
  EXPECT_EQ(vc_cleanup_radius(m.data(), 16, 0, 3, scratch.data(), scratch.size()), -EINVAL);
  EXPECT_EQ(vc_cleanup_radius(m.data(), 16, 16, 3, scratch.data(), scratch.size()), 0);
}

}  // namespace
