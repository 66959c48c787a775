// The rig calibration file (rig.yaml): every camera's intrinsics, distortion and extrinsics, plus
// optionally the voxel grid, in OpenCV FileStorage YAML. The layout is documented in hw/rig/README.md.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "voxcap/rig/camera.hpp"
#include "voxcap/rig/voxel_grid.hpp"

namespace vc::rig {

struct Calibration {
  std::vector<Camera> cameras;  // cameras[k] is node cam<k> in the file
  std::optional<VoxelGrid> grid;

  bool valid(std::string* why) const;
};

// Reads and validates a calibration file. Throws std::runtime_error whose message starts with the
// path and names the offending node, e.g. "rig.yaml: cam2.K: expected a 3x3 matrix".
Calibration read_calibration(const std::string& path);
// Writes a calibration file (YAML regardless of the extension). Throws std::runtime_error when
// the calibration is invalid or the file cannot be written.
void write_calibration(const std::string& path, const Calibration& calibration);

}  // namespace vc::rig
