// The two-layer model: forward kinematics against hand-checked values, the law of cosines, the
// level pelvis, the cylinder sample pattern, body.toml.
#include "voxcap/fit/model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <glm/geometric.hpp>
#include <opencv2/core.hpp>

#include "voxcap/fit/init.hpp"

namespace vc::fit {
namespace {

using J = pipeline::PoseJoint;

void expect_near(const Vec3& a, const Vec3& b, double tol, const char* what) {
  EXPECT_NEAR(a.x, b.x, tol) << what;
  EXPECT_NEAR(a.y, b.y, tol) << what;
  EXPECT_NEAR(a.z, b.z, tol) << what;
}

TEST(FitModel, ForwardKinematicsHandChecked) {
  const BodyModel body;  // neck->head 0.155, spine 0.47, shoulders 0.18/0.04, hips 0.09/0.07,
                         // arm 0.30 + 0.26, leg 0.43 + 0.43
  Layer1 l1;
  l1.head_world = Vec3(0, 0, 1.6);
  l1.neck_world = Vec3(0, 0, 1.45);
  // Left wrist 0.5 m out to the left of the shoulder (-x), right arm straight out of reach, legs down.
  l1.end_world = {Vec3(-0.68, 0, 1.41), Vec3(0.18 + 0.7, 0, 1.41), Vec3(-0.09, 0, 0.05), Vec3(0.09, 0, 0.05)};
  const Layer2 l2;  // elbows bend backward (-y), knees forward (+y)
  const auto p = forward_kinematics(body, l1, l2);
  auto at = [&p](J j) { return p[static_cast<size_t>(j)]; };
  expect_near(at(J::head), Vec3(0, 0, 1.6), 1e-12, "head");
  expect_near(at(J::neck), Vec3(0, 0, 1.45), 1e-12, "neck");
  expect_near(at(J::hips), Vec3(0, 0, 0.98), 1e-12, "hips");
  expect_near(at(J::l_shoulder), Vec3(-0.18, 0, 1.41), 1e-12, "l_shoulder");
  expect_near(at(J::r_shoulder), Vec3(0.18, 0, 1.41), 1e-12, "r_shoulder");
  expect_near(at(J::l_hip), Vec3(-0.09, 0, 0.91), 1e-12, "l_hip");
  expect_near(at(J::r_hip), Vec3(0.09, 0, 0.91), 1e-12, "r_hip");
  // Law of cosines by hand: d = 0.5, a = (0.09 - 0.0676 + 0.25) / 1.0 = 0.2724 along the arm,
  // h = sqrt(0.09 - 0.2724^2) = sqrt(0.0157982) = 0.125691 behind it.
  expect_near(at(J::l_elbow), Vec3(-0.18 - 0.2724, -0.125691, 1.41), 1e-6, "l_elbow");
  expect_near(at(J::l_wrist), Vec3(-0.68, 0, 1.41), 1e-12, "l_wrist");
  // Out of reach: straight, the elbow at 0.30/0.56 of the way, the wrist at the goal.
  expect_near(at(J::r_elbow), Vec3(0.18 + 0.7 * 0.30 / 0.56, 0, 1.41), 1e-9, "r_elbow");
  // Legs: 0.86 m to the ankle, exactly the reach: straight, knee half way.
  expect_near(at(J::l_knee), Vec3(-0.09, 0, 0.48), 1e-6, "l_knee");
  expect_near(at(J::r_ankle), Vec3(0.09, 0, 0.05), 1e-12, "r_ankle");

  // The torso turned 90 degrees to the left (facing +x): the shoulders follow the torso frame.
  l1.R_torso_world = Mat3(Vec3(0, 1, 0), Vec3(-1, 0, 0), Vec3(0, 0, 1));
  l1.R_pelvis_world = level_heading(l1.R_torso_world);
  const auto q = forward_kinematics(body, l1, l2);
  expect_near(q[static_cast<size_t>(J::l_shoulder)], Vec3(0, -0.18, 1.41), 1e-12, "turned l_shoulder");
  expect_near(q[static_cast<size_t>(J::r_hip)], Vec3(0, 0.09, 0.91), 1e-12, "turned r_hip");
}

TEST(FitModel, TheHingeKeepsBothSegmentLengthsAndTheBendDirection) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 200; ++i) {
    // Braced lists: drawn in order (a call's arguments are not, and gcc and clang differed).
    const Vec3 root{u(rng), u(rng), 1 + u(rng)};
    const Vec3 dir = glm::normalize(Vec3{u(rng), u(rng), u(rng)});
    const double d = 0.1 + 0.45 * (u(rng) + 1) / 2;  // within reach of 0.30 + 0.26
    const Vec3 bend{u(rng), u(rng), u(rng)};
    const LimbPose p = solve_limb(root, root + d * dir, 0.30, 0.26, bend);
    EXPECT_NEAR(glm::length(p.hinge - root), 0.30, 1e-9);
    EXPECT_NEAR(glm::length(p.end - p.hinge), 0.26, 1e-9);
    // The hinge lies off the segment on the bend direction's side.
    const Vec3 perp = bend - glm::dot(bend, dir) * dir;
    EXPECT_GT(glm::dot(p.hinge - root, perp), 0);
    // phi's complement from the law of cosines.
    const double cos_inner = (0.30 * 0.30 + 0.26 * 0.26 - d * d) / (2 * 0.30 * 0.26);
    EXPECT_NEAR(p.bend_rad, M_PI - std::acos(cos_inner), 1e-6);
  }
}

