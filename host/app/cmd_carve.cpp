// `voxcap carve --calib rig.yaml --images DIR [--background DIR | --silhouettes DIR | --threshold T
// [--dilate PX --erode PX]] [--grid-min X Y Z --voxel S --dims NX NY NZ | --auto N] --out hull.ply
// [--preview hull.png] [--npy hull.npy]`: the edge's own subtraction and carving code over image folders
// (host/calib's CarveSession), so a rig and its calibration can be checked on real images without boards.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "voxcap/calib/carve.hpp"
#include "voxcap/rig/calibration.hpp"

namespace vc::cli {
namespace {

namespace fs = std::filesystem;

struct CarveArgs {
  std::string calib, images, background, silhouettes, out, preview, npy;
  std::optional<double> threshold;
  int dilate = 0, erode = 0, auto_n = 0;
  std::vector<double> grid_min;
  std::optional<double> voxel;
  std::vector<int> dims;
};

// With several frames, frame f's outputs are NAME-<frame>.EXT (<frame>: the first camera's file name).
std::string output_for(const std::string& path, const calib::CarveSession& s, int f) {
  if (path.empty() || s.frames() == 1) return path;
  const fs::path p(path);
  return (p.parent_path() / (p.stem().string() + "-" + s.frame_name(f) + p.extension().string())).string();
}

void run_carve(const CarveArgs& a) {
  calib::CarveOptions o;
  o.images = a.images;
  const int sources = !a.background.empty() + !a.silhouettes.empty() + a.threshold.has_value();
  if (sources != 1) throw UsageError("carve: give exactly one of --background, --silhouettes, --threshold");
  if (!a.background.empty()) {
    o.source = calib::MaskSource::Background;
    o.background = a.background;
  } else if (!a.silhouettes.empty()) {
    o.source = calib::MaskSource::Silhouettes;
    o.silhouettes = a.silhouettes;
  } else {
    o.source = calib::MaskSource::Threshold;
    o.threshold = *a.threshold;
  }
  o.dilate_px = a.dilate;
  o.erode_px = a.erode;
  const bool explicit_grid = !a.grid_min.empty() || a.voxel || !a.dims.empty();
  if (explicit_grid) {
    if (a.grid_min.size() != 3 || !a.voxel || a.dims.size() != 3)
      throw UsageError(
          "carve: an explicit grid needs all of --grid-min X Y Z, --voxel S and --dims NX NY NZ");
    rig::VoxelGrid g;
    g.min_m = cv::Vec3d(a.grid_min[0], a.grid_min[1], a.grid_min[2]);
    g.voxel_m = *a.voxel;
    g.nx = a.dims[0];
    g.ny = a.dims[1];
    g.nz = a.dims[2];
    o.grid = g;
  }
  o.auto_n = a.auto_n;
  std::string why;
  if (!o.valid(&why)) throw UsageError("carve: " + why);
  rig::Calibration cal;
  try {
    cal = rig::read_calibration(a.calib);
  } catch (const std::runtime_error& e) {
    throw UsageError(e.what());
  }
  try {
    calib::CarveSession s(cal, o);
    const rig::VoxelGrid& g = s.grid();
    std::printf("carve: %zu cameras matched", s.cameras().size());
    if (!s.skipped().empty()) std::printf(", %zu without images left out", s.skipped().size());
    std::printf(", %d frame(s); grid min (%.6g, %.6g, %.6g) voxel %.6g dims %d %d %d\n", s.frames(),
                g.min_m[0], g.min_m[1], g.min_m[2], g.voxel_m, g.nx, g.ny, g.nz);
    for (int f = 0; f < s.frames(); ++f) {
      const calib::Hull hull = s.carve(f);
      calib::write_ply(output_for(a.out, s, f), hull);
      if (!a.npy.empty()) calib::write_npy(output_for(a.npy, s, f), hull);
      if (!a.preview.empty()) calib::write_preview(output_for(a.preview, s, f), hull);
      int lo[3], hi[3];
      if (hull.bounds(lo, hi)) {
        const cv::Vec3d bl = g.min_m + cv::Vec3d(lo[0], lo[1], lo[2]) * g.voxel_m;
        const cv::Vec3d bh = g.min_m + cv::Vec3d(hi[0] + 1, hi[1] + 1, hi[2] + 1) * g.voxel_m;
        std::printf("  %s: %zu voxels, box (%.4f %.4f %.4f) - (%.4f %.4f %.4f) m -> %s\n",
                    s.frame_name(f).c_str(), hull.occupied, bl[0], bl[1], bl[2], bh[0], bh[1], bh[2],
                    output_for(a.out, s, f).c_str());
      } else {
        std::printf("  %s: empty hull -> %s\n", s.frame_name(f).c_str(), output_for(a.out, s, f).c_str());
      }
    }
  } catch (const calib::CarveError& e) {
    throw UsageError(std::string("carve: ") + e.what());
  }
}

}  // namespace

void add_carve_commands(CLI::App& app) {
  auto a = std::make_shared<CarveArgs>();
  CLI::App* cmd = app.add_subcommand(
      "carve",
      "Carve visual hulls from image folders with the edge's own subtraction and carver (host/calib): one "
      "image "
      "per camera and frame, matched to the calibration's cameras by name (DIR/NAME/ holding the frames in "
      "name "
      "order, or DIR/NAME.png as one frame; cameras without images are left out). The pairs of cameras are "
      "carved as edge nodes would, their hulls ANDed as the host does (the subpixel rule)");
  cmd->add_option("--calib", a->calib, "rig.yaml (voxcap calib import writes one)")->required();
  cmd->add_option("--images", a->images, "Folder of images, one per camera and frame")->required();
  cmd->add_option(
      "--background", a->background,
      "Folder of empty-scene frames (same layout): the edge's background subtraction and clean-up");
  cmd->add_option("--silhouettes", a->silhouettes, "Folder of masks (same layout, nonzero = foreground)");
  cmd->add_option("--threshold", a->threshold, "Foreground where luminance (0-1) > T");
  cmd->add_option("--dilate", a->dilate, "With --threshold: dilate the mask by a disc of PX pixels");
  cmd->add_option("--erode", a->erode, "With --threshold: then erode it by a disc of PX pixels");
  cmd->add_option("--grid-min", a->grid_min, "X Y Z: the grid's min corner, metres (DESIGN.md's voxel grid)")
      ->expected(3)
      ->allow_extra_args(false);
  cmd->add_option("--voxel", a->voxel, "S: the voxel edge, metres");
  cmd->add_option("--dims", a->dims, "NX NY NZ: voxels along x, y, z")->expected(3)->allow_extra_args(false);
  cmd->add_option("--auto", a->auto_n,
                  "N: a grid of N voxels on its longest side around the region every matched camera sees "
                  "(found by sampling, host/calib/README.md); without a grid option the calibration's grid");
  cmd->add_option("--out", a->out, "hull.ply: binary PLY of the occupied voxel centres")->required();
  cmd->add_option("--preview", a->preview, "hull.png: the hull seen from above, the front and the side");
  cmd->add_option(
      "--npy", a->npy,
      "hull.npy: the flat boolean occupancy in DESIGN.md's voxel order (index i + nx*(j + ny*k))");
  cmd->callback([a] { run_carve(*a); });
}

}  // namespace vc::cli
