#include "voxcap/emulated/emulated_rig.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <fmt/core.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <fstream>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <toml++/toml.h>

#include "voxcap/aggregator/record_stage.hpp"
#include "voxcap/edge/carver.h"
#include "voxcap/rig/c_models.hpp"
#include "voxcap/rig/calibration.hpp"
#include "voxcap/rle.h"
#include "voxcap/sim/rig_layout.hpp"
#include "voxcap/sim/scene.hpp"

namespace vc::emulated {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

bool Options::valid(std::string* why) const {
  auto fail = [&](std::string m) {
    if (why) *why = std::move(m);
    return false;
  };
  if (nodes < 1 || nodes > 16) return fail(fmt::format("nodes: must be in 1..16, got {}", nodes));
  if (width < 32 || height < 32 || width > 4096 || height > 4096)
    return fail("size: must be 32..4096 per side");
  if (rate_hz <= 0 || rate_hz > 240) return fail("rate: must be in (0, 240] Hz");
  if (grid < 8 || grid > 512) return fail("grid: must be in 8..512 voxels per axis");
  if (missing_policy != "drop" && missing_policy != "degraded")
    return fail("missing policy: drop or degraded");
  if (deadline_ms <= 0) return fail("deadline: must be > 0");
  if (truth_every < 0) return fail("truth_every: must be >= 0");
  if (motion.empty()) return fail("motion: must be set");
  return true;
}

static long status_kb(const char* key) {
  std::ifstream f("/proc/self/status");
  std::string line;
  size_t n = std::strlen(key);
  while (std::getline(f, line))
    if (line.compare(0, n, key) == 0) return std::stol(line.substr(n + 1));
  return 0;
}
long rss_kb() {
  return status_kb("VmRSS");
}
long peak_rss_kb() {
  return status_kb("VmHWM");
}

static int free_port(int type) {
  int fd = socket(AF_INET, type, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) < 0) {
    close(fd);
    throw std::runtime_error("cannot find a free port on 127.0.0.1");
  }
  socklen_t len = sizeof(a);
  getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  close(fd);
  return ntohs(a.sin_port);
}

// Scores merged frames against the simulator's truth: a consumer stage of the host's pipeline, on its
// own thread behind a drop-oldest queue (when it falls behind, frames are skipped from scoring —
// counted as the stage's drops — never from the rig). Every truth_every-th frame of the run is scored.
class TruthScorer : public pipeline::Stage {
 public:
  TruthScorer(const Options& opt, const rig::Calibration& cal, const rig::VoxelGrid& grid,
              const std::string& spec_cal)
      : opt_(opt), grid_(grid) {
    sim::SceneOptions so;
    so.motion.source = opt.motion;
    so.motion.fps = opt.rate_hz;
    so.seed = opt.seed;
    so.noise_sigma = opt.noise;
    so.calibration = rig::read_calibration(spec_cal);
    scene_ = std::make_unique<sim::Scene>(so);
    const vc_voxel_grid g = rig::to_c_grid(grid);
    for (int k = 0; k < opt.nodes; k++) {
      vc_camera a = rig::to_c_camera(cal.cameras[2 * static_cast<size_t>(k)]);
      vc_camera b = rig::to_c_camera(cal.cameras[2 * static_cast<size_t>(k) + 1]);
      vc_carver* c = nullptr;
      char why[200];
      if (vc_carver_new(&g, &a, &b, VC_CARVE_CENTRE, &c, why, sizeof why) < 0)
        throw std::runtime_error(std::string("truth: cannot build a carver for the rig: ") + why);
      carvers_.push_back(c);
    }
    voxels_ = static_cast<uint64_t>(grid.nx) * grid.ny * grid.nz;
    const size_t bytes = (voxels_ + 7) / 8;
    merged_.resize(bytes);
    truth_.resize(bytes);
    part_.resize(bytes);
    sil_.resize(2);
  }
  ~TruthScorer() override {
    for (auto* c : carvers_) vc_carver_free(c);
  }
  // The queue: a few frames to score deep, so that a scoring in progress does not push them out.
  static pipeline::QueueOptions queue(const Options& o) {
    return {static_cast<size_t>(8 * std::max(1, o.truth_every)), pipeline::Overflow::DropOldest};
  }
  std::string name() const override { return "score"; }
  void set_origin(uint64_t origin) { origin_ = origin; }
  void process(pipeline::Frame& f) override {
    const uint64_t origin = origin_;
    if (opt_.truth_every <= 0 || f.seq < origin ||
        (f.seq - origin) % static_cast<uint64_t>(opt_.truth_every) != 0)
      return;
    score(static_cast<int>(f.seq - origin), f.rle);
  }
  Accuracy accuracy() const {
    std::lock_guard<std::mutex> g(mu_);
    return acc_;
  }

