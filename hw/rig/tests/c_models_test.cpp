#include "voxcap/rig/c_models.hpp"

#include <stdexcept>

#include <gtest/gtest.h>

namespace vc::rig {
namespace {

Camera skewed_camera() {
  Camera cam = Camera::look_at("c", 640, 480, 500, cv::Vec3d(3, -2, 1.5), cv::Vec3d(0.1, 0.2, 1.0));
  cam.K(0, 0) = 510;  // fx != fy and an off-centre principal point: every entry tells its place
  cam.K(0, 2) = 321.5;
  cam.K(1, 2) = 233.25;
  cam.dist = {-0.21, 0.04, 0.001, -0.002, 0.003};
  return cam;
}

TEST(RigCModels, CameraIsRowMajorWithNamedFrames) {
  const Camera cam = skewed_camera();
  const vc_camera c = to_c_camera(cam);
  EXPECT_EQ(c.width, 640u);
  EXPECT_EQ(c.height, 480u);
  EXPECT_EQ(c.K[0], 510.0);
  EXPECT_EQ(c.K[2], 321.5);   // cx: row 0, column 2
  EXPECT_EQ(c.K[5], 233.25);  // cy: row 1, column 2
  EXPECT_EQ(c.K[8], 1.0);
  for (int r = 0; r < 3; r++)
    for (int q = 0; q < 3; q++) EXPECT_EQ(c.R_cam_from_world[3 * r + q], cam.R_cam_from_world(r, q));
  for (int i = 0; i < 3; i++) EXPECT_EQ(c.t_cam_from_world[i], cam.t_cam_from_world[i]);
  for (int i = 0; i < 5; i++) EXPECT_EQ(c.dist[i], cam.dist[i]);
}

TEST(RigCModels, RoundTripsExactly) {
  const Camera cam = skewed_camera();
  const Camera back = from_c_camera(to_c_camera(cam));
  EXPECT_EQ(back.width, cam.width);
  EXPECT_EQ(back.height, cam.height);
  EXPECT_EQ(cv::norm(back.K - cam.K, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(back.R_cam_from_world - cam.R_cam_from_world, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(back.t_cam_from_world - cam.t_cam_from_world, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(back.dist - cam.dist, cv::NORM_INF), 0.0);
  // Same pixel for a world point: the C struct is the same camera.
  const cv::Point2d a = cam.project({0.3, -0.1, 1.2}), b = back.project({0.3, -0.1, 1.2});
  EXPECT_EQ(a, b);

  VoxelGrid g;
  g.min_m = {-1.12, -1.0, 0.05};
  g.voxel_m = 0.0175;
  g.nx = 128;
  g.ny = 100;
  g.nz = 64;
  const vc_voxel_grid cg = to_c_grid(g);
  EXPECT_EQ(cg.nx, 128u);
  EXPECT_EQ(cg.ny, 100u);
  EXPECT_EQ(cg.nz, 64u);
  EXPECT_EQ(cg.min_m[1], -1.0);
  EXPECT_EQ(cg.voxel_m, 0.0175);
  const VoxelGrid gb = from_c_grid(cg);
  EXPECT_EQ(gb.count(), g.count());
  EXPECT_EQ(gb.center(5, 6, 7), g.center(5, 6, 7));
}

TEST(RigCModels, InvalidInputThrowsInsteadOfWrapping) {
  Camera cam = skewed_camera();
  cam.width = -640;
  EXPECT_THROW(to_c_camera(cam), std::invalid_argument);
  VoxelGrid g;
  g.voxel_m = 0.02;
  g.nx = -1;
  g.ny = g.nz = 4;
  EXPECT_THROW(to_c_grid(g), std::invalid_argument);
}

}  // namespace
}  // namespace vc::rig
