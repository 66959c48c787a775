// The carver's C structs (carver.h) from the rig calibration (hw/rig), for the C++ code that holds a
// rig::Calibration: tests, benchmarks and the host's truth scoring. The edge daemon builds them from
// the CONFIG message instead. Header-only; link target vc_edge_rig (vc_edge_core + vc_rig).
#pragma once

#include "voxcap/edge/carver.h"
#include "voxcap/rig/camera.hpp"
#include "voxcap/rig/voxel_grid.hpp"

namespace vc::edge {

inline vc_camera_model camera_model(const rig::Camera& c) {
  vc_camera_model m{};
  m.width = c.width;
  m.height = c.height;
  for (int i = 0; i < 9; i++) {
    m.K[i] = c.K.val[i];  // both row-major
    m.R[i] = c.R_cam_from_world.val[i];
  }
  for (int i = 0; i < 5; i++) m.dist[i] = c.dist[i];
  for (int i = 0; i < 3; i++) m.t[i] = c.t_cam_from_world[i];
  return m;
}

inline vc_voxel_grid voxel_grid(const rig::VoxelGrid& g) {
  return {{g.min_m[0], g.min_m[1], g.min_m[2]}, g.voxel_m, g.nx, g.ny, g.nz};
}

}  // namespace vc::edge