 private:
  void score(int frame, const std::vector<uint8_t>& rle) {
    std::vector<uint8_t>&merged = merged_, &truth = truth_, &part = part_, &body = body_;
    std::vector<cv::Mat>& sil = sil_;
    cv::Mat& rgb = rgb_;
    const size_t bytes = merged.size();
    {
      vc_rle_decode(rle.data(), rle.size(), merged.data(), voxels_);
      std::fill(truth.begin(), truth.end(), 0xFF);
      for (int k = 0; k < opt_.nodes; k++) {
        for (int c = 0; c < 2; c++) scene_->render_clean(frame, 2 * k + c, rgb, &sil[static_cast<size_t>(c)]);
        vc_carver_run(carvers_[static_cast<size_t>(k)], sil[0].ptr<uint8_t>(), sil[1].ptr<uint8_t>(),
                      part.data(), nullptr);
        for (size_t i = 0; i < bytes; i++) truth[i] &= part[i];
      }
      scene_->occupancy(grid_, frame, &body);
      uint64_t same = 0, inter = 0, uni = 0, body_n = 0, body_in = 0;
      for (uint64_t v = 0; v < voxels_; v++) {
        bool m = (merged[v / 8] >> (v % 8)) & 1, t = (truth[v / 8] >> (v % 8)) & 1;
        bool b = (body[v / 8] >> (v % 8)) & 1;
        same += m == t;
        inter += m && t;
        uni += m || t;
        body_n += b;
        body_in += b && m;
      }
      std::lock_guard<std::mutex> g(mu_);
      double agree = double(same) / double(voxels_);
      double n = double(acc_.frames);
      acc_.agree = (acc_.agree * n + agree) / (n + 1);
      acc_.min_agree = std::min(acc_.min_agree, agree);
      double iou = uni ? double(inter) / double(uni) : 1.0;
      acc_.iou_silhouette_hull = (acc_.iou_silhouette_hull * n + iou) / (n + 1);
      double rec = body_n ? double(body_in) / double(body_n) : 1.0;
      acc_.body_recall = (acc_.body_recall * n + rec) / (n + 1);
      acc_.frames++;
    }
  }

  const Options& opt_;
  rig::VoxelGrid grid_;
  std::unique_ptr<sim::Scene> scene_;
  std::vector<vc_carver*> carvers_;
  uint64_t voxels_ = 0;
  std::atomic<uint64_t> origin_{0};
  std::vector<uint8_t> merged_, truth_, part_, body_;  // scratch, reused frame to frame
  std::vector<cv::Mat> sil_;
  cv::Mat rgb_;
  mutable std::mutex mu_;  // acc_
  Accuracy acc_;
};

