// `voxcap calibrate solve|capture`: calibrating a rig from board views (host/calibrate).
//   solve   --images DIR [--board SPEC] -o rig.yaml [--report DIR] [--floor NAME] [--grid-min X Y Z
//           --voxel S --dims NX NY NZ]: detection, intrinsics, chained extrinsics, bundle adjustment, world
//           frame from the floor view; the rig calibration file, the report (text and PNG).
//   capture --config rig.toml --out DIR [--seconds S | --frames N] [--every K] [--board SPEC] [--floor]:
//           a real rig: the host side runs (hulls merge as in voxcap rig) and asks the edges for every
//           K-th frame's camera images (GRAB/FRAME, protocol 2.4); synchronized sets are recorded.
//   capture --emulated --out DIR: the virtual rig renders the board sequence (hw/sim).
//   Both keep the sets where the board is well seen by two or more cameras (and the floor view) in
//   solve's layout, with progress: views per camera, a coarse coverage grid per image, what is missing
//   (host/calibrate's CaptureRecorder, one place for both).
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "commands.hpp"
#include "voxcap/aggregator/aggregator.hpp"
#include "voxcap/calibrate/board.hpp"
#include "voxcap/calibrate/capture.hpp"
#include "voxcap/calibrate/folders.hpp"
#include "voxcap/calibrate/solve.hpp"
#include "voxcap/config/rig_config.hpp"
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
  std::string out, board = kDefaultBoard, size = "640x480", room = "default", calibration, config;
  int cameras = 6, poses = 80, min_corners = 6;
  double noise = 2.0;
  bool distortion = true;
  std::uint64_t seed = 1;
  bool quiet = false;
  // A real rig (--config).
  double seconds = 0;  // 0: until --frames sets were kept (or 60 s when neither is given)
  int frames = 0;      // kept sets to stop at; 0: --seconds
  int every = 15;      // GRAB every K-th frame
  bool floor = false;  // the board lies on the floor: keep one set, named "floor"
  bool rgb = false;    // rgb8 FRAMEs (default gray8: a third of the bytes, what detection uses)
  double wait_s = 30;  // for every node to be running
};

std::atomic<bool> g_capture_interrupted{false};
void on_capture_sigint(int) {
  g_capture_interrupted = true;
}

// One progress line per offered set, rewritten in place ("\r"), as both capture paths print it.
void progress(const calibrate::CaptureRecorder& rec, const std::string& what, bool kept) {
  std::string line = fmt::format("{}: {} {}", what, kept ? "kept" : "skipped", rec.views_line());
  std::fprintf(stderr, "\r%-100s", line.c_str());
}

void run_capture_emulated(const CaptureArgs& a, const calibrate::BoardSpec& board) {
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
  std::vector<calibrate::CaptureCamera> cams;
  for (const rig::Camera& c : scene.calibration().cameras) cams.push_back({c.name, c.width, c.height});
  calibrate::CaptureOptions co;
  co.min_corners = a.min_corners;
  calibrate::CaptureRecorder rec(a.out, cams, board, co);
  // The truth beside the capture (a file, so solve does not take it for a camera folder).
  rig::write_calibration((fs::path(a.out) / "truth_rig.yaml").string(), scene.calibration());

  std::vector<cv::Mat> rgb(static_cast<std::size_t>(n_cam));
  for (int f = 0; f < scene.frame_count(); ++f) {
    const bool floor = f == scene.floor_frame();
    for (int c = 0; c < n_cam; ++c) scene.render(f, c, rgb[static_cast<std::size_t>(c)]);
    const bool kept = rec.add(floor ? "floor" : fmt::format("{:04d}", f), rgb, floor);
    if (!a.quiet)
      progress(rec, fmt::format("frame {:3d}/{}{}", f + 1, scene.frame_count(), floor ? " (floor)" : ""),
               kept);
  }
  if (!a.quiet) std::fputc('\n', stderr);
  fmt::print("kept {} of {} frames in {}\n", rec.kept(), scene.frame_count(), a.out);
  fmt::print("{}", rec.summary());
}

// FRAMEs from the aggregator's thread, grouped into synchronized sets by seq. Bounded: at most
// kMaxPending sets wait for their other cameras; beyond that the oldest goes out as it is (the cameras
// whose images did not come are missing from it), so a node that stopped sending never grows memory.
class FrameSets {
 public:
  static constexpr std::size_t kMaxPending = 6;
  explicit FrameSets(std::vector<std::string> cameras) : cams_(std::move(cameras)) {}

