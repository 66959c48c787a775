// `voxcap calib import --from FORMAT FILE -o rig.yaml`: a calibration from another system (OpenCV
// FileStorage, Qualisys .qca, CMU Panoptic JSON, Pose2Sim/anipose/FreeMoCap TOML, Middlebury *_par.txt)
// converted into voxcap's world frame and written as rig.yaml (host/calib). Bad input is one line and
// exit 2; the import prints the cameras, the convention applied and any rotation it re-orthonormalised.
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "voxcap/calib/import.hpp"
#include "voxcap/rig/calibration.hpp"

namespace vc::cli {
namespace {

struct ImportArgs {
  std::string from, file, out, units;
  std::vector<int> image_size;
};

std::optional<double> unit_of(const std::string& units) {
  if (units.empty()) return std::nullopt;
  if (units == "m") return 1.0;
  if (units == "cm") return 0.01;
  if (units == "mm") return 0.001;
  throw UsageError("calib import: --units must be m, cm or mm, got '" + units + "'");
}

void run_import(const ImportArgs& a) {
  const std::optional<calib::Format> format = calib::parse_format(a.from);
  if (!format)
    throw UsageError("calib import: --from must be opencv, qualisys, panoptic, toml or middlebury, got '" +
                     a.from + "'");
  calib::ImportOptions o;
  o.unit_m = unit_of(a.units);
  if (!a.image_size.empty()) {
    if (a.image_size.size() != 2) throw UsageError("calib import: --image-size takes W H");
    o.image_size = cv::Size(a.image_size[0], a.image_size[1]);
  }
  std::string why;
  if (!o.valid(&why)) throw UsageError("calib import: " + why);
  calib::Imported imp;
  try {
    imp = calib::import_calibration(*format, a.file, o);
  } catch (const std::runtime_error& e) {  // the file's fault: bad input
    throw UsageError(e.what());
  }
  rig::write_calibration(a.out, imp.calibration);
  const calib::ImportReport& r = imp.report;
  std::printf("%s: %d cameras (%s) -> %s\n", a.file.c_str(), r.cameras, calib::format_name(*format),
              a.out.c_str());
  std::printf("  convention: %s\n", calib::format_convention(*format));
  for (const std::string& n : r.notes) std::printf("  %s\n", n.c_str());
  if (r.rotations_fixed > 0)
    std::printf(
        "  re-orthonormalised %d rotation(s) (SVD): max entry change %.3g (camera '%s'), max |R^T R - I| "
        "%.3g\n",
        r.rotations_fixed, r.max_rotation_change, r.worst_rotation_camera.c_str(), r.max_rotation_error);
  else
    std::printf("  rotations orthonormal as given (max |R^T R - I| %.3g)\n", r.max_rotation_error);
}

}  // namespace

void add_calib_commands(CLI::App& app) {
  CLI::App* calib = app.add_subcommand("calib", "Calibrations from other systems (host/calib)");
  calib->require_subcommand(1, 1);
  auto a = std::make_shared<ImportArgs>();
  CLI::App* imp = calib->add_subcommand(
      "import",
      "Convert a calibration into rig.yaml in voxcap's world frame (metres, z up; Middlebury keeps its own "
      "frame). FORMAT: opencv (FileStorage YAML/XML: per-camera maps with K/camera_matrix, dist, R or rvec, "
      "t, "
      "width/height; OpenCV's calibration sample; stereo M1 D1 M2 D2 R T), qualisys (.qca XML: mm, lab frame "
      "z "
      "up), panoptic (calibration*.json, camera_parameters.json: cm, up -y), toml "
      "(Pose2Sim/anipose/FreeMoCap: "
      "Rodrigues rotations, --units), middlebury (*_par.txt: P = K [R | t]). Rotations orthonormal only to "
      "print precision are re-orthonormalised (reported); host/calib/README.md has every transform");
  imp->add_option("--from", a->from, "The source format: opencv, qualisys, panoptic, toml or middlebury")
      ->required();
  imp->add_option("FILE", a->file, "The calibration file to import")->required();
  imp->add_option("-o,--out", a->out, "The rig.yaml to write")->required();
  imp->add_option("--units", a->units,
                  "Length unit of the file's translations for toml and opencv: m (default), cm or mm "
                  "(anipose and FreeMoCap write the board's unit, usually mm)");
  imp->add_option("--image-size", a->image_size,
                  "W H: image size when the file has none (Middlebury: else read from the first listed "
                  "image beside the file or in its images/ folder)")
      ->expected(2)
      ->allow_extra_args(false);
  imp->callback([a] { run_import(*a); });
}

}  // namespace vc::cli