namespace {

// The emulated rig's configuration, built in code: the option structs' defaults except what an
// emulated rig is — its nodes (node0 the front one) and grid, the udp trigger to each edge's port, the
// host on loopback, and the simulator's subtraction settings.
config::RigConfig rig_config(const Options& o, const rig::Calibration& cal, const fs::path& cal_path,
                             const fs::path& toml_path, const std::vector<int>& trigger_ports,
                             int host_port) {
  config::RigConfig c;
  c.source = toml_path;
  c.name = "emulated";
  c.calibration_path = cal_path;
  // As the edges' sim cameras read it: the file, so that host and edges agree to the last digit.
  c.calibration = rig::read_calibration(cal_path.string());
  c.grid = *cal.grid;  // set by the caller
  c.grid_source = config::GridSource::Config;
  for (int k = 0; k < o.nodes; k++) {
    config::NodeConfig n;
    n.id = fmt::format("node{}", k);
    n.number = static_cast<uint16_t>(k);
    n.address = "127.0.0.1";
    n.cameras = {fmt::format("cam{}", 2 * k), fmt::format("cam{}", 2 * k + 1)};
    n.role = k == 0 ? config::NodeRole::Front : config::NodeRole::Side;
    c.nodes.push_back(std::move(n));
  }
  // The simulator's floor shadow darkens by up to ~40 % (~90 levels) while its sensor noise is ~2
  // levels: T_u * sigma must exceed the shadow's depth so shadows reach the colour test (eq. 2), and the
  // noise of a darkened pixel tilts its colour by a few degrees. The edge's sim-truth tests use these.
  c.subtraction.t_upper = 60.0;
  c.subtraction.t_lower = 3.5;
  c.subtraction.shadow_angle_deg = 8.0;
  c.subtraction.cleanup_radius_px = 1;
  c.subtraction.background_frames = 20;
  c.trigger.backend = config::TriggerBackend::Udp;
  c.trigger.rate_hz = o.rate_hz;
  c.trigger.rt_priority = 0;
  for (int port : trigger_ports) c.trigger.udp.targets.push_back({"127.0.0.1", static_cast<uint16_t>(port)});
  c.assembly.deadline_ms = o.deadline_ms;
  c.assembly.missing_node_policy =
      o.missing_policy == "drop" ? config::MissingNodePolicy::Drop : config::MissingNodePolicy::Degraded;
  c.network.listen = "127.0.0.1";
  c.network.port = static_cast<uint16_t>(host_port);
  std::string why;
  if (!c.valid(&why)) throw std::logic_error("emulated rig: its configuration is invalid: " + why);
  return c;
}

// rig.toml of a RigConfig, for the workdir and the session recording (which keeps a copy of the file
// the rig ran from): the keys an emulated rig sets, written with toml++ and read back with the one
// loader, which must give the same rig.
void write_rig_toml(const config::RigConfig& c, const fs::path& path) {
  toml::table t;
  t.insert("version", 1);
  t.insert("name", c.name);
  t.insert("calibration", c.calibration_path.string());
  t.insert("grid", toml::table{{"min_m", toml::array{c.grid.min_m[0], c.grid.min_m[1], c.grid.min_m[2]}},
                               {"voxel_m", c.grid.voxel_m},
                               {"nx", c.grid.nx},
                               {"ny", c.grid.ny},
                               {"nz", c.grid.nz}});
  toml::array nodes;
  for (const config::NodeConfig& n : c.nodes) {
    toml::array cams;
    for (const std::string& cam : n.cameras) cams.push_back(cam);
    nodes.push_back(toml::table{{"id", n.id},
                                {"address", n.address},
                                {"cameras", cams},
                                {"role", std::string(config::to_string(n.role))}});
  }
  t.insert("nodes", nodes);
  t.insert("subtraction", toml::table{{"t_upper", c.subtraction.t_upper},
                                      {"t_lower", c.subtraction.t_lower},
                                      {"shadow_angle_deg", c.subtraction.shadow_angle_deg},
                                      {"cleanup_radius_px", c.subtraction.cleanup_radius_px},
                                      {"background_frames", c.subtraction.background_frames}});
  t.insert("features", toml::table{{"enabled", c.features.enabled}});
  toml::array targets;
  for (const config::Endpoint& e : c.trigger.udp.targets) targets.push_back(e.str());
  t.insert("trigger", toml::table{{"backend", std::string(config::to_string(c.trigger.backend))},
                                  {"rate_hz", c.trigger.rate_hz},
                                  {"pulse_width_us", c.trigger.pulse_width_us},
                                  {"rt_priority", c.trigger.rt_priority},
                                  {"late_threshold_us", c.trigger.late_threshold_us},
                                  {"udp", toml::table{{"targets", targets}}}});
  t.insert("assembly", toml::table{{"deadline_ms", c.assembly.deadline_ms},
                                   {"missing_node_policy",
                                    std::string(config::to_string(c.assembly.missing_node_policy))}});
  t.insert("network",
           toml::table{{"listen", c.network.listen}, {"port", static_cast<int64_t>(c.network.port)}});
  {
    std::ofstream f(path);
    f << "# Written by voxcap's emulated rig from its RigConfig (host/emulated).\n" << t << "\n";
    if (!f) throw std::runtime_error(fmt::format("cannot write {}", path.string()));
  }
  const config::RigConfig back = config::load_rig_config(path);
  bool same = back.nodes.size() == c.nodes.size() && back.trigger.udp.targets == c.trigger.udp.targets &&
              back.subtraction.t_upper == c.subtraction.t_upper && back.network.port == c.network.port &&
              back.grid.nx == c.grid.nx && back.assembly.deadline_ms == c.assembly.deadline_ms;
  for (size_t k = 0; same && k < c.nodes.size(); k++)
    same = back.nodes[k].id == c.nodes[k].id && back.nodes[k].number == c.nodes[k].number &&
           back.nodes[k].role == c.nodes[k].role;
  if (!same)
    throw std::logic_error(
        fmt::format("emulated rig: {} does not read back as the rig it was written from", path.string()));
}

}  // namespace

struct EmulatedRig::Impl {
  Options opt;
  fs::path dir;
  bool own_dir = false;
  fs::path edge_bin;
  std::string sim_spec;
  int host_port = 0;
  std::vector<int> trigger_ports;
  std::vector<pid_t> pids;
  std::unique_ptr<aggregator::Aggregator> agg;
  TruthScorer* scorer = nullptr;  // stages of agg's pipeline (owned there)
  aggregator::RecordStage* recorder = nullptr;
  Clock::time_point t_start;
  long rss_start = 0;
  bool stopped = false;

