#include "voxcap/emulated/emulated_rig.hpp"

#include "voxcap/auth.h"
#include "voxcap/base/programs.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <fmt/core.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <fstream>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <toml++/toml.h>

#include "feature_scorer.hpp"
#include "voxcap/aggregator/record_stage.hpp"
#include "voxcap/config/options.hpp"
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
  if (!(bvh_scale >= 0 && bvh_scale <= 100)) return fail("bvh scale: must be in [0, 100] metres per unit");
  config::CarveRule rule{};
  if (!config::parse_carve_rule(carve, &rule))
    return fail("carve: subpixel, footprint or centre, got '" + carve + "'");
  if (silhouette_scale < 1 || silhouette_scale > 16) return fail("silhouette scale: must be in 1..16");
  {
    sim::SceneOptions so;
    so.appearance = appearance;
    so.room = room;
    std::string w;
    if (!so.valid(&w)) return fail(w);
  }
  return true;
}

sim::SceneOptions truth_scene_options(const Options& o, const rig::Calibration& cal) {
  sim::SceneOptions so;
  so.motion.source = o.motion;
  so.motion.fps = o.rate_hz;
  so.motion.bvh_scale = o.bvh_scale;
  so.seed = o.seed;
  so.noise_sigma = o.noise;
  so.appearance = o.appearance;
  so.room = o.room;
  so.calibration = cal;
  return so;
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

namespace {

// Running sums of one edge mask's figures; means when read.
struct SilhouetteSums {
  uint64_t frames = 0, missing = 0, bad = 0, recall_n = 0, precision_n = 0, shadow_n = 0;
  double recall = 0, precision = 0, shadow = 0;

  void add(const SilhouetteSums& o) {
    frames += o.frames;
    missing += o.missing;
    bad += o.bad;
    recall_n += o.recall_n;
    precision_n += o.precision_n;
    shadow_n += o.shadow_n;
    recall += o.recall;
    precision += o.precision;
    shadow += o.shadow;
  }
  SilhouetteScore mean() const {
    SilhouetteScore s;
    s.frames = frames;
    s.missing = missing;
    s.bad = bad;
    s.recall = recall_n ? recall / double(recall_n) : 0;
    s.precision = precision_n ? precision / double(precision_n) : 0;
    s.shadow_kept = shadow_n ? shadow / double(shadow_n) : 0;
    s.shadow_frames = shadow_n;
    return s;
  }
};

// The rule named (Options::valid() checked it), as the wire's value.
vc_carve_rule carve_rule(const std::string& name) {
  config::CarvingOptions c;
  config::parse_carve_rule(name, &c.rule);
  return static_cast<vc_carve_rule>(c.wire_value());
}

}  // namespace

// Scores merged frames against the simulator's truth: a consumer stage of the host's pipeline, on its
// own thread behind a drop-oldest queue (when it falls behind, frames are skipped from scoring —
// counted as the stage's drops — never from the rig). The frames whose seq is a multiple of
// truth_every are scored (the edges send their masks for exactly those); the simulator's frame of seq
// is seq − origin (the run's origin, START).
//
// Per scored frame: the true silhouettes and floor shadows of every camera (render_clean: the same
// geometry as the edges' noisy frames), the true-silhouette hull (the edges' carve rule, AND over the
// nodes), the part label of every voxel (Scene::occupancy_parts); then one pass over the voxels for
// agreement, IoU and per-part recall, a separable 3x3x3 dilation of the body over its bounding box
// for the hull's precision, and each edge mask (NodePart::silhouettes) against its camera's truth.
class TruthScorer : public pipeline::Stage {
 public:
  TruthScorer(const Options& opt, const rig::Calibration& cal, const rig::VoxelGrid& grid,
              const std::string& spec_cal)
      : opt_(opt), grid_(grid) {
    scene_ = std::make_unique<sim::Scene>(truth_scene_options(opt, rig::read_calibration(spec_cal)));
    const vc_voxel_grid g = rig::to_c_grid(grid);
    const vc_carve_rule rule = carve_rule(opt.carve);
    reference_carve_ = opt.carve;
    for (int k = 0; k < opt.nodes; k++) {
      vc_camera a = rig::to_c_camera(cal.cameras[2 * static_cast<size_t>(k)]);
      vc_camera b = rig::to_c_camera(cal.cameras[2 * static_cast<size_t>(k) + 1]);
      vc_carver* c = nullptr;
      char why[200];
      int rc = vc_carver_new(&g, &a, &b, rule, &c, why, sizeof why);
      if (rc < 0) throw std::runtime_error(std::string("truth: cannot build a carver for the rig: ") + why);
      carvers_.push_back(c);
    }
    voxels_ = static_cast<uint64_t>(grid.nx) * grid.ny * grid.nz;
    const size_t bytes = (voxels_ + 7) / 8;
    merged_.resize(bytes);
    truth_.resize(bytes);
    part_.resize(bytes);
    sil_.resize(2 * static_cast<size_t>(opt.nodes));
    shadow_.resize(2 * static_cast<size_t>(opt.nodes));
    cams_.resize(2 * static_cast<size_t>(opt.nodes));
    // Build the scene's per-camera render caches now (~0.3 s per camera at 640x480), not on the first
    // scored frame: that would hold the stage for a second while its queue fills.
    for (int c = 0; c < scene_->camera_count(); c++) scene_->render_background_clean(c, rgb_);
  }
  ~TruthScorer() override {
    for (auto* c : carvers_) vc_carver_free(c);
  }
  // The queue: a few frames to score deep, so that a scoring in progress does not push them out.
  static pipeline::QueueOptions queue(const Options& o) {
    return {static_cast<size_t>(8 * std::max(1, o.truth_every)), pipeline::Overflow::DropOldest};
  }
  std::string name() const override { return "score"; }
  void set_origin(uint64_t origin) {
    origin_ = origin;
    started_ = true;
  }
  void process(pipeline::Frame& f) override {
    const uint64_t origin = origin_;
    if (!started_ || opt_.truth_every <= 0 || f.seq < origin ||
        f.seq % static_cast<uint64_t>(opt_.truth_every) != 0)
      return;
    score(static_cast<int>(f.seq - origin), f);
  }
  Accuracy accuracy() const {
    std::lock_guard<std::mutex> g(mu_);
    Accuracy a = acc_;
    const double n = double(acc_.frames);
    if (n > 0) {
      a.agree = sum_agree_ / n;
      a.iou_silhouette_hull = sum_iou_ / n;
      a.body_recall = sum_recall_ / n;
    }
    a.hull_precision = a.hull_precision_frames ? sum_precision_ / double(a.hull_precision_frames) : 0;
    for (int p = 0; p < kPartGroups; p++)
      a.part_recall[static_cast<size_t>(p)] =
          a.part_frames[static_cast<size_t>(p)]
              ? sum_part_[static_cast<size_t>(p)] / double(a.part_frames[static_cast<size_t>(p)])
              : 0;
    a.reference_carve = reference_carve_;
    SilhouetteSums all;
    for (const SilhouetteSums& c : cams_) {
      a.cameras.push_back(c.mean());
      all.add(c);
    }
    a.silhouettes = all.mean();
    return a;
  }

 private:
  void score(int frame, const pipeline::Frame& f) {
    const size_t bytes = merged_.size();
    const int ncam = 2 * opt_.nodes;
    if (f.rle.empty() || vc_rle_decode(f.rle.data(), f.rle.size(), merged_.data(), voxels_) < 0)
      std::fill(merged_.begin(), merged_.end(), 0);  // no merged hull: nothing of the body is in it
    std::fill(truth_.begin(), truth_.end(), 0xFF);
    for (int c = 0; c < ncam; c++)
      scene_->render_clean(frame, c, rgb_, &sil_[static_cast<size_t>(c)], &shadow_[static_cast<size_t>(c)]);
    for (int k = 0; k < opt_.nodes; k++) {
      vc_carver_run(carvers_[static_cast<size_t>(k)], sil_[2 * static_cast<size_t>(k)].ptr<uint8_t>(),
                    sil_[2 * static_cast<size_t>(k) + 1].ptr<uint8_t>(), part_.data(), nullptr);
      for (size_t i = 0; i < bytes; i++) truth_[i] &= part_[i];
    }
    // Agreement and IoU with the true-silhouette hull, 64 voxels at a time (padding bits cleared in
    // both; the last word's tail is zero-filled).
    if (voxels_ % 8 != 0) {
      const auto keep = static_cast<uint8_t>((1u << (voxels_ % 8)) - 1);
      merged_[bytes - 1] &= keep;
      truth_[bytes - 1] &= keep;
    }
    uint64_t same = 0, inter = 0, uni = 0, hull_n = 0;
    for (size_t i = 0; i < bytes; i += 8) {
      uint64_t m = 0, t = 0;
      const size_t n = std::min<size_t>(8, bytes - i);
      std::memcpy(&m, merged_.data() + i, n);
      std::memcpy(&t, truth_.data() + i, n);
      same += static_cast<uint64_t>(64 - std::popcount(m ^ t));
      inter += static_cast<uint64_t>(std::popcount(m & t));
      uni += static_cast<uint64_t>(std::popcount(m | t));
      hull_n += static_cast<uint64_t>(std::popcount(m));
    }
    same -= ((bytes + 7) / 8) * 64 - voxels_;  // padding bits agree
    // Per part: one pass over the part labels, with the body's bounding box.
    scene_->occupancy_parts(grid_, frame, &label_);
    std::array<uint64_t, kPartGroups> n_part{}, in_part{};
    const int nx = grid_.nx, ny = grid_.ny, nz = grid_.nz;
    int lo[3] = {nx, ny, nz}, hi[3] = {-1, -1, -1};
    for (int k = 0; k < nz; k++) {
      for (int j = 0; j < ny; j++) {
        const size_t row = (static_cast<size_t>(k) * static_cast<size_t>(ny) + static_cast<size_t>(j)) *
                           static_cast<size_t>(nx);
        const uint8_t* lab = label_.data() + row;
        for (int i = 0; i < nx; i++) {
          if (lab[i] == sim::Scene::kNoPart) continue;
          const auto g = static_cast<size_t>(group_[lab[i]]);
          const size_t v = row + static_cast<size_t>(i);
          n_part[g]++;
          in_part[g] += (merged_[v / 8] >> (v % 8)) & 1u;
          lo[0] = std::min(lo[0], i), hi[0] = std::max(hi[0], i);
          lo[1] = std::min(lo[1], j), hi[1] = std::max(hi[1], j);
          lo[2] = std::min(lo[2], k), hi[2] = std::max(hi[2], k);
        }
      }
    }
    const uint64_t near = hull_near_body(lo, hi);
    std::vector<SilhouetteSums> cams(static_cast<size_t>(ncam));
    for (int c = 0; c < ncam; c++) score_mask(f, c, &cams[static_cast<size_t>(c)]);

    std::lock_guard<std::mutex> g(mu_);
    const double agree = double(same) / double(voxels_);
    acc_.frames++;
    sum_agree_ += agree;
    acc_.min_agree = std::min(acc_.min_agree, agree);
    sum_iou_ += uni ? double(inter) / double(uni) : 1.0;
    uint64_t body_n = 0, body_in = 0;
    for (size_t p = 0; p < kPartGroups; p++) {
      body_n += n_part[p];
      body_in += in_part[p];
      if (n_part[p] == 0) continue;
      acc_.part_frames[p]++;
      sum_part_[p] += double(in_part[p]) / double(n_part[p]);
    }
    sum_recall_ += body_n ? double(body_in) / double(body_n) : 1.0;
    if (hull_n > 0) {
      acc_.hull_precision_frames++;
      sum_precision_ += double(near) / double(hull_n);
    }
    for (size_t c = 0; c < cams.size(); c++) cams_[c].add(cams[c]);
  }

  // Merged-hull voxels within one voxel (26-neighbourhood) of a body voxel: the body (label_) dilated
  // by a 3x3x3 box, separably (x, then y, then z), over its bounding box lo..hi grown by one voxel.
  uint64_t hull_near_body(const int lo_in[3], const int hi_in[3]) {
    if (hi_in[0] < 0) return 0;
    const int n[3] = {grid_.nx, grid_.ny, grid_.nz};
    int lo[3], hi[3], d[3];
    for (int a = 0; a < 3; a++) {
      lo[a] = std::max(0, lo_in[a] - 1);
      hi[a] = std::min(n[a] - 1, hi_in[a] + 1);
      d[a] = hi[a] - lo[a] + 1;
    }
    const size_t box = static_cast<size_t>(d[0]) * static_cast<size_t>(d[1]) * static_cast<size_t>(d[2]);
    dil_a_.assign(box, 0);
    dil_b_.assign(box, 0);
    auto at = [&](int i, int j, int k) {
      return (static_cast<size_t>(k) * static_cast<size_t>(d[1]) + static_cast<size_t>(j)) *
                 static_cast<size_t>(d[0]) +
             static_cast<size_t>(i);
    };
    // x: a = body dilated along x.
    for (int k = 0; k < d[2]; k++) {
      for (int j = 0; j < d[1]; j++) {
        const uint8_t* lab = label_.data() + grid_.index(lo[0], lo[1] + j, lo[2] + k);
        uint8_t* out = &dil_a_[at(0, j, k)];
        for (int i = 0; i < d[0]; i++) {
          if (lab[i] == sim::Scene::kNoPart) continue;
          out[i] = 1;
          if (i > 0) out[i - 1] = 1;
          if (i + 1 < d[0]) out[i + 1] = 1;
        }
      }
    }
    // y: b = a dilated along y; z: a = b dilated along z.
    for (int k = 0; k < d[2]; k++) {
      for (int j = 0; j < d[1]; j++) {
        uint8_t* out = &dil_b_[at(0, j, k)];
        for (int dj = -1; dj <= 1; dj++) {
          if (j + dj < 0 || j + dj >= d[1]) continue;
          const uint8_t* in = &dil_a_[at(0, j + dj, k)];
          for (int i = 0; i < d[0]; i++) out[i] |= in[i];
        }
      }
    }
    std::fill(dil_a_.begin(), dil_a_.end(), 0);
    for (int k = 0; k < d[2]; k++) {
      for (int dk = -1; dk <= 1; dk++) {
        if (k + dk < 0 || k + dk >= d[2]) continue;
        const uint8_t* in = &dil_b_[at(0, 0, k + dk)];
        uint8_t* out = &dil_a_[at(0, 0, k)];
        const size_t plane = static_cast<size_t>(d[0]) * static_cast<size_t>(d[1]);
        for (size_t v = 0; v < plane; v++) out[v] |= in[v];
      }
    }
    uint64_t near = 0;
    for (int k = 0; k < d[2]; k++) {
      for (int j = 0; j < d[1]; j++) {
        const size_t row = grid_.index(lo[0], lo[1] + j, lo[2] + k);
        const uint8_t* dil = &dil_a_[at(0, j, k)];
        for (int i = 0; i < d[0]; i++) {
          const size_t v = row + static_cast<size_t>(i);
          near += dil[i] & ((merged_[v / 8] >> (v % 8)) & 1u);
        }
      }
    }
    return near;
  }

  // Rig camera c's mask from its node (node_id k = c / 2, its camera c % 2) against the truth.
  void score_mask(const pipeline::Frame& f, int c, SilhouetteSums* out) {
    const pipeline::NodePart* node = f.node(static_cast<uint16_t>(c / 2));
    const pipeline::Silhouette* s = nullptr;
    if (node)
      for (const pipeline::Silhouette& m : node->silhouettes)
        if (m.camera == c % 2) s = &m;
    if (!s) {
      out->missing++;
      return;
    }
    const cv::Mat& sil = sil_[static_cast<size_t>(c)];
    const cv::Mat& shadow = shadow_[static_cast<size_t>(c)];
    const int W = sil.cols, H = sil.rows, q = s->scale;
    if (q < 1 || q > 16 || s->width != (W + q - 1) / q || s->height != (H + q - 1) / q) {
      out->bad++;
      return;
    }
    const size_t nbits = static_cast<size_t>(s->width) * s->height;
    mask_.resize((nbits + 7) / 8);
    if (vc_rle_decode(s->rle.data(), s->rle.size(), mask_.data(), nbits) < 0) {
      out->bad++;
      return;
    }
    // A scaled pixel is body when any pixel of its block is (as the edge scales its mask), shadow
    // when any pixel of its block is shadow and none is body.
    uint64_t body = 0, fg = 0, hit = 0, shade = 0, kept = 0;
    for (int y = 0; y < s->height; y++) {
      for (int x = 0; x < s->width; x++) {
        bool b = false, sh = false;
        for (int yy = y * q; yy < std::min(H, (y + 1) * q); yy++) {
          const uint8_t* srow = sil.ptr<uint8_t>(yy);
          const uint8_t* hrow = shadow.ptr<uint8_t>(yy);
          for (int xx = x * q; xx < std::min(W, (x + 1) * q); xx++) {
            b = b || srow[xx] != 0;
            sh = sh || hrow[xx] != 0;
          }
        }
        sh = sh && !b;
        const size_t v = static_cast<size_t>(y) * s->width + static_cast<size_t>(x);
        const bool e = (mask_[v / 8] >> (v % 8)) & 1u;
        body += b;
        fg += e;
        hit += b && e;
        shade += sh;
        kept += sh && e;
      }
    }
    if (fg != s->foreground) {
      out->bad++;
      return;
    }
    out->frames++;
    if (body) {
      out->recall_n++;
      out->recall += double(hit) / double(body);
    }
    if (fg) {
      out->precision_n++;
      out->precision += double(hit) / double(fg);
    }
    if (shade) {
      out->shadow_n++;
      out->shadow += double(kept) / double(shade);
    }
  }

  const Options& opt_;
  rig::VoxelGrid grid_;
  std::unique_ptr<sim::Scene> scene_;
  std::vector<vc_carver*> carvers_;
  std::string reference_carve_;
  uint64_t voxels_ = 0;
  std::atomic<uint64_t> origin_{0};
  std::atomic<bool> started_{false};
  const std::array<int, sim::kPartCount> group_ = [] {
    std::array<int, sim::kPartCount> g{};
    for (int p = 0; p < sim::kPartCount; p++) g[static_cast<size_t>(p)] = part_group(p);
    return g;
  }();
  // Scratch, reused frame to frame.
  std::vector<uint8_t> merged_, truth_, part_, label_, dil_a_, dil_b_, mask_;
  std::vector<cv::Mat> sil_, shadow_;
  cv::Mat rgb_;
  mutable std::mutex mu_;  // everything below
  Accuracy acc_;
  double sum_agree_ = 0, sum_iou_ = 0, sum_recall_ = 0, sum_precision_ = 0;
  std::array<double, kPartGroups> sum_part_{};
  std::vector<SilhouetteSums> cams_;
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
  // The edges carve with the rig's rule and send their masks for the scored frames.
  config::parse_carve_rule(o.carve, &c.carving.rule);  // o.valid() checked the name
  c.silhouettes.every = o.truth_every;
  c.silhouettes.scale = o.silhouette_scale;
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
  if (!c.key_path.empty()) t.insert("key", c.key_path.string());
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
  t.insert("tracking", toml::table{{"nodes", std::string(config::to_string(c.tracking.nodes))}});
  t.insert("carving", toml::table{{"rule", std::string(config::to_string(c.carving.rule))}});
  t.insert("silhouettes", toml::table{{"every", c.silhouettes.every}, {"scale", c.silhouettes.scale}});
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
  t.insert("network", toml::table{{"listen", c.network.listen},
                                  {"port", static_cast<int64_t>(c.network.port)},
                                  {"heartbeat_interval_ms", c.network.heartbeat_interval_ms},
                                  {"heartbeat_timeout_ms", c.network.heartbeat_timeout_ms}});
  {
    std::ofstream f(path);
    f << "# Written by voxcap's emulated rig from its RigConfig (host/emulated).\n" << t << "\n";
    if (!f) throw std::runtime_error(fmt::format("cannot write {}", path.string()));
  }
  const config::RigConfig back = config::load_rig_config(path);
  bool same = back.nodes.size() == c.nodes.size() && back.trigger.udp.targets == c.trigger.udp.targets &&
              back.subtraction.t_upper == c.subtraction.t_upper && back.network.port == c.network.port &&
              back.network.heartbeat_interval_ms == c.network.heartbeat_interval_ms &&
              back.network.heartbeat_timeout_ms == c.network.heartbeat_timeout_ms &&
              back.grid.nx == c.grid.nx && back.assembly.deadline_ms == c.assembly.deadline_ms &&
              back.carving.rule == c.carving.rule && back.silhouettes.every == c.silhouettes.every &&
              back.silhouettes.scale == c.silhouettes.scale && back.tracking.nodes == c.tracking.nodes;
  for (size_t k = 0; same && k < c.nodes.size(); k++)
    same = back.nodes[k].id == c.nodes[k].id && back.nodes[k].number == c.nodes[k].number &&
           back.nodes[k].role == c.nodes[k].role && back.tracks(back.nodes[k]) == c.tracks(c.nodes[k]);
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
  fs::path key_path;  // the run's rig key (keyed rigs)
  std::string sim_spec;
  int host_port = 0;
  std::vector<int> trigger_ports;
  std::vector<pid_t> pids;
  std::unique_ptr<aggregator::Aggregator> agg;
  TruthScorer* scorer = nullptr;  // stages of agg's pipeline (owned there)
  FeatureScorer* feature_scorer = nullptr;
  PoseScorer* pose_scorer = nullptr;
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
    if (!key_path.empty()) {
      args.emplace_back("--key");
      args.push_back(key_path.string());
    }
    fs::create_directories(dir / fmt::format("node{}", k));
    std::vector<char*> argv;
    argv.reserve(args.size() + 1);
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    // fork + exec rather than posix_spawn: the child must ask for a parent-death signal between the
    // two, so that an edge never outlives its host (kill -9 of the host left every edge running, issue
    // #13). The signal races the fork (the host may die before prctl), hence the check of getppid()
    // against the host's pid. It is delivered when the *thread* that forked exits, so start() and
    // restart_node() must be called from a thread that lives as long as the rig (the main thread in
    // voxcap and the tests). Between fork and exec the child calls async-signal-safe functions only.
    std::string log = (dir / fmt::format("edge{}.log", k)).string();
    if (access(argv[0], X_OK) != 0)
      throw std::runtime_error(fmt::format("cannot start {}: {}", argv[0], std::strerror(errno)));
    int log_fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (log_fd < 0) throw std::runtime_error(fmt::format("cannot open {}: {}", log, std::strerror(errno)));
    const pid_t host = getpid();
    pid_t pid = fork();
    if (pid == 0) {
      if (prctl(PR_SET_PDEATHSIG, SIGTERM) != 0 || getppid() != host) _exit(127);
      if (dup2(log_fd, 1) < 0 || dup2(log_fd, 2) < 0) _exit(127);
      execve(argv[0], argv.data(), environ);
      _exit(127);
    }
    const int fork_errno = errno;
    ::close(log_fd);
    if (pid < 0)
      throw std::runtime_error(fmt::format("cannot start {}: {}", argv[0], std::strerror(fork_errno)));
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
  m.edge_bin = o.edge_binary.empty() ? vc::find_program("voxcap-edge") : fs::path(o.edge_binary);
  if (m.edge_bin.empty()) m.edge_bin = vc::program_candidates("voxcap-edge").front();
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
  if (o.keyed) {  // a fresh key per run, beside rig.toml
    m.key_path = fs::absolute(m.dir / "rig.key");
    char why[512];
    if (vc_auth_init() < 0 || vc_key_write(m.key_path.string().c_str(), true, nullptr, why, sizeof why) < 0)
      throw std::runtime_error(fmt::format("emulated rig: cannot make its key: {}", why));
    rig.key_path = m.key_path;
  }
  write_rig_toml(rig, rig.source);  // for the workdir and the session recording's copy

  // What the edges' sim cameras render: the scorer's scene, to the last option.
  m.sim_spec = fmt::format("motion={},fps={},seed={},noise={},appearance={},room={},calibration={}", o.motion,
                           o.rate_hz, o.seed, o.noise, o.appearance, o.room, cal_path.string());
  if (o.bvh_scale > 0) m.sim_spec += fmt::format(",bvh_scale={}", o.bvh_scale);
  aggregator::Options ao;
  if (o.host_log)
    ao.log = o.host_log;
  else if (o.quiet)
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
  if (o.truth_every > 0 && rig.features.enabled && rig.triangulation.enabled)
    m.feature_scorer = &m.agg->pipeline().tap(
        std::make_unique<FeatureScorer>(o, cal_path.string(), rig.triangulation.confident),
        FeatureScorer::queue());
  if (o.score_poses) {
    m.pose_scorer = &m.agg->pipeline().tap(
        std::make_unique<PoseScorer>(std::make_unique<sim::Scene>(truth_scene_options(o, cal)), grid,
                                     o.keep_poses),
        PoseScorer::kQueue);
  }
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
  if (m.feature_scorer) m.feature_scorer->set_origin(m.agg->report().origin);
  if (m.pose_scorer) m.pose_scorer->set_origin(m.agg->report().origin);
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
  // What merged until here (the frames pending at r.report, those while the edges stopped) is what
  // the session holds.
  r.final_report = m.agg->report();
  r.stages = r.final_report.pipeline;
  if (m.scorer) r.accuracy = m.scorer->accuracy();
  if (m.feature_scorer) r.accuracy.features = m.feature_scorer->figures();
  if (m.pose_scorer) r.poses = m.pose_scorer->accuracy();
  r.origin = r.report.origin;
  r.host_rss_start_kb = m.rss_start;
  r.host_rss_end_kb = rss_kb();
  r.workdir = m.dir;
  if (m.recorder) r.session_dir = m.recorder->dir();
  return r;
}

}  // namespace vc::emulated
