// `voxcap calibrate solve|capture`: calibrating a rig from board views (host/calibrate).
//   solve   --images DIR [--board SPEC] -o rig.yaml [--report DIR] [--floor NAME] [--grid-min X Y Z
//           --voxel S --dims NX NY NZ]: detection, intrinsics, chained extrinsics, bundle adjustment, world
//           frame from the floor view; the rig calibration file, the report (text and PNG).
//   capture --emulated --out DIR: the virtual rig renders the board sequence (hw/sim); frames where the
//           board is well seen by two or more cameras (and the floor view) are kept in solve's layout, with
//           progress: views per camera, a coarse coverage grid per image, what is still missing.
// A real rig cannot be asked for synchronized frames yet: the protocol has no frame-grab message.
#include <array>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "commands.hpp"
#include "voxcap/calibrate/board.hpp"
#include "voxcap/calibrate/folders.hpp"
#include "voxcap/calibrate/solve.hpp"
#include "voxcap/rig/calibration.hpp"
#include "voxcap/sim/board.hpp"

namespace vc::cli {
namespace {

namespace fs = std::filesystem;

constexpr const char* kDefaultBoard = "charuco:5x4:0.2:0.15:DICT_4X4_50";

calibrate::BoardSpec board_arg(const std::string& spec, const char* cmd) {
  try {
    return calibrate::parse_board_spec(spec);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string(cmd) + ": --board: " + e.what());
  }
}

struct SolveArgs {
  std::string images, board = kDefaultBoard, out, report, floor = "floor";
  std::vector<double> grid_min{-1.25, -1.25, 0.0};
  double voxel = 0.02;
  std::vector<int> dims{125, 125, 110};
  bool quiet = false;
};

void run_solve(const SolveArgs& a) {
  if (a.images.empty()) throw UsageError("calibrate solve: --images DIR is required");
  if (a.out.empty()) throw UsageError("calibrate solve: -o rig.yaml is required");
  const calibrate::BoardSpec board = board_arg(a.board, "calibrate solve");
  calibrate::SolveOptions opt;
  rig::VoxelGrid grid;
  grid.min_m = cv::Vec3d(a.grid_min[0], a.grid_min[1], a.grid_min[2]);
  grid.voxel_m = a.voxel;
  grid.nx = a.dims[0];
  grid.ny = a.dims[1];
  grid.nz = a.dims[2];
  std::string why;
  if (!grid.valid(&why)) throw UsageError("calibrate solve: grid: " + why);
  opt.grid = grid;
  std::error_code ec;
  if (!fs::is_directory(a.images, ec))
    throw UsageError("calibrate solve: --images: " + a.images + " is not a folder");
  std::function<void(int, int)> progress;
  if (!a.quiet) {
    progress = [](int done, int total) {
      if (done == total || done % 20 == 0) {
        std::fprintf(stderr, "\rvoxcap calibrate: detecting the board: %d/%d images", done, total);
        if (done == total) std::fputc('\n', stderr);
      }
    };
  }
  calibrate::Capture cap;
  try {
    cap = calibrate::load_capture(a.images, board, a.floor, progress);
  } catch (const std::runtime_error& e) {
    throw UsageError(std::string("calibrate solve: ") + e.what());
  }
  calibrate::Solution s;
  try {
    s = calibrate::solve(cap, opt);
  } catch (const calibrate::DegenerateCapture& e) {
    throw UsageError(e.what());
  }
  rig::write_calibration(a.out, s.calibration);
  const std::string text = calibrate::report_text(cap, s);
  if (!a.report.empty()) calibrate::write_report(a.report, cap, s);
  if (!a.quiet) fmt::print("{}", text);
  fmt::print("wrote {} ({} cameras, reprojection RMS {:.3f} px){}\n", a.out, s.calibration.cameras.size(),
             s.rms_px, a.report.empty() ? "" : ", report in " + a.report);
}

struct CaptureArgs {
  bool emulated = false;
  std::string out, board = kDefaultBoard, size = "640x480", room = "default", calibration;
  int cameras = 6, poses = 80, min_corners = 6;
  double noise = 2.0;
  bool distortion = true;
  std::uint64_t seed = 1;
  bool quiet = false;
};

void write_png(const fs::path& p, const cv::Mat& rgb) {
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  if (!cv::imwrite(p.string(), bgr)) throw std::runtime_error(p.string() + ": cannot write");
}

void run_capture(const CaptureArgs& a) {
  if (!a.emulated) {
    throw UsageError(
        "calibrate capture: only --emulated for now: the protocol has no message to ask the edges for "
        "synchronized "
        "frames; record image folders (DIR/<camera>/<frame>.png) and run voxcap calibrate solve --images "
        "DIR");
  }
  if (a.out.empty()) throw UsageError("calibrate capture: --out DIR is required");
  const calibrate::BoardSpec board = board_arg(a.board, "calibrate capture");
  if (board.kind != calibrate::BoardSpec::Kind::charuco) {
    throw UsageError("calibrate capture: the virtual rig renders ChArUco boards only");
  }
  sim::BoardCaptureOptions o;
  o.board.squares_x = board.squares_x;
  o.board.squares_y = board.squares_y;
  o.board.square_m = board.square_m;
  o.board.marker_m = board.marker_m;
  o.board.dictionary = board.dictionary;
  o.held_poses = a.poses;
  o.noise_sigma = a.noise;
  o.seed = a.seed;
  o.room = a.room;
  o.rig.cameras = a.cameras;
  o.rig.distortion = a.distortion;
  int w = 0, h = 0;
  char tail = 0;
  if (std::sscanf(a.size.c_str(), "%dx%d%c", &w, &h, &tail) != 2 || w <= 0 || h <= 0) {
    throw UsageError("calibrate capture: --size must be WxH, e.g. 640x480 (got '" + a.size + "')");
  }
  o.rig.width = w;
  o.rig.height = h;
  if (!a.calibration.empty()) {
    try {
      o.calibration = rig::read_calibration(a.calibration);
    } catch (const std::exception& e) {
      throw UsageError(std::string("calibrate capture: --calibration: ") + e.what());
    }
  }
  std::string why;
  if (!o.valid(&why)) throw UsageError("calibrate capture: " + why);
  const sim::BoardScene scene(o);
  const int n_cam = scene.camera_count();
  std::vector<std::string> names;
  for (const rig::Camera& c : scene.calibration().cameras) names.push_back(c.name);
  std::error_code ec;
  for (const std::string& n : names) {
    fs::create_directories(fs::path(a.out) / n, ec);
    if (ec) throw std::runtime_error(a.out + "/" + n + ": cannot create (" + ec.message() + ")");
  }
  // The truth beside the capture (a file, so solve does not take it for a camera folder).
  rig::write_calibration((fs::path(a.out) / "truth_rig.yaml").string(), scene.calibration());

  constexpr int kCells = 4;
  std::vector<int> views(static_cast<std::size_t>(n_cam), 0);
  std::vector<std::array<bool, kCells * kCells>> cover(static_cast<std::size_t>(n_cam));
  int kept = 0;
  std::vector<cv::Mat> rgb(static_cast<std::size_t>(n_cam));
  for (int f = 0; f < scene.frame_count(); ++f) {
    const bool floor = f == scene.floor_frame();
    std::vector<int> seen;
    std::vector<calibrate::Detection> det(static_cast<std::size_t>(n_cam));
    for (int c = 0; c < n_cam; ++c) {
      const auto cu = static_cast<std::size_t>(c);
      scene.render(f, c, rgb[cu]);
      det[cu] = calibrate::detect_board(rgb[cu], board);
      if (static_cast<int>(det[cu].ids.size()) >= a.min_corners) seen.push_back(c);
    }
    // A held frame is kept when two or more cameras see the board well; the floor view always (it sets
    // the world frame; solve says so when no camera sees it).
    const bool keep = floor || seen.size() >= 2;
    if (keep) {
      ++kept;
      const std::string name = floor ? "floor" : fmt::format("{:04d}", f);
      for (int c = 0; c < n_cam; ++c) {
        write_png(fs::path(a.out) / names[static_cast<std::size_t>(c)] / (name + ".png"),
                  rgb[static_cast<std::size_t>(c)]);
      }
      for (int c : seen) {
        const auto cu = static_cast<std::size_t>(c);
        if (!floor) ++views[cu];
        const rig::Camera& cam = scene.calibration().cameras[cu];
        for (const cv::Point2d& p : det[cu].image_px) {
          const int gx = std::clamp(static_cast<int>(p.x * kCells / cam.width), 0, kCells - 1);
          const int gy = std::clamp(static_cast<int>(p.y * kCells / cam.height), 0, kCells - 1);
          cover[cu][(static_cast<std::size_t>(gy) * std::size_t{kCells} + static_cast<std::size_t>(gx))] =
              true;
        }
      }
    }
    if (!a.quiet) {
      std::string line = fmt::format("frame {:3d}/{}{}: {} ", f + 1, scene.frame_count(),
                                     floor ? " (floor)" : "", keep ? "kept" : "skipped");
      line += " views:";
      for (int c = 0; c < n_cam; ++c) line += fmt::format(" {}", views[static_cast<std::size_t>(c)]);
      std::fprintf(stderr, "\r%-90s", line.c_str());
    }
  }
  if (!a.quiet) std::fputc('\n', stderr);
  // Coverage grids and what is missing.
  fmt::print("kept {} of {} frames in {}\n", kept, scene.frame_count(), a.out);
  fmt::print("coverage ({}x{} cells per image, # = board corners seen there):\n", kCells, kCells);
  for (int row = 0; row < kCells; ++row) {
    std::string line;
    for (int c = 0; c < n_cam; ++c) {
      line += "  ";
      for (int col = 0; col < kCells; ++col)
        line += cover[static_cast<std::size_t>(c)]
                     [(static_cast<std::size_t>(row) * std::size_t{kCells} + static_cast<std::size_t>(col))]
                    ? '#'
                    : '.';
      line += "  ";
    }
    fmt::print("{}\n", line);
  }
  std::vector<std::string> missing;
  for (int c = 0; c < n_cam; ++c) {
    const auto cu = static_cast<std::size_t>(c);
    const calibrate::SolveOptions so;
    const int covered = static_cast<int>(std::count(cover[cu].begin(), cover[cu].end(), true));
    fmt::print("{}: {} views, {} of {} cells\n", names[cu], views[cu], covered, kCells * kCells);
    if (views[cu] < so.warn_views)
      missing.push_back(fmt::format("{} needs {} more views", names[cu], so.warn_views - views[cu]));
    if (covered < kCells * kCells / 2)
      missing.push_back(fmt::format("{} needs the board nearer its image edges", names[cu]));
  }
  if (missing.empty()) {
    fmt::print("nothing missing: run voxcap calibrate solve --images {} -o rig.yaml\n", a.out);
  } else {
    for (const std::string& m : missing) fmt::print("still missing: {}\n", m);
  }
}

}  // namespace

