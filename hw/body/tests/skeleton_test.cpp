// Rotations and forward kinematics against independent references (OpenCV's Rodrigues, hand
// computed chains), and the standard joint table and skeleton.
#include "voxcap/body/skeleton.hpp"

#include <random>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <opencv2/calib3d.hpp>

#include "voxcap/body/glm_cv.hpp"
#include "voxcap/body/joints.hpp"

namespace vc::body {
namespace {

// Largest element difference (OpenCV's NORM_INF of a - b).
double rot_err(const glm::dmat3& a, const glm::dmat3& b) {
  double e = 0;
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r < 3; ++r) e = std::max(e, std::abs(a[c][r] - b[c][r]));
  }
  return e;
}
double rot_err(const glm::dmat3& a, const cv::Matx33d& b) {
  return rot_err(a, to_glm(b));
}
double norm(const glm::dvec3& v) {
  return glm::length(v);
}

TEST(BodyRotations, AxisRotationsAgreeWithRodrigues) {
  for (double a : {-2.0, -0.3, 0.0, 0.7, 3.0}) {
    cv::Matx33d R;
    cv::Rodrigues(cv::Vec3d(a, 0, 0), R);
    EXPECT_LT(rot_err(rot_x(a), R), 1e-12);
    cv::Rodrigues(cv::Vec3d(0, a, 0), R);
    EXPECT_LT(rot_err(rot_y(a), R), 1e-12);
    cv::Rodrigues(cv::Vec3d(0, 0, a), R);
    EXPECT_LT(rot_err(rot_z(a), R), 1e-12);
    cv::Rodrigues(cv::Vec3d(1, -2, 0.5) * (a / cv::norm(cv::Vec3d(1, -2, 0.5))), R);
    EXPECT_LT(rot_err(rot_axis({1, -2, 0.5}, a), R), 1e-12);
  }
}

TEST(BodyRotations, EulerRoundTripInEveryTaitBryanOrder) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-179, 179), v(-89, 89);
  for (const char* order : {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"}) {
    for (int i = 0; i < 200; ++i) {
      const glm::dvec3 deg{u(rng), v(rng), u(rng)};  // braced: drawn in order
      const glm::dmat3 R = matrix_from_euler(order, deg);
      const glm::dvec3 back = euler_from_matrix(order, R);
      EXPECT_LT(rot_err(matrix_from_euler(order, back), R), 1e-10) << order;
      EXPECT_LT(norm(back - deg), 1e-7) << order;
    }
    // Gimbal lock: the angles change but the rotation does not.
    const glm::dmat3 G = matrix_from_euler(order, {30, 90, 20});
    EXPECT_LT(rot_err(matrix_from_euler(order, euler_from_matrix(order, G)), G), 1e-10) << order;
  }
  // "ZYX" means Rz * Ry * Rx (BVH order of application as written).
  const glm::dmat3 R = matrix_from_euler("ZYX", {10, 20, 30});
  EXPECT_LT(rot_err(R, rot_z(10 * M_PI / 180) * rot_y(20 * M_PI / 180) * rot_x(30 * M_PI / 180)), 1e-14);
}

TEST(BodyRotations, RotBetweenIsMinimalAndHandlesOpposites) {
  const glm::dmat3 R = rot_between({1, 0, 0}, {0, 1, 0});
  EXPECT_LT(norm(R * glm::dvec3(1, 0, 0) - glm::dvec3(0, 1, 0)), 1e-12);
  EXPECT_LT(norm(R * glm::dvec3(0, 0, 1) - glm::dvec3(0, 0, 1)), 1e-12);  // axis untouched
  const glm::dmat3 F = rot_between({0, 0, 2}, {0, 0, -1});
  EXPECT_LT(norm(F * glm::dvec3(0, 0, 1) - glm::dvec3(0, 0, -1)), 1e-12);
  EXPECT_NEAR(glm::determinant(F), 1.0, 1e-12);
}

TEST(BodyRotations, SlerpEndsAndMidpoint) {
  const glm::dmat3 a = rot_z(0.2), b = rot_z(1.0);
  EXPECT_LT(rot_err(slerp(a, b, 0), a), 1e-15);
  EXPECT_LT(rot_err(slerp(a, b, 1), b), 1e-15);
  EXPECT_LT(rot_err(slerp(a, b, 0.5), rot_z(0.6)), 1e-12);
  // The shorter arc: from +170 deg to -170 deg passes through 180.
  EXPECT_LT(rot_err(slerp(rot_z(170 * M_PI / 180), rot_z(-170 * M_PI / 180), 0.5), rot_z(M_PI)), 1e-12);
  EXPECT_LT(rot_err(matrix_from_quat(quat_from_matrix(rot_axis({1, 2, 3}, 2.5))), rot_axis({1, 2, 3}, 2.5)),
            1e-12);
}

