// The pose scorer against hw/sim's truth: the truth itself scores 0 mm; a shift scores its length in
// MPJPE and 0 after Procrustes; initialization frames, frames outside the volume and an arm inside the
// torso are counted as documented; latency is trigger -> t_fitted_ns.
#include <gtest/gtest.h>

#include <cmath>

#include "voxcap/body/joints.hpp"
#include "voxcap/emulated/pose_scorer.hpp"
#include "voxcap/sim/scene.hpp"

namespace vc::emulated {
namespace {

std::unique_ptr<sim::Scene> wave() {
  sim::SceneOptions so;
  so.motion.source = "wave";
  so.motion.fps = 60;
  return std::make_unique<sim::Scene>(so);
}

rig::VoxelGrid volume(double height_m = 2.24) {
  rig::VoxelGrid g;
  g.min_m = cv::Vec3d(-1.12, -1.12, 0.0);
  g.voxel_m = height_m / 64;
  g.nx = g.ny = static_cast<int>(std::lround(2.24 / g.voxel_m));
  g.nz = 64;
  return g;
}

pipeline::Pose truth_pose(const sim::Scene& scene, int f) {
  pipeline::Pose p;
  p.state = pipeline::PoseState::Fitted;
  p.body_version = 1;
  const auto t = scene.joints(f);
  for (int j = 0; j < pipeline::kPoseJointCount; ++j) {
    const cv::Vec3d& v = t[static_cast<size_t>(body::joint_from_name(pipeline::pose_joint_name(j)))];
    p.p_world[static_cast<size_t>(j)] = {v[0], v[1], v[2]};
  }
  return p;
}

pipeline::Frame frame_at(uint64_t origin, int f, const pipeline::Pose& pose) {
  pipeline::Frame fr;
  fr.seq = origin + static_cast<uint64_t>(f);
  fr.t_trigger_ns = 1'000'000'000ull + static_cast<uint64_t>(f) * 16'666'667ull;
  fr.pose = pose;
  fr.pose.t_fitted_ns = pose.valid() ? fr.t_trigger_ns + 5'000'000ull : 0;
  return fr;
}

TEST(PoseScorer, TheTruthScoresZeroAndFramesAreCountedAsDocumented) {
  const auto ref = wave();
  PoseScorer s(wave(), volume(), /*keep_poses=*/true);
  pipeline::Frame early = frame_at(0, 0, truth_pose(*ref, 0));
  s.process(early);  // before the origin is known: not scored
  s.set_origin(500);
  for (int f = 0; f < 60; ++f) {
    pipeline::Frame fr = frame_at(500, f, f < 4 || f == 30 ? pipeline::Pose{} : truth_pose(*ref, f));
    s.process(fr);
  }
  const PoseAccuracy a = s.accuracy();
  EXPECT_EQ(a.merged_frames, 60u);
  EXPECT_EQ(a.init_frames, 4u);
  EXPECT_EQ(a.frames, 56u);
  EXPECT_EQ(a.fitted_frames, 55u);  // frame 30 lost its pose
  EXPECT_EQ(a.scored_frames, 55u);
  EXPECT_EQ(a.frames_outside_volume, 0u);
  EXPECT_EQ(a.arm_in_torso_frames, 0u);
  EXPECT_LT(a.mpjpe_mm, 1e-9);
  EXPECT_LT(a.pa_mpjpe_mm, 1e-6);
  EXPECT_NEAR(a.latency_p50_ms, 5.0, 1e-9);
  EXPECT_NEAR(a.latency_p99_ms, 5.0, 1e-9);
  EXPECT_NEAR(a.fps, 54.0 / (55.0 / 60.0), 0.01);  // 55 poses over frames 4 .. 59 (30 lost)
  ASSERT_EQ(a.poses.size(), 60u);
  EXPECT_EQ(a.poses.front().frame, 0);
  EXPECT_EQ(a.poses.back().frame, 59);
}

TEST(PoseScorer, AShiftIsMpjpeNotPaMpjpeAndAWristInTheChestIsCounted) {
  const auto ref = wave();
  PoseScorer s(wave(), volume(), false);
  s.set_origin(0);
  pipeline::Pose p = truth_pose(*ref, 10);
  for (auto& q : p.p_world) q[0] += 0.02;  // 2 cm sideways
  pipeline::Frame fr = frame_at(0, 10, p);
  s.process(fr);
  PoseAccuracy a = s.accuracy();
  EXPECT_NEAR(a.mpjpe_mm, 20.0, 1e-6);
  EXPECT_LT(a.pa_mpjpe_mm, 1e-6);
  EXPECT_NEAR(a.per_joint_mm[5], 20.0, 1e-6);
  EXPECT_EQ(a.arm_in_torso_frames, 0u);

  // The left wrist at the true chest centre: inside the torso.
  const auto truth = ref->joints(11);
  pipeline::Pose q = truth_pose(*ref, 11);
  const cv::Vec3d chest =
      0.5 * (truth[static_cast<size_t>(body::Joint::spine)] + truth[static_cast<size_t>(body::Joint::neck)]);
  q.p_world[static_cast<size_t>(pipeline::PoseJoint::l_wrist)] = {chest[0], chest[1], chest[2]};
  pipeline::Frame fr2 = frame_at(0, 11, q);
  s.process(fr2);
  a = s.accuracy();
  EXPECT_EQ(a.arm_in_torso_frames, 1u);
  EXPECT_GT(a.per_joint_mm[static_cast<size_t>(pipeline::PoseJoint::l_wrist)], 100.0);
}

TEST(PoseScorer, ABodyOutsideTheVolumeIsCountedAndLeftOut) {
  const auto ref = wave();
  PoseScorer s(wave(), volume(/*height_m=*/1.2), false);  // the head is above the box
  s.set_origin(0);
  pipeline::Pose p = truth_pose(*ref, 5);
  for (auto& q : p.p_world) q[2] += 1.0;  // would be a huge error if it were scored
  pipeline::Frame fr = frame_at(0, 5, p);
  s.process(fr);
  const PoseAccuracy a = s.accuracy();
  EXPECT_EQ(a.fitted_frames, 1u);
  EXPECT_EQ(a.frames_outside_volume, 1u);
  EXPECT_EQ(a.scored_frames, 0u);
  EXPECT_EQ(a.mpjpe_mm, 0.0);
}

TEST(PoseScorer, ProcrustesUndoesRotationScaleAndTranslation) {
  const auto ref = wave();
  const pipeline::Pose truth = truth_pose(*ref, 20);
  std::array<std::array<double, 3>, pipeline::kPoseJointCount> t{};
  for (size_t j = 0; j < t.size(); ++j) t[j] = truth.p_world[j];
  pipeline::Pose moved = truth;
  const double c = std::cos(0.7), s = std::sin(0.7);
  for (auto& q : moved.p_world) {
    const double x = q[0], y = q[1];
    q = {1.1 * (c * x - s * y) + 0.3, 1.1 * (s * x + c * y) - 0.2, 1.1 * q[2] + 0.05};
  }
  std::array<double, pipeline::kPoseJointCount> err{};
  double pa = 0;
  PoseScorer::joint_errors(moved, t, &err, &pa);
  EXPECT_LT(pa, 1e-9);
  EXPECT_GT(err[0], 0.05);
}

}  // namespace
}  // namespace vc::emulated
