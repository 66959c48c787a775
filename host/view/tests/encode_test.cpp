// The viewer's binary messages, byte for byte (PROTOCOL.md), and the pose JSON of /pose.json.
#include <cstring>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "voxcap/view/encode.hpp"

namespace vc::view {
namespace {

template <class T>
T at(const std::string& s, size_t off) {
  T v;
  std::memcpy(&v, s.data() + off, sizeof(T));
  return v;
}

pipeline::Frame frame() {
  pipeline::Frame f;
  f.seq = 42;
  f.t_trigger_ns = 1'000'000'000;
  f.t_merged_ns = 1'012'500'000;
  f.grid_id = 0xABCD1234;
  f.voxel_count = 10;
  f.occupied = 3;
  f.merged = true;
  f.present = {0, 1};
  f.rle = {3, 3, 4};
  return f;
}

TEST(ViewEncode, HullCarriesTheMergedRleAsIs) {
  const std::string m = encode_hull(frame());
  ASSERT_EQ(m.size(), 52u + 3);
  EXPECT_EQ(uint8_t(m[0]), uint8_t(MsgType::Hull));
  EXPECT_EQ(uint8_t(m[1]), kProtocolVersion);
  EXPECT_EQ(at<uint64_t>(m, 4), 42u);
  EXPECT_EQ(at<uint64_t>(m, 12), 1'000'000'000u);
  EXPECT_EQ(at<uint32_t>(m, 20), 0xABCD1234u);
  EXPECT_EQ(uint8_t(m[24]), 1);  // present, not degraded
  EXPECT_EQ(uint8_t(m[25]), 2);  // nodes present
  EXPECT_EQ(at<uint64_t>(m, 28), 10u);
  EXPECT_EQ(at<uint64_t>(m, 36), 3u);
  EXPECT_FLOAT_EQ(at<float>(m, 44), 12.5f);
  EXPECT_EQ(at<uint32_t>(m, 48), 3u);
  EXPECT_EQ(std::string(m.data() + 52, 3), std::string("\x03\x03\x04", 3));
}

TEST(ViewEncode, HullWithoutMergeHasNoRle) {
  pipeline::Frame f = frame();
  f.merged = false;
  f.degraded = true;
  const std::string m = encode_hull(f);
  ASSERT_EQ(m.size(), 52u);
  EXPECT_EQ(uint8_t(m[24]), 2);
  EXPECT_EQ(at<uint64_t>(m, 36), 0u);
}

TEST(ViewEncode, PoseIsFifteenJointsOfFloat32) {
  pipeline::Frame f = frame();
  EXPECT_TRUE(encode_pose(f).empty());
  f.pose.state = pipeline::PoseState::Fitted;
  f.pose.confidence = 0.75f;
  f.pose.body_version = 7;
  for (int j = 0; j < pipeline::kPoseJointCount; j++) f.pose.p_world[size_t(j)] = {j * 1.0, j * 2.0, j * 0.5};
  const std::string m = encode_pose(f);
  ASSERT_EQ(m.size(), 24u + 12 * 15);
  EXPECT_EQ(uint8_t(m[0]), uint8_t(MsgType::Pose));
  EXPECT_EQ(at<uint64_t>(m, 4), 42u);
  EXPECT_EQ(uint8_t(m[12]), 1);   // fitted
  EXPECT_EQ(uint8_t(m[13]), 15);  // joints
  EXPECT_FLOAT_EQ(at<float>(m, 16), 0.75f);
  EXPECT_EQ(at<uint32_t>(m, 20), 7u);
  EXPECT_FLOAT_EQ(at<float>(m, 24 + 12 * 5 + 4), 10.f);  // l_wrist y
}

TEST(ViewEncode, Features2DAndSilhouetteNameTheRigCamera) {
  pipeline::Frame f = frame();
  pipeline::NodePart p;
  p.node_id = 3;
  vc_features fs{};
  fs.camera = 1;
  fs.feature_count = 1;
  fs.features[0] = {2, 0, 10.5f, 20.25f, 0.5f};
  p.features.push_back(fs);
  pipeline::Silhouette s;
  s.camera = 1;
  s.scale = 4;
  s.width = 160;
  s.height = 120;
  s.rle = {0x80, 0x96, 0x01};
  p.silhouettes.push_back(s);
  f.nodes.push_back(p);
  const std::string m = encode_features2d(f, nullptr);
  ASSERT_EQ(m.size(), 16u + 8 + 16);
  EXPECT_EQ(uint8_t(m[12]), 1);  // one camera entry
  EXPECT_EQ(at<uint16_t>(m, 16), 3u);
  EXPECT_EQ(at<uint16_t>(m, 18), 1u);
  EXPECT_EQ(at<uint16_t>(m, 20), 0xFFFFu);  // no rig: unknown rig camera
  EXPECT_EQ(uint8_t(m[22]), 1);
  EXPECT_EQ(uint8_t(m[24]), 2);  // right_hand
  EXPECT_FLOAT_EQ(at<float>(m, 28), 10.5f);
  EXPECT_FLOAT_EQ(at<float>(m, 32), 20.25f);
  const std::string sm = encode_silhouette(f, f.nodes[0], s, nullptr);
  ASSERT_EQ(sm.size(), 28u + 3);
  EXPECT_EQ(at<uint16_t>(sm, 12), 3u);
  EXPECT_EQ(at<uint16_t>(sm, 18), 4u);
  EXPECT_EQ(at<uint16_t>(sm, 20), 160u);
  EXPECT_EQ(at<uint16_t>(sm, 22), 120u);
  EXPECT_EQ(at<uint32_t>(sm, 24), 3u);
}

TEST(ViewEncode, PoseJsonNamesEveryJoint) {
  pipeline::Frame f = frame();
  EXPECT_TRUE(pose_json(f).empty());
  f.pose.state = pipeline::PoseState::Predicted;
  f.pose.p_world[5] = {0.1, 0.2, 1.3};
  const auto j = nlohmann::json::parse(pose_json(f));
  EXPECT_EQ(j["seq"], 42);
  EXPECT_EQ(j["state"], "predicted");
  ASSERT_EQ(j["joints"].size(), 15u);
  EXPECT_DOUBLE_EQ(j["joints"]["l_wrist"][2].get<double>(), 1.3);
}

TEST(ViewEncode, JsonMessagesHaveTheHeader) {
  const std::string m = encode_json(MsgType::Stats, R"({"a":1})");
  EXPECT_EQ(uint8_t(m[0]), uint8_t(MsgType::Stats));
  EXPECT_EQ(m.substr(4), R"({"a":1})");
}

}  // namespace
}  // namespace vc::view