TEST(BodyForwardKinematics, ChainFollowsTheBvhConvention) {
  Skeleton sk;
  sk.joints = {{"root", -1, {0, 0, 0}, false}, {"a", 0, {1, 0, 0}, false}, {"b", 1, {0, 2, 0}, true}};
  ASSERT_TRUE(sk.valid(nullptr));
  Pose pose = rest_pose(sk, {5, 0, 0});
  pose.local[0] = rot_z(M_PI / 2);  // root turned: its +x is world +y
  pose.local[1] = rot_z(M_PI / 2);
  std::vector<glm::dvec3> p;
  std::vector<glm::dmat3> W;
  forward_kinematics(sk, pose, &p, &W);
  EXPECT_LT(norm(p[0] - glm::dvec3(5, 0, 0)), 1e-12);
  EXPECT_LT(norm(p[1] - glm::dvec3(5, 1, 0)), 1e-12);
  EXPECT_LT(norm(p[2] - glm::dvec3(5, -1, 0)), 1e-12);  // offset (0,2,0) rotated by 180 deg
  EXPECT_LT(rot_err(W[2], rot_z(M_PI)), 1e-12);
  EXPECT_EQ(sk.find("a"), 1);
  EXPECT_EQ(sk.find("zzz"), -1);
  EXPECT_EQ(sk.children(0), std::vector<int>{1});
}

TEST(BodyForwardKinematics, BlendInterpolatesRootAndRotations) {
  Skeleton sk;
  sk.joints = {{"root", -1, {0, 0, 0}, false}, {"a", 0, {1, 0, 0}, false}};
  Pose a = rest_pose(sk, {0, 0, 0}), b = rest_pose(sk, {2, 0, 0});
  b.local[1] = rot_y(1.0);
  const Pose m = blend(a, b, 0.25);
  EXPECT_LT(norm(m.root_position - glm::dvec3(0.5, 0, 0)), 1e-12);
  EXPECT_LT(rot_err(m.local[1], rot_y(0.25)), 1e-12);
  Skeleton bad = sk;
  bad.joints[1].parent = 1;
  EXPECT_FALSE(bad.valid(nullptr));
}

TEST(BodyStandardJoints, TableHierarchyAndExportNames) {
  EXPECT_EQ(joint_name(Joint::l_wrist), "l_wrist");
  EXPECT_EQ(joint_name(99), "?");
  EXPECT_EQ(joint_from_name("r_toe"), static_cast<int>(Joint::r_toe));
  EXPECT_EQ(joint_from_name("nose"), -1);
  EXPECT_EQ(joint_parent(static_cast<int>(Joint::hips)), -1);
  for (int j = 1; j < kJointCount; ++j) {
    EXPECT_GE(joint_parent(j), 0) << joint_name(j);
    EXPECT_LT(joint_parent(j), j) << joint_name(j);  // parents first
    EXPECT_EQ(joint_is_end(j), joint_bvh_name(j).empty()) << joint_name(j);
  }
  EXPECT_EQ(joint_parent(static_cast<int>(Joint::l_shoulder)), static_cast<int>(Joint::spine));
  EXPECT_EQ(joint_parent(static_cast<int>(Joint::r_toe)), static_cast<int>(Joint::r_ankle));
  EXPECT_TRUE(joint_is_end(static_cast<int>(Joint::head_top)));
  EXPECT_TRUE(joint_is_end(static_cast<int>(Joint::l_hand_tip)));
  EXPECT_EQ(joint_bvh_name(static_cast<int>(Joint::hips)), "Hips");
  EXPECT_EQ(joint_bvh_name(static_cast<int>(Joint::l_shoulder)), "LeftArm");
  EXPECT_EQ(joint_bvh_name(static_cast<int>(Joint::r_hip)), "RightUpLeg");
  EXPECT_EQ(joint_bvh_name(static_cast<int>(Joint::l_toe)), "LeftToeBase");
  EXPECT_EQ(feature_joint(Feature::r_foot), Joint::r_ankle);
  EXPECT_EQ(feature_name(Feature::l_hand), "l_hand");
}

TEST(BodyStandardJoints, StandardSkeletonStandsInTheInitializationPose) {
  StandardSegments seg;
  const Skeleton sk = standard_skeleton(seg);
  ASSERT_TRUE(sk.valid(nullptr));
  EXPECT_TRUE(is_standard(sk));
  std::vector<glm::dvec3> p;
  forward_kinematics(sk, rest_pose(sk, {0, 0, 1.0}), &p);
  auto P = [&](Joint j) { return p[static_cast<std::size_t>(j)]; };
  // Arms spread along +-x (left is +x), legs straight down, toes forward (-y), head on top.
  EXPECT_NEAR(P(Joint::l_hand_tip).x - P(Joint::l_shoulder).x, seg.upper_arm_m + seg.forearm_m + seg.hand_m,
              1e-12);
  EXPECT_NEAR(P(Joint::r_wrist).x, -(seg.shoulder_half_width_m + seg.upper_arm_m + seg.forearm_m), 1e-12);
  EXPECT_NEAR(P(Joint::l_ankle).z, 1.0 - seg.pelvis_drop_m - seg.thigh_m - seg.shank_m, 1e-12);
  EXPECT_NEAR(P(Joint::l_toe).y, -seg.foot_forward_m, 1e-12);
  EXPECT_NEAR(P(Joint::head_top).z,
              1.0 + seg.hips_to_spine_m + seg.spine_to_neck_m + seg.neck_to_head_m + seg.head_to_top_m,
              1e-12);
  Skeleton renamed = sk;
  renamed.joints[3].name = "Head";
  EXPECT_FALSE(is_standard(renamed));
  seg.thigh_m = 0;
  EXPECT_THROW(standard_skeleton(seg), std::invalid_argument);
}

}  // namespace
}  // namespace vc::body