void add_calibrate_commands(CLI::App& app) {
  CLI::App* cal = app.add_subcommand("calibrate", "Calibrate a rig from views of a ChArUco (or chess) board");
  cal->require_subcommand(1, 1);

  auto s = std::make_shared<SolveArgs>();
  CLI::App* solve =
      cal->add_subcommand("solve",
                          "Solve the rig from image folders (DIR/<camera>/<frame>.png, frames matched by "
                          "file name, the board lying "
                          "on the floor in frame 'floor'): intrinsics (k1 k2 p1 p2 k3), extrinsics chained "
                          "through shared views, one "
                          "bundle adjustment (Ceres, Huber loss), the world frame from the floor board "
                          "(origin at its origin, z up). "
                          "A degenerate capture is refused with one line naming the camera (exit 2)");
  solve->add_option("--images", s->images, "Folder of camera folders")->required();
  solve->add_option("--board", s->board, "charuco:SXxSY:SQUARE_M:MARKER_M:DICT or chessboard:SXxSY:SQUARE_M")
      ->capture_default_str();
  solve->add_option("-o,--out", s->out, "The rig calibration file to write (hw/rig's rig.yaml)")->required();
  solve->add_option("--report", s->report,
                    "Folder for report.txt and report.png (cameras and volume from above and the side)");
  solve->add_option("--floor", s->floor, "Frame name of the board lying on the floor")->capture_default_str();
  solve
      ->add_option("--grid-min", s->grid_min,
                   "Voxel grid min corner X Y Z (metres), checked against every view")
      ->expected(3)
      ->capture_default_str();
  solve->add_option("--voxel", s->voxel, "Voxel edge (metres)")->capture_default_str();
  solve->add_option("--dims", s->dims, "Voxel grid dims NX NY NZ")->expected(3)->capture_default_str();
  solve->add_flag("--quiet", s->quiet, "Only the summary line");
  solve->callback([s] { run_solve(*s); });

  auto c = std::make_shared<CaptureArgs>();
  CLI::App* capture = cal->add_subcommand("capture",
                                          "Capture board views for solve: with --emulated the virtual rig "
                                          "renders a ChArUco board held in varied poses "
                                          "and lying on the floor; frames where two or more cameras see the "
                                          "board well are kept. A real rig: not yet "
                                          "(the protocol has no frame-grab message)");
  capture->add_flag("--emulated", c->emulated, "Use the virtual rig (hw/sim)");
  capture->add_option("--out", c->out, "Output folder: <camera>/<frame>.png, floor.png, truth_rig.yaml")
      ->required();
  capture->add_option("--board", c->board, "charuco:SXxSY:SQUARE_M:MARKER_M:DICT")->capture_default_str();
  capture->add_option("--poses", c->poses, "Board poses held in the volume (then one on the floor)")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  capture->add_option("--cameras", c->cameras, "Cameras of the default ring")
      ->check(CLI::Range(2, 64))
      ->capture_default_str();
  capture->add_option("--size", c->size, "Image size WxH")->capture_default_str();
  capture->add_option("--calibration", c->calibration,
                      "The virtual cameras from this rig.yaml instead of the ring");
  capture->add_option("--noise", c->noise, "Sensor noise sigma, 8-bit levels")
      ->check(CLI::Range(0.0, 64.0))
      ->capture_default_str();
  capture->add_option("--distortion", c->distortion, "Lens distortion on the ring's cameras (true/false)")
      ->capture_default_str();
  capture->add_option("--room", c->room, "Room preset behind the board")->capture_default_str();
  capture->add_option("--seed", c->seed, "Seed of the poses and the noise")->capture_default_str();
  capture->add_option("--min-corners", c->min_corners, "Corners for a camera to count as seeing the board")
      ->check(CLI::Range(4, 10000))
      ->capture_default_str();
  capture->add_flag("--quiet", c->quiet, "No per-frame progress");
  capture->callback([c] { run_capture(*c); });
}

}  // namespace vc::cli
