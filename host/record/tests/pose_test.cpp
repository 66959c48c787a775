// The fitted pose (pipeline::Pose) in a session: layout "voxcap.pose15/1" of the POSE record round-trips
// every field exactly through the format and a session, and hostile records are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "session_fixture.hpp"
#include "voxcap/record/pose.hpp"

namespace vc::record {
namespace {

using testing::TempDir;
using testing::write_rig_files;

pipeline::Pose make_fitted(uint64_t seq) {
  pipeline::Pose p;
  p.state = static_cast<pipeline::PoseState>(seq % 4);
  p.body_version = 0xFFFFFFF0u + static_cast<uint32_t>(seq % 7);
  p.confidence = 0.125f * static_cast<float>(seq % 8);
  p.t_fitted_ns = 0xFEDCBA9876543210ull + seq;  // needs all 64 bits
  const double c = std::cos(0.1 * double(seq)), s = std::sin(0.1 * double(seq));
  p.torso_R_world = {c, -s, 0, s, c, 0, 0, 0, 1};
  for (size_t j = 0; j < static_cast<size_t>(pipeline::kPoseJointCount); ++j)
    p.p_world[j] = {0.01 * double(j) - 0.3 + 1e-9 * double(seq), -0.2 + 0.003 * double(j),
                    1.7 - 0.1 * double(j)};
  return p;
}

void expect_same(const pipeline::Pose& a, const pipeline::Pose& b) {
  EXPECT_EQ(a.state, b.state);
  EXPECT_EQ(a.body_version, b.body_version);
  EXPECT_EQ(a.confidence, b.confidence);
  EXPECT_EQ(a.t_fitted_ns, b.t_fitted_ns);
  EXPECT_EQ(a.torso_R_world, b.torso_R_world);
  EXPECT_EQ(a.p_world, b.p_world);
}

TEST(RecordPose, LayoutHoldsTheNamesAndValuesAsDocumented) {
  PoseRecord r;
  const pipeline::Pose p = make_fitted(5);
  to_record(77, p, /*with_names=*/true, &r);
  EXPECT_EQ(r.seq, 77u);
  EXPECT_EQ(r.layout, "voxcap.pose15/1");
  ASSERT_EQ(r.joint_names.size(), 15u);
  EXPECT_EQ(r.joint_names.front(), "hips");
  EXPECT_EQ(r.joint_names[5], "l_wrist");
  EXPECT_EQ(r.joint_names.back(), "r_ankle");
  ASSERT_EQ(r.values.size(), 59u);
  EXPECT_EQ(r.values[0], 1.0);  // state 5 % 4 = fitted
  EXPECT_EQ(r.values[1], double(p.body_version));
  EXPECT_EQ(r.values[3], double(0xFEDCBA98u));
  EXPECT_EQ(r.values[4], double(0x76543215u));
  EXPECT_EQ(r.values[5 + 1], p.torso_R_world[1]);
  EXPECT_EQ(r.values[14 + 3 * 8 + 2], p.p_world[8][2]);  // r_wrist z
  to_record(78, p, /*with_names=*/false, &r);
  EXPECT_TRUE(r.joint_names.empty());
}

TEST(RecordPose, RoundTripsThroughASessionExactly) {
  TempDir tmp;
  const auto rig = write_rig_files(tmp.path());
  const auto dir = tmp.path() / "s";
  {
    Recorder rec = Recorder::create(dir, rig.rig_toml, rig.calibration_yaml, "{}");
    PoseRecord r;
    for (uint64_t seq = 10; seq < 30; ++seq) {
      to_record(seq, make_fitted(seq), seq == 10, &r);
      rec.append(r);
    }
    rec.close();
  }
  Reader reader = Reader::open(dir);
  EXPECT_EQ(reader.summary_ref().poses, 20u);
  EXPECT_EQ(reader.summary_ref().pose_layout, kPoseLayout);
  EXPECT_EQ(reader.summary_ref().joint_names.size(), 15u);
  Record rec;
  uint64_t seq = 10;
  while (reader.next(rec)) {
    const auto* r = std::get_if<PoseRecord>(&rec);
    ASSERT_NE(r, nullptr);
    pipeline::Pose back;
    std::string why;
    ASSERT_TRUE(from_record(*r, &back, &why)) << why;
    EXPECT_EQ(r->seq, seq);
    expect_same(back, make_fitted(seq));
    ++seq;
  }
  EXPECT_EQ(seq, 30u);
}

TEST(RecordPose, RefusesRecordsThatAreNotTheLayout) {
  PoseRecord good;
  to_record(1, make_fitted(1), true, &good);
  pipeline::Pose out;
  std::string why;
  ASSERT_TRUE(from_record(good, &out, &why)) << why;

  auto refused = [&](const PoseRecord& r, const char* words) {
    std::string w;
    EXPECT_FALSE(from_record(r, &out, &w)) << words;
    EXPECT_NE(w.find(words), std::string::npos) << w;
  };
  PoseRecord r = good;
  r.layout = "positions_xyz_m";
  refused(r, "layout");
  r = good;
  r.values.pop_back();
  refused(r, "58 values");
  r = good;
  r.joint_names[3] = "LeftArm";
  refused(r, "joint 3");
  r = good;
  r.joint_names.pop_back();
  refused(r, "14 joint names");
  r = good;
  r.values[0] = 4;
  refused(r, "state");
  r = good;
  r.values[0] = 0.5;
  refused(r, "state");
  r = good;
  r.values[1] = -1;
  refused(r, "body_version");
  r = good;
  r.values[1] = 4294967296.0;
  refused(r, "body_version");
  r = good;
  r.values[4] = 4294967296.0;
  refused(r, "t_fitted_ns");
  r = good;
  r.values[20] = std::numeric_limits<double>::quiet_NaN();
  refused(r, "not finite");
  r = good;
  r.values[6] = std::numeric_limits<double>::infinity();
  refused(r, "not finite");
}

// A triangulated feature through its record and back: every recorded field kept (the naming's trust
// among them), the clearance unknown; a state out of range (an unchecked record) reads as inconsistent.
TEST(RecordFeature3D, MapsToItsRecordAndBack) {
  pipeline::Feature3D f;
  f.feature_id = 4;
  f.state = pipeline::Feature3DState::Triangulated;
  f.p_world = {0.25, -1.5, 0.125};
  f.confidence = 0.45f;
  f.reproj_px = 1.75f;
  f.views = {1, 3, 6};
  f.hull_clearance_m = 0.04f;
  f.name_trusted = false;
  Features3DRecord::P p;
  p.views.reserve(8);
  to_record(f, &p);
  EXPECT_EQ(p.id, 4);
  EXPECT_EQ(p.state, 0);
  EXPECT_FALSE(p.name_trusted);
  EXPECT_EQ(p.views, f.views);
  const pipeline::Feature3D back = feature3d_from_record(p);
  EXPECT_EQ(back.feature_id, f.feature_id);
  EXPECT_EQ(back.state, f.state);
  EXPECT_EQ(back.p_world, f.p_world);
  EXPECT_EQ(back.confidence, f.confidence);
  EXPECT_EQ(back.reproj_px, f.reproj_px);
  EXPECT_EQ(back.views, f.views);
  EXPECT_FALSE(back.name_trusted);
  EXPECT_EQ(back.hull_clearance_m, -1.0f);  // not recorded
  p.state = 9;
  EXPECT_EQ(feature3d_from_record(p).state, pipeline::Feature3DState::Inconsistent);
}

}  // namespace
}  // namespace vc::record