TEST(FitModel, LevelHeadingKeepsTheHeadingAndLevelsTheHips) {
  // A torso leaning forward 30 degrees and turned 40 degrees.
  const double lean = 30 * M_PI / 180, turn = 40 * M_PI / 180;
  const Vec3 x(std::cos(turn), std::sin(turn), 0);
  const Vec3 y0(-std::sin(turn), std::cos(turn), 0);
  const Vec3 z = std::cos(lean) * Vec3(0, 0, 1) + std::sin(lean) * y0;
  const Mat3 R(x, glm::cross(z, x), z);
  const Mat3 P = level_heading(R);
  expect_near(P[0], x, 1e-12, "x");
  expect_near(P[2], Vec3(0, 0, 1), 1e-12, "z");
  expect_near(P[1], y0, 1e-12, "y");
}

TEST(FitModel, SymmetricEigenAgreesWithOpenCv) {
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 500; ++i) {
    double A[3][3];
    for (int r = 0; r < 3; ++r)
      for (int c = r; c < 3; ++c) A[r][c] = A[c][r] = u(rng) * (i % 3 == 0 ? 1e-4 : 1.0);
    if (i % 7 == 0) A[0][1] = A[1][0] = A[0][2] = A[2][0] = 0;  // already partly diagonal
    const cv::Matx33d M(A[0][0], A[0][1], A[0][2], A[1][0], A[1][1], A[1][2], A[2][0], A[2][1], A[2][2]);
    cv::Matx31d cv_vals;
    cv::Matx33d cv_vecs;
    cv::eigen(M, cv_vals, cv_vecs);
    double vals[3];
    Vec3 vecs[3];
    eigen_sym3(A, vals, vecs);
    const double scale = i % 3 == 0 ? 1e-4 : 1.0;
    for (int r = 0; r < 3; ++r) {
      EXPECT_NEAR(vals[r], cv_vals(r), 1e-12 * scale + 1e-15);
      EXPECT_NEAR(glm::length(vecs[r]), 1, 1e-12);
      // A v = lambda v
      const cv::Vec3d v(vecs[r].x, vecs[r].y, vecs[r].z);
      EXPECT_LT(cv::norm(M * v - vals[r] * v), 1e-10 * scale + 1e-15);
    }
  }
}

TEST(FitModel, SamplePatternFillsBothSegmentsEvenly) {
  const SamplePattern sp = cylinder_sample_pattern(256);
  ASSERT_EQ(sp.samples.size(), 256u);
  EXPECT_EQ(sp.upper, 128);
  double mean_r2 = 0, mean_t = 0;
  for (const SamplePattern::S& s : sp.samples) {
    EXPECT_GT(s.t, 0);
    EXPECT_LT(s.t, 1);
    EXPECT_GE(s.r, 0);
    EXPECT_LE(s.r, 1);
    EXPECT_NEAR(s.c * s.c + s.s * s.s, 1, 1e-5);
    mean_r2 += s.r * s.r / 256.0;
    mean_t += s.t / 256.0;
  }
  EXPECT_NEAR(mean_r2, 0.5, 0.03);  // uniform over the disc
  EXPECT_NEAR(mean_t, 0.5, 0.01);
}

TEST(FitModel, BodyTomlOverridesValuesAndRejectsBadOnes) {
  BodyModel b;
  apply_body_toml_text("upper_arm_m = 0.31\nthigh_m = 0.45 # measured\nspine_m = 1\n", "body.toml", &b);
  EXPECT_DOUBLE_EQ(b.upper_arm_m, 0.31);
  EXPECT_DOUBLE_EQ(b.thigh_m, 0.45);
  EXPECT_DOUBLE_EQ(b.spine_m, 1.0);
  EXPECT_DOUBLE_EQ(b.forearm_m, BodyModel{}.forearm_m);
  const std::pair<std::string, std::string> bad[] = {
      {"upper_arm = 0.3\n", "body.toml: upper_arm: unknown key (line 1)"},
      {"upper_arm_m = \"long\"\n", "body.toml: upper_arm_m: expected a number of metres (line 1)"},
      {"upper_arm_m = 7\n", "body.toml: upper_arm_m: must be in [0.05, 1] m, got 7"},
      {"upper_arm_m = \n", "body.toml: TOML syntax error"},
  };
  for (const auto& [text, expect] : bad) {
    BodyModel c;
    try {
      apply_body_toml_text(text, "body.toml", &c);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
    }
    EXPECT_DOUBLE_EQ(c.upper_arm_m, BodyModel{}.upper_arm_m);  // unchanged on error
  }
  EXPECT_THROW(apply_body_toml_text(std::string(70000, '#'), "big.toml", &b), std::runtime_error);
  EXPECT_THROW(apply_body_toml("/nonexistent/body.toml", &b), std::runtime_error);
}

}  // namespace
}  // namespace vc::fit