  void push(aggregator::CameraFrame&& f) {  // the session thread: never waits for the consumer
    std::lock_guard<std::mutex> g(mu_);
    auto it = std::find(cams_.begin(), cams_.end(), f.camera);
    if (it == cams_.end()) return;
    const auto c = static_cast<std::size_t>(it - cams_.begin());
    Set& s = pending_[f.seq];
    if (s.images.empty()) s.images.resize(cams_.size());
    const int type = f.format == VC_FRAME_RGB8 ? CV_8UC3 : CV_8UC1;
    cv::Mat img(f.height, f.width, type);
    std::memcpy(img.data, f.pixels.data(), f.pixels.size());  // the decoder checked the size
    if (s.images[c].empty()) ++s.count;
    s.images[c] = std::move(img);
    if (s.count == cams_.size()) {
      ready_.push_back({f.seq, std::move(s.images)});
      pending_.erase(f.seq);
    }
    while (pending_.size() > kMaxPending) {  // the oldest incomplete set goes out as it is
      ++incomplete_;
      ready_.push_back({pending_.begin()->first, std::move(pending_.begin()->second.images)});
      pending_.erase(pending_.begin());
    }
    while (ready_.size() > 2 * kMaxPending) {  // the consumer (board detection) fell behind
      ready_.pop_front();
      ++dropped_;
    }
    cv_.notify_one();
  }
  // The next set (seq, images in camera order; empty Mat: missing), waiting up to timeout.
  bool pop(std::uint64_t* seq, std::vector<cv::Mat>* images, std::chrono::milliseconds timeout) {
    std::unique_lock<std::mutex> g(mu_);
    if (!cv_.wait_for(g, timeout, [&] { return !ready_.empty(); })) return false;
    *seq = ready_.front().first;
    *images = std::move(ready_.front().second);
    ready_.pop_front();
    return true;
  }
  std::uint64_t dropped() const {
    std::lock_guard<std::mutex> g(mu_);
    return dropped_;
  }
  std::uint64_t incomplete() const {
    std::lock_guard<std::mutex> g(mu_);
    return incomplete_;
  }

 private:
  struct Set {
    std::vector<cv::Mat> images;
    std::size_t count = 0;
  };
  std::vector<std::string> cams_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::map<std::uint64_t, Set> pending_;
  std::deque<std::pair<std::uint64_t, std::vector<cv::Mat>>> ready_;
  std::uint64_t dropped_ = 0, incomplete_ = 0;
};