  void spawn(int k) {
    std::vector<std::string> args = {edge_bin.string(),
                                     "--node-id",
                                     std::to_string(k),
                                     "--host",
                                     "127.0.0.1",
                                     "--port",
                                     std::to_string(host_port),
                                     "--trigger",
                                     "udp",
                                     "--trigger-port",
                                     std::to_string(trigger_ports[static_cast<size_t>(k)]),
                                     "--camera0",
                                     "sim:" + sim_spec,
                                     "--camera1",
                                     "sim:" + sim_spec,
                                     "--size",
                                     fmt::format("{}x{}", opt.width, opt.height),
                                     "--verbosity",
                                     opt.quiet ? "0" : "1",
                                     "--state-dir",
                                     (dir / fmt::format("node{}", k)).string()};
    fs::create_directories(dir / fmt::format("node{}", k));
    std::vector<char*> argv;
    argv.reserve(args.size() + 1);
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    std::string log = (dir / fmt::format("edge{}.log", k)).string();
    posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    pid_t pid = 0;
    int rc = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) throw std::runtime_error(fmt::format("cannot start {}: {}", argv[0], std::strerror(rc)));
    pids[static_cast<size_t>(k)] = pid;
  }

  std::string edge_log_tail(int k) const {
    std::ifstream f(dir / fmt::format("edge{}.log", k));
    std::deque<std::string> lines;
    std::string l;
    while (std::getline(f, l)) {
      lines.push_back(l);
      if (lines.size() > 5) lines.pop_front();
    }
    std::string out;
    for (auto& s : lines) out += "\n  edge" + std::to_string(k) + ": " + s;
    return out;
  }

  void reap(int k, int sig, double grace_s) {
    pid_t pid = pids[static_cast<size_t>(k)];
    if (pid <= 0) return;
    kill(pid, sig);
    auto end = Clock::now() + std::chrono::duration<double>(grace_s);
    int st = 0;
    while (waitpid(pid, &st, WNOHANG) == 0) {
      if (Clock::now() > end) {
        kill(pid, SIGKILL);
        waitpid(pid, &st, 0);
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    pids[static_cast<size_t>(k)] = 0;
  }
};

EmulatedRig::EmulatedRig(Options options) : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!options.valid(&why)) throw std::invalid_argument("emulated rig: " + why);
  impl_->opt = std::move(options);
}

EmulatedRig::~EmulatedRig() {
  if (!impl_->stopped) {
    try {
      stop();
    } catch (...) {
    }
  }
  if (impl_->own_dir) {
    std::error_code ec;
    fs::remove_all(impl_->dir, ec);
  }
}

