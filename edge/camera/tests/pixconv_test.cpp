// Fixed-point pixel conversion against the float formula (BT.601/709, limited/full range).
#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <vector>

#include "voxcap/edge/pixconv.h"

namespace {

struct FloatRef {
  double k, rv, gu, gv, bu, y0;
  FloatRef(vc_yuv_matrix m, bool full) { vc_yuv_coeffs_float(m, full, &k, &rv, &gu, &gv, &bu, &y0); }
  static int clamp_round(double v) { return (int)std::lround(std::min(255.0, std::max(0.0, v))); }
  void rgb(int y, int u, int v, int out[3]) const {
    const double l = k * (y - y0), du = u - 128, dv = v - 128;
    out[0] = clamp_round(l + rv * dv);
    out[1] = clamp_round(l - gu * du - gv * dv);
    out[2] = clamp_round(l + bu * du);
  }
};

struct Case {
  vc_yuv_matrix m;
  bool full;
};

class YuvVsFloat : public ::testing::TestWithParam<Case> {};

// Every Y, and U/V on a grid that includes both ends: the fixed-point result is within ±1.
TEST_P(YuvVsFloat, WithinOneOfTheFloatFormula) {
  const Case c = GetParam();
  vc_yuv_coeffs q;
  ASSERT_EQ(vc_yuv_coeffs_init(&q, c.m, c.full), 0);
  FloatRef ref(c.m, c.full);
  std::vector<int> uv;
  for (int i = 0; i < 256; i += 5) uv.push_back(i);
  uv.push_back(255);
  int worst = 0;
  uint8_t src[4], dst[6];
  for (int u : uv)
    for (int v : uv)
      for (int y = 0; y < 256; y++) {
        src[0] = (uint8_t)y;
        src[1] = (uint8_t)u;
        src[2] = (uint8_t)(255 - y);
        src[3] = (uint8_t)v;
        vc_pixconv_yuyv_to_rgb(src, 4, dst, 6, 2, 1, &q);
        int e0[3], e1[3];
        ref.rgb(y, u, v, e0);
        ref.rgb(255 - y, u, v, e1);
        for (int ch = 0; ch < 3; ch++) {
          worst = std::max(worst, std::abs(dst[ch] - e0[ch]));
          worst = std::max(worst, std::abs(dst[3 + ch] - e1[ch]));
        }
      }
  EXPECT_LE(worst, 1);
}

INSTANTIATE_TEST_SUITE_P(Matrices, YuvVsFloat,
                         ::testing::Values(Case{VC_YUV_BT601, false}, Case{VC_YUV_BT601, true},
                                           Case{VC_YUV_BT709, false}, Case{VC_YUV_BT709, true}),
                         [](const ::testing::TestParamInfo<Case>& i) {
                           return std::string(i.param.m == VC_YUV_BT601 ? "bt601" : "bt709") +
                                  (i.param.full ? "_full" : "_limited");
                         });

TEST(Pixconv, KnownBt601LimitedColours) {
  vc_yuv_coeffs q;
  vc_yuv_coeffs_init(&q, VC_YUV_BT601, false);
  auto conv = [&](int y, int u, int v, int r, int g, int b) {
    const uint8_t src[4] = {(uint8_t)y, (uint8_t)u, (uint8_t)y, (uint8_t)v};
    uint8_t d[6];
    vc_pixconv_yuyv_to_rgb(src, 4, d, 6, 2, 1, &q);
    EXPECT_NEAR(d[0], r, 2) << y << "," << u << "," << v;
    EXPECT_NEAR(d[1], g, 2) << y << "," << u << "," << v;
    EXPECT_NEAR(d[2], b, 2) << y << "," << u << "," << v;
  };
  conv(235, 128, 128, 255, 255, 255);  // white
  conv(16, 128, 128, 0, 0, 0);         // black
  conv(81, 90, 240, 255, 0, 0);        // red
  conv(145, 54, 34, 0, 255, 0);        // green
  conv(41, 240, 110, 0, 0, 255);       // blue
}

TEST(Pixconv, UyvyIsYuyvReordered) {
  vc_yuv_coeffs q;
  vc_yuv_coeffs_init(&q, VC_YUV_BT601, false);
  const uint8_t yuyv[8] = {50, 60, 200, 190, 16, 128, 235, 128};
  const uint8_t uyvy[8] = {60, 50, 190, 200, 128, 16, 128, 235};
  uint8_t a[12], b[12];
  vc_pixconv_yuyv_to_rgb(yuyv, 8, a, 12, 4, 1, &q);
  vc_pixconv_uyvy_to_rgb(uyvy, 8, b, 12, 4, 1, &q);
  EXPECT_TRUE(std::equal(a, a + 12, b));
}

TEST(Pixconv, StridesAndOddWidthsTouchOnlyThePicture) {
  vc_yuv_coeffs q;
  vc_yuv_coeffs_init(&q, VC_YUV_BT601, true);
  const int w = 5, h = 3;
  const size_t sstride = 16, dstride = 20;  // padded rows
  std::vector<uint8_t> src(sstride * h, 128), dst(dstride * h, 0xAB);
  for (int y = 0; y < h; y++)
    for (int x = 0; x < 3; x++) src[y * sstride + (size_t)x * 4] = src[y * sstride + (size_t)x * 4 + 2] = (uint8_t)(40 * y + x);
  ASSERT_EQ(vc_pixconv_to_rgb(VC_PIXFMT_YUYV, src.data(), sstride, dst.data(), dstride, w, h, &q), 0);
  for (int y = 0; y < h; y++) {
    for (int x = 0; x < w; x++) {
      const uint8_t expect = (uint8_t)(40 * y + x / 2);  // full range, neutral chroma: R = G = B = Y
      for (int c = 0; c < 3; c++) EXPECT_EQ(dst[y * dstride + (size_t)x * 3 + (size_t)c], expect) << x << "," << y;
    }
    for (size_t pad = (size_t)w * 3; pad < dstride; pad++) EXPECT_EQ(dst[y * dstride + pad], 0xAB);
  }
}

TEST(Pixconv, GreyRgbBgrAndRgbx) {
  const uint8_t grey[3] = {0, 100, 255};
  uint8_t d[9];
  ASSERT_EQ(vc_pixconv_to_rgb(VC_PIXFMT_GREY, grey, 3, d, 9, 3, 1, nullptr), 0);
  EXPECT_EQ((std::vector<uint8_t>(d, d + 9)), (std::vector<uint8_t>{0, 0, 0, 100, 100, 100, 255, 255, 255}));
  const uint8_t rgb[6] = {1, 2, 3, 4, 5, 6};
  ASSERT_EQ(vc_pixconv_to_rgb(VC_PIXFMT_RGB24, rgb, 6, d, 9, 2, 1, nullptr), 0);
  EXPECT_EQ((std::vector<uint8_t>(d, d + 6)), (std::vector<uint8_t>{1, 2, 3, 4, 5, 6}));
  ASSERT_EQ(vc_pixconv_to_rgb(VC_PIXFMT_BGR24, rgb, 6, d, 9, 2, 1, nullptr), 0);
  EXPECT_EQ((std::vector<uint8_t>(d, d + 6)), (std::vector<uint8_t>{3, 2, 1, 6, 5, 4}));
  const uint8_t x4[8] = {10, 20, 30, 99, 40, 50, 60, 99};
  vc_pixconv_rgbx_to_rgb(x4, 8, d, 6, 2, 1, false);
  EXPECT_EQ((std::vector<uint8_t>(d, d + 6)), (std::vector<uint8_t>{10, 20, 30, 40, 50, 60}));
  vc_pixconv_rgbx_to_rgb(x4, 8, d, 6, 2, 1, true);
  EXPECT_EQ((std::vector<uint8_t>(d, d + 6)), (std::vector<uint8_t>{30, 20, 10, 60, 50, 40}));
}

TEST(Pixconv, RejectsBadArguments) {
  uint8_t buf[64] = {};
  vc_yuv_coeffs q;
  vc_yuv_coeffs_init(&q, VC_YUV_BT601, false);
  EXPECT_EQ(vc_pixconv_to_rgb(VC_PIXFMT_DEFAULT, buf, 8, buf, 8, 2, 1, &q), -EINVAL);
  EXPECT_EQ(vc_pixconv_to_rgb(VC_PIXFMT_YUYV, buf, 8, buf, 12, 4, 1, nullptr), -EINVAL);  // no coefficients
  EXPECT_EQ(vc_pixconv_to_rgb(VC_PIXFMT_YUYV, buf, 6, buf, 12, 4, 1, &q), -EINVAL);       // src stride < 8
  EXPECT_EQ(vc_pixconv_to_rgb(VC_PIXFMT_RGB24, buf, 6, buf, 5, 2, 1, nullptr), -EINVAL);  // dst stride < 6
  EXPECT_EQ(vc_pixconv_to_rgb(VC_PIXFMT_GREY, buf, 2, buf, 6, 0, 1, nullptr), -EINVAL);
  EXPECT_EQ(vc_yuv_coeffs_init(&q, (vc_yuv_matrix)7, false), -EINVAL);
  EXPECT_EQ(vc_pixfmt_bytes_per_pixel(VC_PIXFMT_YUYV), 2u);
  EXPECT_EQ(vc_pixfmt_bytes_per_pixel(VC_PIXFMT_DEFAULT), 0u);
}

}  // namespace