// A real rig (rig.toml): the host's side runs as `voxcap rig` does (the edges are on their boards),
// asks every node for its cameras' images of every K-th frame (GRAB, protocol 2.4), and records the
// sets where the board is well seen while the hulls go on merging.
void run_capture_rig(const CaptureArgs& a, const calibrate::BoardSpec& board) {
  if (a.every < 1 || a.every > 65535) throw UsageError("calibrate capture: --every must be 1..65535");
  config::RigConfig rig;
  std::unique_ptr<aggregator::Aggregator> agg_ptr;
  aggregator::Options ao;
  ao.log_every_s = 0;
  // The host's warnings always, its info lines unless --quiet; a line of its own after the progress line.
  ao.log = [quiet = a.quiet](log::Level level, const std::string& line) {
    if (level < (quiet ? log::Level::warn : log::Level::info)) return;
    std::fprintf(stderr, "\nvoxcap-host: %s\n", line.c_str());
  };
  try {
    rig = config::load_rig_config(a.config);
    agg_ptr = std::make_unique<aggregator::Aggregator>(rig, ao);
  } catch (const config::ConfigError& e) {
    throw UsageError(e.what());
  }
  aggregator::Aggregator& agg = *agg_ptr;
  std::vector<calibrate::CaptureCamera> cams;
  std::vector<std::string> names;
  for (const config::NodeConfig& n : rig.nodes)
    for (const std::string& name : n.cameras) {
      const rig::Camera& c = rig.calibration.cameras.at(static_cast<std::size_t>(rig.camera_index(name)));
      cams.push_back({name, c.width, c.height});
      names.push_back(name);
    }
  calibrate::CaptureOptions co;
  co.min_corners = a.min_corners;
  calibrate::CaptureRecorder rec(a.out, cams, board, co);
  FrameSets sets(names);
  agg.set_frame_sink([&sets](aggregator::CameraFrame&& f) { sets.push(std::move(f)); });
  agg.start();
  const auto t0 = std::chrono::steady_clock::now();
  while (!g_capture_interrupted && !agg.all_running()) {
    if (std::chrono::steady_clock::now() - t0 > std::chrono::duration<double>(a.wait_s)) {
      std::string missing;
      for (const aggregator::NodeReport& n : agg.report().nodes)
        if (!n.connected || n.state != VC_STATE_RUNNING)
          missing +=
              fmt::format(" {} ({})", n.name, n.connected ? vc_node_state_name(n.state) : "not connected");
      agg.stop();
      throw std::runtime_error(
          fmt::format("calibrate capture: after {:.0f} s not every node is running:{}", a.wait_s, missing));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  agg.grab(static_cast<std::uint16_t>(a.every), a.rgb ? VC_FRAME_RGB8 : VC_FRAME_GRAY8);
  if (!a.quiet)
    std::fprintf(stderr, "every node is running: %s; move the board through the volume\n",
                 a.floor ? "lay the board on the floor" : "recording board views");
  const double seconds = a.seconds > 0 ? a.seconds : (a.frames > 0 || a.floor ? 1e12 : 60.0);
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  const int want = a.floor ? 1 : a.frames;
  while (!g_capture_interrupted && std::chrono::steady_clock::now() < end &&
         (want == 0 || rec.kept() < want)) {
    std::uint64_t seq = 0;
    std::vector<cv::Mat> images;
    if (!sets.pop(&seq, &images, std::chrono::milliseconds(100))) continue;
    const bool kept = rec.add(a.floor ? "floor" : fmt::format("{:08d}", seq), images, a.floor);
    if (!a.quiet)
      progress(rec, fmt::format("seq {} ({} cameras see the board)", seq, rec.last_seen().size()), kept);
  }
  agg.grab(0);
  agg.stop();
  if (!a.quiet) std::fputc('\n', stderr);
  const aggregator::Report r = agg.report();
  fmt::print("kept {} of {} sets in {} (hulls merged meanwhile: {} frames, {} complete)\n", rec.kept(),
             rec.offered(), a.out, r.frames, r.complete);
  for (const aggregator::NodeReport& n : r.nodes) {
    std::string refused;
    for (const auto& [why, count] : n.refused) refused += fmt::format(" {} {}", why, count);
    fmt::print("{}: {} images{}\n", n.name, n.frames, refused.empty() ? "" : ", refused:" + refused);
  }
  if (sets.incomplete() || sets.dropped())
    fmt::print("sets with missing cameras: {}, sets dropped (detection fell behind): {}\n", sets.incomplete(),
               sets.dropped());
  fmt::print("{}", rec.summary());
  if (rec.offered() == 0)
    throw std::runtime_error("calibrate capture: no images arrived from the rig (are its edges 2.4?)");
}

void run_capture(const CaptureArgs& a) {
  if (a.out.empty()) throw UsageError("calibrate capture: --out DIR is required");
  if (a.emulated == !a.config.empty())
    throw UsageError(
        "calibrate capture: give --emulated (the virtual rig) or --config rig.toml (a real rig)");
  const calibrate::BoardSpec board = board_arg(a.board, "calibrate capture");
  std::signal(SIGINT, on_capture_sigint);
  std::signal(SIGTERM, on_capture_sigint);
  if (a.emulated)
    run_capture_emulated(a, board);
  else
    run_capture_rig(a, board);
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
  CLI::App* capture = cal->add_subcommand(
      "capture",
      "Capture board views for solve, as DIR/<camera>/<frame>.png: sets where two or more cameras see the "
      "board well are kept, with progress (views per camera, a coverage grid per image, what is missing). "
      "--config rig.toml: a real rig; the host runs as voxcap rig does (hulls keep merging) and asks the "
      "edges for every K-th frame's images (GRAB, protocol 2.4) while a person moves the board; --floor "
      "records the board lying on the floor (the 'floor' set). --emulated: the virtual rig renders a "
      "ChArUco board held in varied poses and lying on the floor");
  capture->add_flag("--emulated", c->emulated, "Use the virtual rig (hw/sim)");
  capture->add_option("--config", c->config, "A real rig: its rig.toml (the edges must speak protocol 2.4)");
  capture
      ->add_option("--seconds", c->seconds, "Real rig: stop after this long (default 60 s unless --frames)")
      ->check(CLI::Range(0.0, 1e6));
  capture->add_option("--frames", c->frames, "Real rig: stop after this many kept sets")
      ->check(CLI::Range(0, 1000000));
  capture->add_option("--every", c->every, "Real rig: ask for every K-th frame's images")
      ->check(CLI::Range(1, 65535))
      ->capture_default_str();
  capture->add_flag("--floor", c->floor,
                    "Real rig: the board lies on the floor; keep one set where a camera sees it, as 'floor'");
  capture->add_flag("--rgb", c->rgb, "Real rig: colour images (rgb8) instead of gray8 (3x the bytes)");
  capture->add_option("--wait", c->wait_s, "Real rig: seconds to wait for every node to be running")
      ->check(CLI::Range(1.0, 3600.0))
      ->capture_default_str();
  capture
      ->add_option("--out", c->out,
                   "Output folder: <camera>/<frame>.png, <camera>/floor.png (emulated: and truth_rig.yaml)")
      ->required();
  capture->add_option("--board", c->board, "charuco:SXxSY:SQUARE_M:MARKER_M:DICT")->capture_default_str();
  capture->add_option("--poses", c->poses, "Emulated: board poses held in the volume (then one on the floor)")
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
  capture->add_flag("--quiet", c->quiet, "No per-frame progress (and only the host's warnings)");
  capture->callback([c] { run_capture(*c); });
}

}  // namespace vc::cli