void EmulatedRig::start(double timeout_s) {
  Impl& m = *impl_;
  const Options& o = m.opt;
  m.rss_start = rss_kb();
  if (o.workdir.empty()) {
    char t[] = "/tmp/voxcap-rig-XXXXXX";
    if (!mkdtemp(t)) throw std::runtime_error("cannot create a temporary folder");
    m.dir = t;
    m.own_dir = true;
  } else {
    m.dir = o.workdir;
    fs::create_directories(m.dir);
  }
  m.edge_bin = o.edge_binary.empty() ? fs::read_symlink("/proc/self/exe").parent_path() / "voxcap-edge"
                                     : o.edge_binary;
  if (!fs::exists(m.edge_bin))
    throw std::runtime_error(
        fmt::format("edge binary {} not found (build the voxcap-edge target)", m.edge_bin.string()));

  // The virtual rig: the simulator's ring of 2 cameras per node, and a grid over the volume.
  sim::RigLayout layout;
  layout.cameras = 2 * o.nodes;
  layout.width = o.width;
  layout.height = o.height;
  rig::Calibration cal = sim::default_rig(layout);
  rig::VoxelGrid grid;
  grid.min_m = cv::Vec3d(-1.12, -1.12, 0.0);
  grid.voxel_m = 2.24 / o.grid;
  grid.nx = grid.ny = grid.nz = o.grid;
  cal.grid = grid;
  fs::path cal_path = fs::absolute(m.dir / "rig.yaml");
  rig::write_calibration(cal_path.string(), cal);

  m.host_port = free_port(SOCK_STREAM);
  m.trigger_ports.clear();
  for (int k = 0; k < o.nodes; k++) m.trigger_ports.push_back(free_port(SOCK_DGRAM));
  config::RigConfig rig = rig_config(o, cal, cal_path, m.dir / "rig.toml", m.trigger_ports, m.host_port);
  write_rig_toml(rig, rig.source);  // for the workdir and the session recording's copy

  m.sim_spec = fmt::format("motion={},fps={},seed={},noise={},calibration={}", o.motion, o.rate_hz, o.seed,
                           o.noise, cal_path.string());
  aggregator::Options ao;
  if (o.quiet)
    ao.log = [out = log::to_spdlog("voxcap-host")](log::Level level, const std::string& line) {
      if (level >= log::Level::err) out(level, line);
    };
  m.agg = std::make_unique<aggregator::Aggregator>(rig, ao);
  // The host's pipeline: assemble -> merge -> the recording (every frame) and the scorer (live).
  if (!o.record_dir.empty())
    m.recorder = &m.agg->pipeline().tap(std::make_unique<aggregator::RecordStage>(o.record_dir),
                                        aggregator::RecordStage::kQueue);
  if (o.truth_every > 0)
    m.scorer = &m.agg->pipeline().tap(std::make_unique<TruthScorer>(o, cal, grid, cal_path.string()),
                                      TruthScorer::queue(o));
  if (o.stages) o.stages(m.agg->pipeline());
  m.agg->start();
  m.pids.assign(static_cast<size_t>(o.nodes), 0);
  for (int k = 0; k < o.nodes; k++) m.spawn(k);
  auto end = Clock::now() + std::chrono::duration<double>(timeout_s);
  while (!m.agg->all_running()) {
    for (int k = 0; k < o.nodes; k++) {
      int st = 0;
      if (m.pids[static_cast<size_t>(k)] > 0 && waitpid(m.pids[static_cast<size_t>(k)], &st, WNOHANG) > 0) {
        m.pids[static_cast<size_t>(k)] = 0;
        throw std::runtime_error(fmt::format("edge {} exited during start-up:{}", k, m.edge_log_tail(k)));
      }
    }
    if (Clock::now() > end) {
      std::string logs;
      for (int k = 0; k < o.nodes; k++) logs += m.edge_log_tail(k);
      throw std::runtime_error(fmt::format("the rig did not start within {} s:{}", timeout_s, logs));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (m.scorer) m.scorer->set_origin(m.agg->report().origin);
  m.t_start = Clock::now();
}

uint64_t EmulatedRig::merged_frames() const {
  return impl_->agg ? impl_->agg->merged_frames() : 0;
}
aggregator::Report EmulatedRig::report() const {
  return impl_->agg->report();
}
uint16_t EmulatedRig::host_port() const {
  return static_cast<uint16_t>(impl_->host_port);
}
const fs::path& EmulatedRig::workdir() const {
  return impl_->dir;
}

void EmulatedRig::run_frames(uint64_t frames, double timeout_s) {
  auto end = Clock::now() + std::chrono::duration<double>(timeout_s);
  while (merged_frames() < frames && Clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
}

void EmulatedRig::run_seconds(double seconds) {
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
}

void EmulatedRig::kill_node(int k, int sig) {
  impl_->reap(k, sig, 2.0);
}

void EmulatedRig::signal_node(int k, int sig) {
  pid_t pid = impl_->pids.at(static_cast<size_t>(k));
  if (pid > 0) kill(pid, sig);
}

void EmulatedRig::restart_node(int k) {
  if (impl_->pids.at(static_cast<size_t>(k)) > 0) impl_->reap(k, SIGTERM, 2.0);
  impl_->spawn(k);
}

bool EmulatedRig::node_running(int k) const {
  for (const auto& n : impl_->agg->report().nodes)
    if (n.name == fmt::format("node{}", k)) return n.connected && n.state == VC_STATE_RUNNING;
  return false;
}

Result EmulatedRig::stop() {
  Impl& m = *impl_;
  Result r;
  if (m.stopped || !m.agg) return r;
  m.stopped = true;
  r.wall_seconds = std::chrono::duration<double>(Clock::now() - m.t_start).count();
  r.report = m.agg->report();
  for (int k = 0; k < static_cast<int>(m.pids.size()); k++) m.reap(k, SIGTERM, 3.0);
  m.agg->stop();  // every stage drains its queue; the recording is closed cleanly
  r.stages = m.agg->report().pipeline;
  if (m.scorer) r.accuracy = m.scorer->accuracy();
  r.host_rss_start_kb = m.rss_start;
  r.host_rss_end_kb = rss_kb();
  r.workdir = m.dir;
  if (m.recorder) r.session_dir = m.recorder->dir();
  return r;
}

}  // namespace vc::emulated
