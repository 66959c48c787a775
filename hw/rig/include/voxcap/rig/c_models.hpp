// The rig calibration as the C side of voxcap holds it: rig::Camera → vc_camera, rig::VoxelGrid →
// vc_voxel_grid (proto/include/voxcap/camera_model.h). The one place these conversions are written:
// the host fills CONFIG's cameras and grid with them, and tests, benchmarks and the emulated rig's
// truth scorer hand them to the edge's carver.
#pragma once

#include "voxcap/camera_model.h"
#include "voxcap/rig/camera.hpp"
#include "voxcap/rig/voxel_grid.hpp"

namespace vc::rig {

// Throw std::invalid_argument when the camera or grid is not valid() (the message says why): the C
// structs hold sizes unsigned, so a negative size must not wrap silently.
vc_camera to_c_camera(const Camera& camera);
vc_voxel_grid to_c_grid(const VoxelGrid& grid);

// The inverse conversions (the camera's name is not in the C struct: it comes back empty).
Camera from_c_camera(const vc_camera& camera);
VoxelGrid from_c_grid(const vc_voxel_grid& grid);

}  // namespace vc::rig
