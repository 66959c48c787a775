#include "voxcap/rig/c_models.hpp"

#include <stdexcept>
#include <string>

namespace vc::rig {

vc_camera to_c_camera(const Camera& camera) {
  std::string why;
  if (!camera.valid(&why)) throw std::invalid_argument("camera " + camera.name + ": " + why);
  vc_camera c{};
  c.width = static_cast<uint32_t>(camera.width);
  c.height = static_cast<uint32_t>(camera.height);
  for (int i = 0; i < 9; i++) {
    c.K[i] = camera.K.val[i];  // cv::Matx is row-major, as the C struct
    c.R_cam_from_world[i] = camera.R_cam_from_world.val[i];
  }
  for (int i = 0; i < 5; i++) c.dist[i] = camera.dist[i];
  for (int i = 0; i < 3; i++) c.t_cam_from_world[i] = camera.t_cam_from_world[i];
  return c;
}

vc_voxel_grid to_c_grid(const VoxelGrid& grid) {
  std::string why;
  if (!grid.valid(&why)) throw std::invalid_argument("voxel grid: " + why);
  vc_voxel_grid g{};
  g.nx = static_cast<uint32_t>(grid.nx);
  g.ny = static_cast<uint32_t>(grid.ny);
  g.nz = static_cast<uint32_t>(grid.nz);
  for (int i = 0; i < 3; i++) g.min_m[i] = grid.min_m[i];
  g.voxel_m = grid.voxel_m;
  return g;
}

Camera from_c_camera(const vc_camera& camera) {
  Camera c;
  c.width = static_cast<int>(camera.width);
  c.height = static_cast<int>(camera.height);
  for (int i = 0; i < 9; i++) {
    c.K.val[i] = camera.K[i];
    c.R_cam_from_world.val[i] = camera.R_cam_from_world[i];
  }
  for (int i = 0; i < 5; i++) c.dist[i] = camera.dist[i];
  for (int i = 0; i < 3; i++) c.t_cam_from_world[i] = camera.t_cam_from_world[i];
  return c;
}

VoxelGrid from_c_grid(const vc_voxel_grid& grid) {
  VoxelGrid g;
  g.nx = static_cast<int>(grid.nx);
  g.ny = static_cast<int>(grid.ny);
  g.nz = static_cast<int>(grid.nz);
  g.min_m = {grid.min_m[0], grid.min_m[1], grid.min_m[2]};
  g.voxel_m = grid.voxel_m;
  return g;
}

}  // namespace vc::rig
