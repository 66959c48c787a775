#include "voxcap/sim/skeleton.hpp"

#include <random>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

namespace vc::sim {
namespace {

double rot_err(const cv::Matx33d& a, const cv::Matx33d& b) { return cv::norm(a - b, cv::NORM_INF); }

TEST(SimRotations, AxisRotationsAgreeWithRodrigues) {
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

TEST(SimRotations, EulerRoundTripInEveryTaitBryanOrder) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-179, 179), v(-89, 89);
  for (const char* order : {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"}) {
    for (int i = 0; i < 200; ++i) {
      const cv::Vec3d deg(u(rng), v(rng), u(rng));
      const cv::Matx33d R = matrix_from_euler(order, deg);
      const cv::Vec3d back = euler_from_matrix(order, R);
      EXPECT_LT(rot_err(matrix_from_euler(order, back), R), 1e-10) << order;
      EXPECT_LT(cv::norm(back - deg), 1e-7) << order;
    }
    // Gimbal lock: the angles change but the rotation does not.
    const cv::Matx33d G = matrix_from_euler(order, {30, 90, 20});
    EXPECT_LT(rot_err(matrix_from_euler(order, euler_from_matrix(order, G)), G), 1e-10) << order;
  }
  // "ZYX" means Rz * Ry * Rx (BVH order of application as written).
  const cv::Matx33d R = matrix_from_euler("ZYX", {10, 20, 30});
  EXPECT_LT(rot_err(R, rot_z(10 * M_PI / 180) * rot_y(20 * M_PI / 180) * rot_x(30 * M_PI / 180)), 1e-14);
}

TEST(SimRotations, RotBetweenIsMinimalAndHandlesOpposites) {
  const cv::Matx33d R = rot_between({1, 0, 0}, {0, 1, 0});
  EXPECT_LT(cv::norm(R * cv::Vec3d(1, 0, 0) - cv::Vec3d(0, 1, 0)), 1e-12);
  EXPECT_LT(cv::norm(R * cv::Vec3d(0, 0, 1) - cv::Vec3d(0, 0, 1)), 1e-12);  // axis untouched
  const cv::Matx33d F = rot_between({0, 0, 2}, {0, 0, -1});
  EXPECT_LT(cv::norm(F * cv::Vec3d(0, 0, 1) - cv::Vec3d(0, 0, -1)), 1e-12);
  EXPECT_NEAR(cv::determinant(F), 1.0, 1e-12);
}

TEST(SimRotations, SlerpEndsAndMidpoint) {
  const cv::Matx33d a = rot_z(0.2), b = rot_z(1.0);
  EXPECT_LT(rot_err(slerp(a, b, 0), a), 1e-15);
  EXPECT_LT(rot_err(slerp(a, b, 1), b), 1e-15);
  EXPECT_LT(rot_err(slerp(a, b, 0.5), rot_z(0.6)), 1e-12);
  // The shorter arc: from +170 deg to -170 deg passes through 180.
  EXPECT_LT(rot_err(slerp(rot_z(170 * M_PI / 180), rot_z(-170 * M_PI / 180), 0.5), rot_z(M_PI)), 1e-12);
  EXPECT_LT(rot_err(matrix_from_quat(quat_from_matrix(rot_axis({1, 2, 3}, 2.5))), rot_axis({1, 2, 3}, 2.5)), 1e-12);
}

TEST(SimForwardKinematics, ChainFollowsTheBvhConvention) {
  Skeleton sk;
  sk.joints = {{"root", -1, {0, 0, 0}, false}, {"a", 0, {1, 0, 0}, false}, {"b", 1, {0, 2, 0}, true}};
  ASSERT_TRUE(sk.valid(nullptr));
  Pose pose = rest_pose(sk, {5, 0, 0});
  pose.local[0] = rot_z(M_PI / 2);  // root turned: its +x is world +y
  pose.local[1] = rot_z(M_PI / 2);
  std::vector<cv::Vec3d> p;
  std::vector<cv::Matx33d> W;
  forward_kinematics(sk, pose, &p, &W);
  EXPECT_LT(cv::norm(p[0] - cv::Vec3d(5, 0, 0)), 1e-12);
  EXPECT_LT(cv::norm(p[1] - cv::Vec3d(5, 1, 0)), 1e-12);
  EXPECT_LT(cv::norm(p[2] - cv::Vec3d(5, -1, 0)), 1e-12);  // offset (0,2,0) rotated by 180 deg
  EXPECT_LT(rot_err(W[2], rot_z(M_PI)), 1e-12);
  EXPECT_EQ(sk.find("a"), 1);
  EXPECT_EQ(sk.find("zzz"), -1);
  EXPECT_EQ(sk.children(0), std::vector<int>{1});
}

TEST(SimForwardKinematics, BlendInterpolatesRootAndRotations) {
  Skeleton sk;
  sk.joints = {{"root", -1, {0, 0, 0}, false}, {"a", 0, {1, 0, 0}, false}};
  Pose a = rest_pose(sk, {0, 0, 0}), b = rest_pose(sk, {2, 0, 0});
  b.local[1] = rot_y(1.0);
  const Pose m = blend(a, b, 0.25);
  EXPECT_LT(cv::norm(m.root_position - cv::Vec3d(0.5, 0, 0)), 1e-12);
  EXPECT_LT(rot_err(m.local[1], rot_y(0.25)), 1e-12);
  Skeleton bad = sk;
  bad.joints[1].parent = 1;
  EXPECT_FALSE(bad.valid(nullptr));
}

}  // namespace
}  // namespace vc::sim
