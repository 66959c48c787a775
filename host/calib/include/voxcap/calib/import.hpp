// Calibrations from other systems, converted into a voxcap rig calibration (hw/rig's Calibration,
// written as rig.yaml): `voxcap calib import --from FORMAT FILE -o rig.yaml`.
//
// Every importer reads a file a user hands us, so each is a hardened parser (issue #13): the file is read
// as a bounded regular file (kMaxImportBytes), nesting is bounded before any parser recurses, at most
// kMaxImportCameras cameras, every number must be finite, image sizes within hw/rig's limits, and every
// failure is one ImportError line naming the file and the camera or field. Each format's units and axes
// and the transform into voxcap's world frame (metres, right-handed, z up) are in host/calib/README.md.
//
// Rotations: a source's R that is orthonormal only to its printed precision (Middlebury's deviate by
// ~1e-6, over hw/rig's 1e-6 check) is replaced by the nearest rotation (SVD: U V^T; one within 1e-12 is
// kept as given) and the change is reported (ImportReport::max_rotation_change); one further than
// kMaxRotationError from a rotation
// (|R^T R - I|, max entry), or a reflection (det < 0), is refused.
#pragma once

#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "voxcap/rig/calibration.hpp"

namespace vc::calib {

// Bad input in a file being imported: the message is one line, "PATH: camera 'x': what".
struct ImportError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

enum class Format { OpenCV, Qualisys, Panoptic, Toml, Middlebury };

// "opencv", "qualisys", "panoptic", "toml", "middlebury" (the --from names); nullopt otherwise.
std::optional<Format> parse_format(std::string_view name);
const char* format_name(Format format);
// One line: the format's units and axes and how they are converted (the README's table row).
const char* format_convention(Format format);

inline constexpr std::size_t kMaxImportBytes =
    std::size_t{8} << 20;                       // 8 MiB: a full Panoptic calibration (521 cameras) is ~0.5 MB
inline constexpr int kMaxImportCameras = 1024;  // Panoptic: 521, Middlebury dino: 363
inline constexpr int kMaxImportNesting = 32;    // brackets / elements deep
inline constexpr double kMaxRotationError = 1e-3;  // |R^T R - I| refused above this
inline constexpr std::size_t kMaxCameraName = 64;  // bytes

// Length units where the format leaves them to the file's author (toml, opencv): the source's length
// unit in metres (1 for metres, 0.001 for millimetres).
struct ImportOptions {
  std::optional<double> unit_m;  // override of the format's unit (toml and opencv only)
  // Middlebury's *_par.txt holds no image size: taken from here, else from the first listed image
  // found beside the file (FILE's folder or its images/ subfolder).
  std::optional<cv::Size> image_size;

  bool valid(std::string* why) const;
};

struct ImportReport {
  int cameras = 0;
  int rotations_fixed = 0;            // rotations replaced by their nearest rotation
  double max_rotation_change = 0;     // largest entry change of those replacements
  double max_rotation_error = 0;      // largest |R^T R - I| (max entry) met in the file
  std::string worst_rotation_camera;  // the camera with max_rotation_change
  std::vector<std::string> notes;     // one line each: units, axes, assumptions
};

struct Imported {
  rig::Calibration calibration;
  ImportReport report;
};

// Reads and converts FILE. Throws ImportError (one line) for bad input; std::runtime_error from
// hw/rig's input reader for a file that cannot be read (also one line).
Imported import_calibration(Format format, const std::string& path, const ImportOptions& options = {});
// The same over text already in memory (`path` names it in messages, and Middlebury looks for images
// beside it): tests and fuzzing.
Imported parse_import(Format format, const std::string& text, const std::string& path,
                      const ImportOptions& options = {});

// The nearest rotation to R (SVD), or ImportError naming `where` when R is far from one or a reflection.
// *change receives the largest entry change, *error |R^T R - I| (max entry).
cv::Matx33d nearest_rotation(const cv::Matx33d& R, const std::string& where, double* change, double* error);

}  // namespace vc::calib
