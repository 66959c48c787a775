#include "voxcap/rig/camera.hpp"

#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

namespace vc::rig {
namespace {

Camera random_camera(std::mt19937& rng, bool distorted) {
  std::uniform_real_distribution<double> u(-1, 1);
  const double angle = 2 * M_PI * (u(rng) + 1) / 2;
  // Braced lists and one draw per statement: the order of the draws is fixed (in a call's argument list
  // it is not, and gcc and clang would test different cameras).
  const cv::Vec3d eye{4 * std::cos(angle), 4 * std::sin(angle), 2.0 + 0.5 * u(rng)};
  const double focal = 500 + 100 * u(rng);
  const cv::Vec3d target{0.2 * u(rng), 0.2 * u(rng), 1.0 + 0.2 * u(rng)};
  Camera cam = Camera::look_at("c", 640, 480, focal, eye, target);
  cam.K(0, 0) *= 1.0 + 0.01 * u(rng);  // fx != fy, off-centre principal point
  cam.K(0, 2) += 10 * u(rng);
  cam.K(1, 2) += 10 * u(rng);
  if (distorted)
    cam.dist = {-0.2 + 0.05 * u(rng), 0.05 * u(rng), 0.002 * u(rng), 0.002 * u(rng), 0.01 * u(rng)};
  return cam;
}

std::vector<cv::Point3d> random_points(std::mt19937& rng, int n) {
  std::uniform_real_distribution<double> u(-1.2, 1.2), z(0, 2.2);
  std::vector<cv::Point3d> pts;
  for (int i = 0; i < n; ++i) pts.push_back(cv::Point3d{u(rng), u(rng), z(rng)});  // braced: in order
  return pts;
}

class RigCameraProjection : public ::testing::TestWithParam<bool> {};

TEST_P(RigCameraProjection, MatchesCvProjectPoints) {
  std::mt19937 rng(42);
  for (int c = 0; c < 20; ++c) {
    const Camera cam = random_camera(rng, GetParam());
    ASSERT_TRUE(cam.valid(nullptr));
    const auto pts = random_points(rng, 200);
    cv::Vec3d rvec;
    cv::Rodrigues(cam.R_cam_from_world, rvec);
    std::vector<cv::Point2d> ref;
    cv::projectPoints(pts, rvec, cam.t_cam_from_world, cam.K, cam.dist, ref);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const cv::Point2d px = cam.project(cv::Vec3d(pts[i].x, pts[i].y, pts[i].z));
      // The only difference is R -> rvec -> R inside projectPoints (~1e-16 relative).
      EXPECT_NEAR(px.x, ref[i].x, 1e-9);
      EXPECT_NEAR(px.y, ref[i].y, 1e-9);
    }
  }
}

TEST_P(RigCameraProjection, RayThroughProjectedPixelPassesThroughThePoint) {
  std::mt19937 rng(7);
  for (int c = 0; c < 10; ++c) {
    const Camera cam = random_camera(rng, GetParam());
    for (const auto& p : random_points(rng, 100)) {
      const cv::Vec3d p_world(p.x, p.y, p.z);
      const cv::Vec3d ray = cam.ray_world(cam.project(p_world));
      const cv::Vec3d to_p = cv::normalize(p_world - cam.center_world());
      EXPECT_LT(cv::norm(ray - to_p), 1e-12);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(RigDistortion, RigCameraProjection, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& p) {
                           return p.param ? "distorted" : "pinhole";
                         });

TEST(RigCamera, LookAtPutsTargetAtPrincipalPointAndUpUp) {
  const Camera cam = Camera::look_at("front", 640, 480, 500, {0, -4, 2}, {0, 0, 1});
  ASSERT_TRUE(cam.valid(nullptr));
  const cv::Point2d c = cam.project({0, 0, 1});
  EXPECT_NEAR(c.x, 319.5, 1e-9);
  EXPECT_NEAR(c.y, 239.5, 1e-9);
  // A point above the target is higher in the image (smaller v); +x world is to the right here.
  EXPECT_LT(cam.project({0, 0, 1.5}).y, c.y);
  EXPECT_GT(cam.project({0.5, 0, 1}).x, c.x);
  EXPECT_LT(cv::norm(cam.center_world() - cv::Vec3d(0, -4, 2)), 1e-12);
  EXPECT_GT(cam.to_cam({0, 0, 1})[2], 0);
}

TEST(RigCamera, ProjectionMatrixAgreesWithoutDistortion) {
  const Camera cam = Camera::look_at("c", 320, 240, 300, {3, 1, 2}, {0, 0, 1});
  const cv::Matx34d P = cam.projection_matrix();
  const cv::Vec3d p(0.3, -0.2, 1.4);
  const cv::Vec3d h = P * cv::Vec4d(p[0], p[1], p[2], 1);
  const cv::Point2d px = cam.project(p);
  EXPECT_NEAR(h[0] / h[2], px.x, 1e-9);
  EXPECT_NEAR(h[1] / h[2], px.y, 1e-9);
}

TEST(RigCamera, InImageUsesPixelCentreConvention) {
  Camera cam = Camera::look_at("c", 10, 8, 10, {0, -4, 2}, {0, 0, 1});
  EXPECT_TRUE(cam.in_image({-0.5, -0.5}));
  EXPECT_TRUE(cam.in_image({9.49, 7.49}));
  EXPECT_FALSE(cam.in_image({9.5, 3}));
  EXPECT_FALSE(cam.in_image({3, -0.51}));
}

TEST(RigCamera, ValidRejectsBadModels) {
  const Camera good = Camera::look_at("c", 640, 480, 500, {0, -4, 2}, {0, 0, 1});
  std::string why;
  ASSERT_TRUE(good.valid(&why)) << why;

  Camera c = good;
  c.width = 0;
  EXPECT_FALSE(c.valid(&why));
  EXPECT_NE(why.find("size"), std::string::npos);

  c = good;
  c.K(0, 1) = 0.5;
  EXPECT_FALSE(c.valid(&why));
  EXPECT_NE(why.find("skew"), std::string::npos);

  c = good;
  c.K(1, 1) = -1;
  EXPECT_FALSE(c.valid(&why));

  c = good;
  c.R_cam_from_world = c.R_cam_from_world * 1.01;
  EXPECT_FALSE(c.valid(&why));
  EXPECT_NE(why.find("rotation"), std::string::npos);

  c = good;
  c.R_cam_from_world = -c.R_cam_from_world;  // a reflection
  EXPECT_FALSE(c.valid(&why));

  c = good;
  c.dist[0] = std::nan("");
  EXPECT_FALSE(c.valid(&why));
}

}  // namespace
}  // namespace vc::rig
