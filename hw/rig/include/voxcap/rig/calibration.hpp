// The rig calibration file (rig.yaml): every camera's intrinsics, distortion and extrinsics, plus
// optionally the voxel grid, in OpenCV FileStorage YAML. The layout is documented in hw/rig/README.md.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
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
// path and names the offending node, e.g. "rig.yaml: cam2.K: expected a 3x3 matrix". Only a regular
// file of at most kMaxCalibrationBytes (input_file.hpp) is read; its text must pass check_yaml_limits.
Calibration read_calibration(const std::string& path);
// The same over a file's text already in memory (`path` names it in messages): tests and fuzzing.
Calibration parse_calibration(const std::string& text, const std::string& path);

// Limits checked on the text before OpenCV's parser sees it (it recurses per level and wraps integers).
inline constexpr int kMaxYamlDepth = 32;            // block indentation levels + `- ` + `[`/`{` open
inline constexpr std::size_t kMaxYamlLine = 16384;  // bytes per line
// Throws std::runtime_error("PATH: line N: nested more than 32 levels deep") and the like: too large,
// a NUL byte, a line too long, nesting too deep, a plain integer outside int32.
void check_yaml_limits(std::string_view text, const std::string& path);
// Writes a calibration file (YAML regardless of the extension). Throws std::runtime_error when
// the calibration is invalid or the file cannot be written.
void write_calibration(const std::string& path, const Calibration& calibration);

}  // namespace vc::rig
