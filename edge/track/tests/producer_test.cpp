// The FEATURES producer: one valid FEATURES per camera every frame, in every state; hostile input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "voxcap/edge/track/producer.hpp"

namespace vc::track {
namespace {

bool encodes(const vc_features& f) {
  std::vector<std::uint8_t> buf(1024);
  std::size_t len = 0;
  vc_header hdr{};
  hdr.seq = 1;
  return vc_encode_features(buf.data(), buf.size(), &len, &hdr, &f) == 0;
}

TEST(ToFeatures, EveryStateEncodesAndNonFiniteOrOutOfRangeValuesAreMadeSafe) {
  FrameReport r;
  r[0] = {FeatureState::tracking, {12.5f, 40}, 0.9f};
  r[1] = {FeatureState::lost, {3, 4}, 0};
  r[2] = {FeatureState::not_visible, {99, 99}, 0};
  r[3] = {FeatureState::tracking, {NAN, 4}, 2.0f};
  r[4] = {FeatureState::tracking, {1, 2}, -1.0f};
  vc_features f;
  to_features(r, 1, &f);
  EXPECT_EQ(f.camera, 1);
  ASSERT_EQ(f.feature_count, 5);
  EXPECT_EQ(f.features[0].state, VC_FEATURE_TRACKING);
  EXPECT_EQ(f.features[0].u, 12.5f);
  EXPECT_EQ(f.features[1].state, VC_FEATURE_LOST);
  EXPECT_EQ(f.features[1].u, 3.0f);
  EXPECT_EQ(f.features[2].state, VC_FEATURE_NOT_VISIBLE);
  EXPECT_EQ(f.features[2].u, 0.0f);
  EXPECT_EQ(f.features[3].state, VC_FEATURE_NOT_VISIBLE);  // a NaN position is no measurement
  EXPECT_EQ(f.features[3].confidence, 1.0f);
  EXPECT_EQ(f.features[4].confidence, 0.0f);
  for (int k = 0; k < 5; ++k) EXPECT_EQ(f.features[k].feature_id, k);
  EXPECT_TRUE(encodes(f));
}

TEST(Producer, GivesOneFeaturesPerCameraEveryFrameAndRefusesBadImages) {
  const int W = 64, H = 48;
  std::vector<std::uint8_t> img(W * H * 3, 100), mask(W * H, 0);
  const std::uint8_t* rgb[2] = {img.data(), img.data()};
  const std::uint8_t* masks[2] = {mask.data(), mask.data()};
  std::size_t stride[2] = {W * 3, W * 3};
  int w[2] = {W, W}, h[2] = {H, H};
  Producer p;
  vc_features out[2];
  for (std::uint64_t seq = 10; seq < 15; ++seq) {
    ASSERT_EQ(p.track(seq, rgb, stride, masks, w, h, out), 2);
    for (int c = 0; c < 2; ++c) {
      EXPECT_EQ(out[c].camera, c);
      EXPECT_EQ(out[c].feature_count, 5);  // nothing seen yet: all five, not_visible
      for (int k = 0; k < 5; ++k) EXPECT_EQ(out[c].features[k].state, VC_FEATURE_NOT_VISIBLE);
      EXPECT_TRUE(encodes(out[c]));
    }
  }
  EXPECT_EQ(p.frames(), 5u);
  const std::uint8_t* none[2] = {nullptr, img.data()};
  EXPECT_EQ(p.track(20, none, stride, masks, w, h, out), -EINVAL);
  std::size_t short_stride[2] = {W, W * 3};
  EXPECT_EQ(p.track(21, rgb, short_stride, masks, w, h, out), -EINVAL);
  int huge[2] = {1 << 20, W};
  EXPECT_EQ(p.track(22, rgb, stride, masks, huge, h, out), -EINVAL);
  int zero[2] = {0, W};
  EXPECT_EQ(p.track(23, rgb, stride, masks, zero, h, out), -EINVAL);
}

}  // namespace
}  // namespace vc::track
