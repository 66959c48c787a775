#include "voxcap/aggregator/aggregator.hpp"

#include "voxcap/auth.h"
#include "voxcap/base/clock.hpp"

#include <arpa/inet.h>
#include <fmt/core.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "voxcap/assemble/merge_stage.hpp"
#include "voxcap/crc32c.h"
#include "voxcap/fit/fitter.hpp"
#include "voxcap/rig/c_models.hpp"
#include "voxcap/triangulate/triangulate_stage.hpp"

namespace vc::aggregator {

std::vector<std::string> resolve_ipv4(const std::string& address) {
  std::vector<std::string> out;
  if (address.empty() || address == "any") return out;
  in_addr a{};
  if (inet_pton(AF_INET, address.c_str(), &a) == 1) return {address};
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* res = nullptr;
  if (getaddrinfo(address.c_str(), nullptr, &hints, &res) != 0) return out;
  for (addrinfo* r = res; r; r = r->ai_next) {
    char ip[INET_ADDRSTRLEN] = "";
    const auto* sin = reinterpret_cast<const sockaddr_in*>(r->ai_addr);
    if (inet_ntop(AF_INET, &sin->sin_addr, ip, sizeof ip) &&
        std::find(out.begin(), out.end(), ip) == out.end())
      out.emplace_back(ip);
  }
  freeaddrinfo(res);
  return out;
}

std::vector<uint8_t> load_rig_key(const config::RigConfig& rig) {
  if (rig.key_path.empty()) return {};
  if (vc_auth_init() < 0) throw std::runtime_error("libsodium failed to start");
  std::vector<uint8_t> key(VC_AUTH_KEY_SIZE);
  char why[512] = "";
  if (vc_key_load(rig.key_path.string().c_str(), key.data(), why, sizeof why) < 0)
    throw config::ConfigError(rig.source.string(), "key", why[0] ? why : "cannot read the key file");
  return key;
}

uint32_t grid_id(const rig::VoxelGrid& g) {
  double d[4] = {g.min_m[0], g.min_m[1], g.min_m[2], g.voxel_m};
  int32_t n[3] = {g.nx, g.ny, g.nz};
  uint32_t crc = vc_crc32c(0, d, sizeof(d));
  return vc_crc32c(crc, n, sizeof(n));
}

vc_config make_config_message(const config::RigConfig& rig, const config::NodeConfig& node, uint32_t gid,
                              uint8_t node_minor) {
  vc_config c{};
  c.grid_id = gid;
  c.grid = rig::to_c_grid(rig.grid);
  c.t_upper = static_cast<float>(rig.subtraction.t_upper);
  c.t_lower = static_cast<float>(rig.subtraction.t_lower);
  c.shadow_angle_deg = static_cast<float>(rig.subtraction.shadow_angle_deg);
  c.cleanup_radius_px = static_cast<uint32_t>(rig.subtraction.cleanup_radius_px);  // what the edge runs
  c.background_frames = static_cast<uint32_t>(rig.subtraction.background_frames);
  if (node_minor >= 1) {  // 2.1: these bytes were 2.0's `reserved`, which a 2.0 node wants 0
    c.carve_rule = rig.carving.wire_value();
    // 2.2 added subpixel; a 2.1 node gets footprint, whose hull holds the subpixel one (SPEC "Evolution")
    if (node_minor < 2 && c.carve_rule == VC_CARVE_SUBPIXEL) c.carve_rule = VC_CARVE_FOOTPRINT;
    c.silhouette_every = static_cast<uint8_t>(rig.silhouettes.every);
    c.silhouette_scale = static_cast<uint8_t>(rig.silhouettes.scale);
  }
  c.feature_role = rig.tracks(node) ? VC_ROLE_FRONT : VC_ROLE_NONE;  // FRONT (1) on the wire: "track"
  c.camera_count = static_cast<uint16_t>(node.cameras.size());
  for (size_t k = 0; k < node.cameras.size() && k < VC_PROTO_MAX_CAMERAS; k++) {
    int idx = rig.camera_index(node.cameras[k]);
    c.cameras[k] = rig::to_c_camera(rig.calibration.cameras.at(static_cast<size_t>(idx)));
  }
  return c;
}

void Latency::add(uint64_t v) {
  n++;
  sum += double(v);
  max = std::max(max, v);
  if (samples.size() < kReservoir) {
    samples.reserve(kReservoir);  // allocated once, at the first sample
    samples.push_back(v);
    return;
  }
  // Reservoir sampling (Vitter's algorithm R): every value seen so far is in the sample with the same
  // probability kReservoir / n. The generator is a fixed-seed xorshift: runs are repeatable.
  rng ^= rng << 13;
  rng ^= rng >> 7;
  rng ^= rng << 17;
  const uint64_t j = rng % n;
  if (j < kReservoir) samples[j] = v;
}

double Latency::percentile_ms(double p) const {
  if (samples.empty()) return 0;
  std::vector<uint64_t> s = samples;
  size_t k = static_cast<size_t>(std::clamp(p, 0.0, 1.0) * double(s.size() - 1) + 0.5);
  std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(k), s.end());
  return double(s[k]) / 1e6;
}

struct Aggregator::Node {
  uint16_t id = 0;
  const config::NodeConfig* cfg = nullptr;
  // CONFIG for a node of protocol minor version m (2.m), m = 0..VC_PROTO_VERSION_MINOR; a newer node
  // gets this version's: 2.0 centre carving, no SILHOUETTE; 2.1 footprint for subpixel carving.
  std::array<std::vector<uint8_t>, VC_PROTO_VERSION_MINOR + 1> config_msg;
  session::ConnId conn = 0;
  bool connected = false;
  uint32_t state = VC_STATE_IDLE;
  bool background_sent = false, start_sent = false;
  uint8_t minor = 0;        // the protocol minor version of its HELLO
  bool grab_sent = false;   // the GRAB in force was sent to it in its current run
  vc_grab grabbed{};        // what it was last asked (every 0: nothing): FRAMEs are checked against it
  bool assembling = false;  // what the assembly stage was last told (set_running)
  std::string peer;         // where its connection comes from
  std::vector<std::string> addresses;  // nodes[].address resolved (IPv4); empty: "any"
  NodeReport rep;
};

uint64_t Report::unmerged_pulses() const {
  if (!running) return 0;
  const uint64_t from = frames ? last_seq : (origin > 0 ? origin - 1 : 0);
  return last_pulse > from ? last_pulse - from : 0;
}

bool Report::merging_stopped() const {
  if (!running) return false;
  // A second of pulses past the deadline: until its deadline a frame may rightly wait for a hull (a
  // rig with a deadline of a second has 60 pulses unmerged at 60 Hz while every frame is whole).
  const uint64_t allowed =
      std::max<uint64_t>(64, static_cast<uint64_t>(std::ceil(rate_hz * (1.0 + deadline_ms / 1000.0))));
  return unmerged_pulses() > allowed;
}

class Aggregator::Figures : public pipeline::Stage {
 public:
  std::string name() const override { return "figures"; }
  void process(pipeline::Frame& f) override {
    std::lock_guard<std::mutex> g(mu);
    if (frames == 0) {
      first_merged_ns = f.t_merged_ns;
      first_seq = f.seq;
    }
    frames++;
    last_merged_ns = f.t_merged_ns;
    last_seq = f.seq;
    if (f.t_merged_ns > f.t_trigger_ns) {
      merged.add(f.t_merged_ns - f.t_trigger_ns);
      window.add(f.t_merged_ns - f.t_trigger_ns);
    }
    count = frames;
  }
  mutable std::mutex mu;
  uint64_t first_merged_ns = 0, last_merged_ns = 0, frames = 0, first_seq = 0, last_seq = 0;
  Latency window;  // trigger -> merged since the last figures line
  Latency merged;
  std::atomic<uint64_t> count{0};
};

Aggregator::Aggregator(config::RigConfig rig, Options options)
    : rig_(std::move(rig)),
      opt_(std::move(options)),
      log_(log::or_spdlog(opt_.log, "voxcap-host")),
      grid_id_(grid_id(rig_.grid)) {
  std::string why;
  if (!rig_.valid(&why)) throw config::ConfigError(rig_.source.string(), "", why);
  assemble::AssemblerOptions ao;
  ao.grid_id = grid_id_;
  ao.voxel_count = static_cast<uint64_t>(rig_.grid.nx) * static_cast<uint64_t>(rig_.grid.ny) *
                   static_cast<uint64_t>(rig_.grid.nz);
  ao.deadline_ns = static_cast<uint64_t>(rig_.assembly.deadline_ms * 1e6);
  ao.pulsed_only = true;  // a seq is taken only once the host pulsed it (note_pulse)
  ao.policy = rig_.assembly.missing_node_policy == config::MissingNodePolicy::Drop
                  ? assemble::MissingPolicy::Drop
                  : assemble::MissingPolicy::Degraded;
  for (size_t k = 0; k < rig_.nodes.size(); k++) {
    auto n = std::make_unique<Node>();
    n->cfg = &rig_.nodes[k];
    n->id = config::node_number(rig_.nodes[k], k, rig_.source.string());  // unique: rig_.valid() checked
    for (uint8_t minor = 0; minor <= VC_PROTO_VERSION_MINOR; minor++) {
      vc_config c = make_config_message(rig_, *n->cfg, grid_id_, minor);
      std::vector<uint8_t>& msg = n->config_msg[minor];
      msg.resize(VC_PROTO_HEADER_SIZE + 4096);
      size_t len = 0;
      vc_header hdr{};
      int rc = vc_encode_config(msg.data(), msg.size(), &len, &hdr, &c);
      if (rc < 0)
        throw config::ConfigError(rig_.source.string(), fmt::format("nodes[{}]", k),
                                  fmt::format("cannot encode its CONFIG: {}", vc_proto_strerror(rc)));
      msg.resize(len);
    }
    n->rep.id = n->id;
    n->rep.name = n->cfg->id;
    n->addresses = resolve_ipv4(n->cfg->address);
    if (n->cfg->address != "any" && n->addresses.empty())
      throw config::ConfigError(rig_.source.string(), fmt::format("nodes[{}].address", k),
                                fmt::format("\"{}\" does not resolve to an IPv4 address", n->cfg->address));
    ao.nodes.push_back(n->id);
    nodes_.push_back(std::move(n));
  }
  pipeline::StageContext ctx;
  ctx.rig = &rig_;
  ctx.log = log_;
  pipeline_ = std::make_unique<pipeline::Pipeline>(ctx);
  pipeline_->then(std::make_unique<assemble::MergeStage>(), {64, pipeline::Overflow::Block});
  if (rig_.triangulation.enabled && rig_.features.enabled && rig_.calibration.cameras.size() >= 2) {
    pipeline_->then(std::make_unique<triangulate::TriangulateStage>(), {64, pipeline::Overflow::Block});
    if (rig_.fitting.enabled)
      pipeline_->then(std::make_unique<fit::FitStage>(), {64, pipeline::Overflow::Block});
  }
  assembly_ = std::make_unique<AssemblyStage>(ao, opt_.assembly, *pipeline_, ctx.log);
  for (const auto& n : nodes_) assembly_->set_running(n->id, false);
  session::ServerOptions so;
  so.listen = rig_.network.listen;
  so.port = rig_.network.port;
  // rig.toml [network]: how often the host says HEARTBEAT and how long a silent node is kept.
  so.heartbeat_interval_ms = rig_.network.heartbeat_interval_ms;
  so.heartbeat_timeout_ms = rig_.network.heartbeat_timeout_ms;
  // The rig key (proto/SPEC.md "Authentication"): the sessions prove it and seal every message, the
  // udp trigger signs its datagrams. Without one the rig is loopback-only (RigConfig::valid) and says so.
  if (!rig_.key_path.empty()) {
    so.key = load_rig_key(rig_);  // a bad key file is bad input: ConfigError, exit 2 at the commands
    rig_.trigger.udp.key = so.key;
    log(log::Level::info, fmt::format("authenticated control: rig key {}", rig_.key_path.string()));
  } else {
    log(log::Level::warn,
        "no rig key: control is not authenticated (allowed because every address is loopback)");
  }
  server_options_ = so;
  server_ = std::make_unique<session::Server>(so, *this, log_);
  if (opt_.start_trigger) {
    trigger_ = trigger::make_generator(rig_.trigger);
    trigger_->set_observer(
        [this](const trigger::Pulse& p) { note_pulse(p.seq, static_cast<uint64_t>(p.t_ns)); });
  }
}

Aggregator::~Aggregator() {
  stop();
}

void Aggregator::log(log::Level level, const std::string& line) const {
  log_(level, line);
}

uint16_t Aggregator::port() const {
  return server_->port();
}

void Aggregator::start() {
  // The figures consumer goes last, after every stage the caller added.
  figures_ = &pipeline_->tap(std::make_unique<Figures>(), {256, pipeline::Overflow::Block});
  pipeline_->start();
  assembly_->start();
  server_->start();
  log(log::Level::info,
      fmt::format("listening on {}:{} for {} nodes", rig_.network.listen, server_->port(), nodes_.size()));
  if (trigger_) {
    trigger_->start(trigger::PulseTrain::from(rig_.trigger));
    log(log::Level::info, fmt::format("trigger: {} at {} Hz", trigger_->describe(), rig_.trigger.rate_hz));
  }
}

void Aggregator::stop() {
  if (!server_) return;
  {
    std::lock_guard<std::mutex> g(mu_);
    std::vector<uint8_t> buf(VC_PROTO_HEADER_SIZE);
    size_t len = 0;
    vc_header hdr{};
    if (vc_encode_stop(buf.data(), buf.size(), &len, &hdr) == 0)
      for (auto& n : nodes_)
        if (n->connected) server_->send(n->conn, buf.data(), len);
  }
  if (trigger_) trigger_->stop();
  if (!server_->drain(500)) log(log::Level::warn, "some nodes did not take their STOP within 0.5 s");
  server_->stop();
  // Upstream first: what was received goes through assembly (pending frames flushed), then every
  // stage drains its queue.
  assembly_->stop();
  pipeline_->stop();
  std::lock_guard<std::mutex> g(mu_);
  server_.reset();
}

uint64_t Aggregator::merged_frames() const {
  return figures_ ? figures_->count.load() : 0;
}

void Aggregator::note_pulse(uint64_t seq, uint64_t t_ns) {
  last_pulse_seq_ = seq;
  pulses_++;
  assembly_->post_pulse(seq, t_ns);
}

bool Aggregator::refuse(Node& n, const vc_msg& m) {
  const char* reason = nullptr;
  std::string detail;
  const char* type = vc_msg_type_name(m.hdr.type) ? vc_msg_type_name(m.hdr.type) : "message";
  if (n.state != VC_STATE_RUNNING) {
    reason = "not_running";
    detail = fmt::format("{} seq {} while the node is {}", type, m.hdr.seq,
                         vc_node_state_name(n.state) ? vc_node_state_name(n.state) : "?");
  } else if (pulses_ == 0 || m.hdr.seq > last_pulse_seq_ + 1) {  // +1: it may overtake the pulse's note
    reason = "unpulsed";
    detail = fmt::format("{} seq {} was never pulsed (the last pulse is seq {})", type, m.hdr.seq,
                         last_pulse_seq_.load());
  }
  if (!reason) return false;
  if (n.rep.refused[reason]++ == 0)
    log(log::Level::warn, fmt::format("node {} ({}): refused {} (counted as '{}'; logged once per reason)",
                                      n.id, n.cfg->id, detail, reason));
  return true;
}

void Aggregator::set_frame_sink(FrameSink sink) {
  std::lock_guard<std::mutex> g(mu_);
  frame_sink_ = std::move(sink);
}

void Aggregator::grab(uint16_t every, uint16_t format) {
  std::lock_guard<std::mutex> g(mu_);
  grab_ = vc_grab{};
  if (every) {
    grab_.every = every;
    grab_.format = format;
    grab_.cameras = 1;  // per node: all of its cameras (send_grab)
  }
  for (auto& n : nodes_) {
    n->grab_sent = false;
    if (n->connected && n->state == VC_STATE_RUNNING) send_grab(*n);
  }
}

void Aggregator::send_grab(Node& n) {
  n.grab_sent = true;
  if (n.minor < 4) {  // SPEC "Evolution": a node older than 2.4 never gets a GRAB
    if (grab_.every)
      log(log::Level::warn, fmt::format("node {} ({}) speaks protocol 2.{}: it cannot send camera images "
                                        "(GRAB is 2.4); update its voxcap-edge",
                                        n.id, n.cfg->id, n.minor));
    return;
  }
  std::vector<uint8_t> buf(VC_PROTO_HEADER_SIZE + 16);
  size_t len = 0;
  vc_header hdr{};
  hdr.node_id = n.id;
  vc_grab g = grab_;
  if (g.every) g.cameras = static_cast<uint16_t>((1u << std::min<size_t>(n.cfg->cameras.size(), 8)) - 1);
  if (vc_encode_grab(buf.data(), buf.size(), &len, &hdr, &g) != 0) return;
  buf.resize(len);
  send(n, buf);
  n.grabbed = g;
}

void Aggregator::on_frame(Node& n, const vc_msg& m) {
  if (refuse(n, m)) return;
  const vc_frame_msg& f = m.u.frame;
  const vc_grab& g = n.grabbed;
  if (!g.every || m.hdr.seq % g.every || f.camera >= n.cfg->cameras.size() ||
      !(g.cameras & (1u << f.camera)) || f.format != g.format) {
    if (n.rep.refused["unrequested"]++ == 0)
      log(log::Level::warn,
          fmt::format("node {} ({}): refused FRAME seq {} camera {} that no GRAB asked for (counted as "
                      "'unrequested'; logged once per reason)",
                      n.id, n.cfg->id, m.hdr.seq, f.camera));
    return;
  }
  if (m.hdr.node_id != n.id) {
    n.rep.rejected++;
    return;
  }
  n.rep.frames++;
  if (!frame_sink_) return;
  CameraFrame cf;
  cf.node_id = n.id;
  cf.node_camera = f.camera;
  cf.camera = n.cfg->cameras[f.camera];
  cf.seq = m.hdr.seq;
  cf.t_trigger_ns = m.hdr.t_trigger_ns;
  cf.width = f.width;
  cf.height = f.height;
  cf.format = f.format;
  // The decoder checked pixels_len = width * height * channels (proto/SPEC.md); the view dies here.
  cf.pixels.assign(f.pixels, f.pixels + f.pixels_len);
  frame_sink_(std::move(cf));
}

Aggregator::Node* Aggregator::by_conn(session::ConnId conn) {
  for (auto& n : nodes_)
    if (n->connected && n->conn == conn) return n.get();
  return nullptr;
}

void Aggregator::send(Node& n, const std::vector<uint8_t>& msg) {
  server_->send(n.conn, msg);
}

std::string Aggregator::on_hello(session::ConnId conn, const vc_msg& m, const std::string& peer) {
  std::lock_guard<std::mutex> g(mu_);
  const vc_hello& h = m.u.hello;
  Node* n = nullptr;
  for (auto& x : nodes_)
    if (x->id == h.node_id) n = x.get();
  if (!n) return fmt::format("node {} is not in rig '{}'", h.node_id, rig_.name);
  if (h.camera_count != n->cfg->cameras.size())
    return fmt::format("node {} has {} cameras, the rig gives it {}", h.node_id, h.camera_count,
                       n->cfg->cameras.size());
  for (size_t k = 0; k < n->cfg->cameras.size(); k++) {
    const rig::Camera& cam =
        rig_.calibration.cameras.at(static_cast<size_t>(rig_.camera_index(n->cfg->cameras[k])));
    if (h.cameras[k].width != cam.width || h.cameras[k].height != cam.height)
      return fmt::format("node {} camera {} delivers {}x{}, {} is calibrated at {}x{}", h.node_id, k,
                         h.cameras[k].width, h.cameras[k].height, cam.name, cam.width, cam.height);
  }
  // nodes[].address: a HELLO from elsewhere is refused (the address it came from is logged).
  const std::string peer_ip = peer.substr(0, peer.rfind(':'));
  if (!n->addresses.empty() &&
      std::find(n->addresses.begin(), n->addresses.end(), peer_ip) == n->addresses.end()) {
    n->rep.hellos_refused++;
    std::string why = fmt::format("node {} ({}) must connect from {}, not from {}", n->id, n->cfg->id,
                                  n->cfg->address, peer_ip);
    log(log::Level::warn, "refused a HELLO: " + why);
    return why;
  }
  // A second HELLO for a node that is connected is refused: the live node stays (issue #13: a
  // duplicate HELLO replaced the real node and took its calibration). An edge that restarted before
  // its old connection was seen to die gets in once that connection is dropped (closed or silent for
  // the heartbeat timeout); edges retry with backoff.
  // On a keyed rig a HELLO whose sender proved the key replaces a connection that has gone silent for
  // more than half the heartbeat timeout (an edge that restarted while its old connection was not yet
  // seen to die): that connection is closed and this one takes the node. A live one always stays.
  if (n->connected && server_->authenticated(conn)) {
    const uint64_t silent = server_->silent_ns(n->conn, monotonic_ns());
    const uint64_t dead_after = static_cast<uint64_t>(server_options_.heartbeat_timeout_ms) * 500'000u;
    if (silent > dead_after) {
      log(log::Level::warn,
          fmt::format("node {} ({}) proved the key from {}; its old connection {} ({}) has been "
                      "silent for {} ms: closing it",
                      n->id, n->cfg->id, peer, n->conn, n->peer, silent / 1'000'000u));
      server_->close(n->conn, "replaced by a new connection that proved the rig key");
      n->connected = false;
    }
  }
  if (n->connected) {
    n->rep.hellos_refused++;
    std::string why = fmt::format("node {} ({}) is already connected (connection {} from {})", n->id,
                                  n->cfg->id, n->conn, n->peer);
    log(log::Level::warn, fmt::format("refused a HELLO from {}: {}", peer, why));
    return why;
  }
  n->peer = peer;
  n->conn = conn;
  n->connected = true;
  n->state = VC_STATE_IDLE;
  n->background_sent = n->start_sent = false;
  n->minor = m.hdr.version_minor;
  n->grab_sent = false;
  n->grabbed = vc_grab{};
  n->rep.joins++;
  log(log::Level::info, fmt::format("node {} ({}) joined from {}", n->id, n->cfg->id, peer));
  // The server delivers HELLO's acceptance after this returns; the CONFIG is queued behind nothing.
  // An older node gets the CONFIG of its minor version, and the user is told what the rig asked for
  // that it cannot do (proto/SPEC.md "Evolution"): a 2.0 node rejects the 2.1 fields (its `reserved`)
  // and gets zeros there; a 2.1 node rejects the 2.2 carve rule subpixel and carves with footprint.
  const uint8_t minor = std::min<uint8_t>(m.hdr.version_minor, VC_PROTO_VERSION_MINOR);
  if (minor == 1 && rig_.carving.rule == config::CarveRule::Subpixel)
    log(log::Level::warn,
        fmt::format("node {} ({}) speaks protocol 2.1: it carves with the footprint rule (the "
                    "rig asks for subpixel carving); update its voxcap-edge",
                    n->id, n->cfg->id));
  if (minor >= 1) {
    send(*n, n->config_msg[minor]);
  } else {
    if (rig_.carving.rule != config::CarveRule::Centre || rig_.silhouettes.enabled())
      log(log::Level::warn,
          fmt::format("node {} ({}) speaks protocol 2.{}: it carves with the centre rule{} (the rig asks for "
                      "{} carving{}); update its voxcap-edge",
                      n->id, n->cfg->id, m.hdr.version_minor,
                      rig_.silhouettes.enabled() ? " and sends no SILHOUETTE" : "",
                      config::to_string(rig_.carving.rule),
                      rig_.silhouettes.enabled()
                          ? fmt::format(" and a SILHOUETTE every {} frames", rig_.silhouettes.every)
                          : ""));
    send(*n, n->config_msg[0]);
  }
  return "";
}

void Aggregator::advance(Node& n) {
  if (n.state == VC_STATE_CONFIGURED && !n.background_sent) {
    std::vector<uint8_t> buf(VC_PROTO_HEADER_SIZE + 16);
    size_t len = 0;
    vc_header hdr{};
    vc_background b{static_cast<uint32_t>(rig_.subtraction.background_frames)};
    if (vc_encode_background(buf.data(), buf.size(), &len, &hdr, &b) == 0) {
      buf.resize(len);
      send(n, buf);
      n.background_sent = true;
      log(log::Level::info, fmt::format("node {}: learning the background ({} frames)", n.id, b.frame_count));
    }
  }
  if (n.state == VC_STATE_READY && !n.start_sent) {
    if (!run_started_) {
      bool all = std::all_of(nodes_.begin(), nodes_.end(),
                             [](const auto& x) { return x->connected && x->state == VC_STATE_READY; });
      if (!all) return;
      run_started_ = true;
      origin_ =
          last_pulse_seq_ +
          std::max<uint64_t>(6, static_cast<uint64_t>(std::ceil(opt_.start_margin_s * rig_.trigger.rate_hz)));
      log(log::Level::info, fmt::format("every node is ready: the run starts at seq {}", origin_));
      for (auto& x : nodes_) {
        x->start_sent = false;
        if (x.get() != &n) advance(*x);
      }
    }
    std::vector<uint8_t> buf(VC_PROTO_HEADER_SIZE);
    size_t len = 0;
    vc_header hdr{};
    hdr.seq = origin_;
    if (vc_encode_start(buf.data(), buf.size(), &len, &hdr) == 0) {
      buf.resize(len);
      send(n, buf);
      n.start_sent = true;
    }
  }
  set_running(n);
}

void Aggregator::set_running(Node& n) {
  bool running = n.connected && n.state == VC_STATE_RUNNING;
  if (!running) {
    n.grab_sent = false;  // a node's GRAB ends with its run (SPEC: START, STOP, CONFIG end it)
    n.grabbed = vc_grab{};
  } else if (grab_.every && !n.grab_sent) {
    send_grab(n);
  }
  if (running == n.assembling) return;
  n.assembling = running;
  assembly_->set_running(n.id, running);
}

void Aggregator::on_message(session::ConnId conn, const vc_msg& m, uint64_t t_rx_ns) {
  std::lock_guard<std::mutex> g(mu_);
  Node* n = by_conn(conn);
  if (!n) return;
  switch (m.hdr.type) {
    case VC_MSG_HEARTBEAT:
      if (n->state != m.u.heartbeat.state) {
        n->state = m.u.heartbeat.state;
        advance(*n);
      }
      break;
    case VC_MSG_HULL: {
      if (refuse(*n, m)) break;
      if (m.hdr.node_id != n->id) {
        n->rep.rejected++;
        break;
      }
      assemble::PartialHull h;
      h.node_id = n->id;
      h.seq = m.hdr.seq;
      h.t_trigger_ns = m.hdr.t_trigger_ns;
      h.t_received_ns = t_rx_ns;
      h.grid_id = m.u.hull.grid_id;
      h.voxel_count = m.u.hull.voxel_count;
      h.occupied = m.u.hull.occupied_count;
      h.rle.assign(m.u.hull.rle, m.u.hull.rle + m.u.hull.rle_len);
      if (t_rx_ns > h.t_trigger_ns) n->rep.rx.add(t_rx_ns - h.t_trigger_ns);
      n->rep.hulls++;
      assembly_->post_hull(std::move(h));  // never waits; a full queue drops it (counted per node)
      break;
    }
    case VC_MSG_FEATURES:
      if (refuse(*n, m)) break;
      if (m.hdr.node_id != n->id) {
        n->rep.rejected++;
        break;
      }
      assembly_->post_features(n->id, m.hdr.seq, m.hdr.t_trigger_ns, m.u.features);
      break;
    case VC_MSG_SILHOUETTE: {
      if (refuse(*n, m)) break;
      if (m.hdr.node_id != n->id) {
        n->rep.rejected++;
        break;
      }
      // The decoder checked sizes, counts and the RLE (proto/SPEC.md); the views die with this call.
      const vc_silhouette& s = m.u.silhouette;
      pipeline::Silhouette sil;
      sil.camera = s.camera;
      sil.scale = s.scale;
      sil.width = s.width;
      sil.height = s.height;
      sil.foreground = s.foreground_count;
      sil.rle.assign(s.rle, s.rle + s.rle_len);
      assembly_->post_silhouette(n->id, m.hdr.seq, m.hdr.t_trigger_ns, std::move(sil));
      break;
    }
    case VC_MSG_FRAME:
      on_frame(*n, m);
      break;
    case VC_MSG_STATS: {
      const vc_stats& s = m.u.stats;
      for (int i = 0; i < s.stage_count; i++) {
        const char* name = vc_stage_name(s.stages[i].stage_id);
        double ms = s.stages[i].mean_ns / 1e6;
        n->rep.edge_stage_ms[name ? name : fmt::format("stage{}", s.stages[i].stage_id)] = ms;
        if (s.stages[i].stage_id == VC_STAGE_FRAME) n->rep.edge_frame_ms = ms;
      }
      for (int i = 0; i < s.counter_count; i++) {
        uint64_t v = s.counters[i].value;
        switch (s.counters[i].counter_id) {
          case VC_COUNTER_SEND_QUEUE_DROPS:
            n->rep.edge_queue_drops = v;
            break;
          case VC_COUNTER_FRAMES_WITHOUT_PULSE:
            n->rep.edge_frames_without_pulse = v;
            break;
          case VC_COUNTER_PULSES_WITHOUT_FRAME:
            n->rep.edge_pulses_without_frame = v;
            break;
          default:
            break;
        }
      }
      assembly_->post_stats(n->id, s);
      break;
    }
    case VC_MSG_ERROR: {
      const vc_error& e = m.u.error;
      n->rep.errors++;
      n->rep.last_error.assign(e.text, e.text_len);
      log(e.severity == VC_SEVERITY_WARNING ? log::Level::warn : log::Level::err,
          fmt::format("node {} {}: {}", n->id,
                      vc_error_severity_name(e.severity) ? vc_error_severity_name(e.severity) : "?",
                      n->rep.last_error));
      break;
    }
    default:
      log(log::Level::warn,
          fmt::format("node {}: unexpected {}", n->id,
                      vc_msg_type_name(m.hdr.type) ? vc_msg_type_name(m.hdr.type) : "message"));
      break;
  }
}

void Aggregator::on_disconnect(session::ConnId conn, const std::string& reason) {
  std::lock_guard<std::mutex> g(mu_);
  Node* n = by_conn(conn);
  if (!n) return;
  n->connected = false;
  n->state = VC_STATE_IDLE;
  n->rep.leaves++;
  set_running(*n);
  log(log::Level::warn, fmt::format("node {} ({}) left: {}", n->id, n->cfg->id, reason));
}

void Aggregator::on_mac_rejected(session::ConnId /*conn*/, uint16_t node_id, int code) {
  // By the node its HELLO named (and the server accepted): the connection may be gone or replaced
  // since, the count stays the node's. The server logged the message's line.
  std::lock_guard<std::mutex> g(mu_);
  for (auto& n : nodes_) {
    if (n->id != node_id) continue;
    NodeReport::MacRejected& m = n->rep.mac_rejected;
    (code == VC_PROTO_EMAC ? m.forged : code == VC_PROTO_EREPLAY ? m.replayed : m.reordered)++;
    return;
  }
}

void Aggregator::on_tick(uint64_t now_ns) {
  // Deadlines are the assembly stage's (its own thread); here only the line of figures.
  if (opt_.log_every_s <= 0 || !figures_) return;
  if (last_log_ns_ == 0) last_log_ns_ = now_ns;
  double dt = double(now_ns - last_log_ns_) / 1e9;
  if (dt < opt_.log_every_s) return;
  // The observability line: fps, trigger -> merged latency, per node what its STATS and the assembler
  // say (edge frame time, late and missing hulls, the edge's own drops and the host's), and per stage
  // its time, queue and drops.
  const assemble::AssemblerStats st = assembly_->stats();
  const std::map<uint16_t, uint64_t> host_drops = assembly_->drops();
  std::string nodes;
  {
    std::lock_guard<std::mutex> g(mu_);
    for (const auto& n : nodes_) {
      auto it = st.nodes.find(n->id);
      auto hd = host_drops.find(n->id);
      nodes += fmt::format(
          " | {} {} edge {:.2f} ms late {} missing {} drops {}", n->cfg->id,
          n->connected ? (vc_node_state_name(n->state) ? vc_node_state_name(n->state) : "?") : "gone",
          n->rep.edge_frame_ms, it != st.nodes.end() ? it->second.late : 0,
          it != st.nodes.end() ? it->second.missing : 0,
          n->rep.edge_queue_drops + n->rep.edge_pulses_without_frame +
              (hd != host_drops.end() ? hd->second : 0));
    }
  }
  std::string stages;
  for (const pipeline::StageReport& s : pipeline_report().stages)
    stages += fmt::format(" | {} {:.2f} ms q {}/{} drops {}", s.name, s.busy_ms_mean, s.queue.depth,
                          s.queue.capacity, s.queue.dropped);
  uint64_t frames = 0;
  double p50 = 0, p99 = 0;
  {
    std::lock_guard<std::mutex> g(figures_->mu);
    frames = figures_->frames;
    p50 = figures_->window.percentile_ms(0.5);
    p99 = figures_->window.percentile_ms(0.99);
    figures_->window = Latency{};
  }
  log(log::Level::info,
      fmt::format(
          "{:.1f} fps, trigger->merged p50 {:.2f} ms p99 {:.2f} ms, frames {} ({} complete, {} degraded, "
          "{} dropped){}{}",
          double(frames - frames_at_log_) / dt, p50, p99, frames, st.complete, st.degraded, st.dropped, nodes,
          stages));
  frames_at_log_ = frames;
  last_log_ns_ = now_ns;
}

pipeline::PipelineReport Aggregator::pipeline_report() const {
  pipeline::PipelineReport p = pipeline_->report();
  p.stages.insert(p.stages.begin(), assembly_->report());
  return p;
}

bool Aggregator::all_running() const {
  std::lock_guard<std::mutex> g(mu_);
  return std::all_of(nodes_.begin(), nodes_.end(),
                     [](const auto& n) { return n->connected && n->state == VC_STATE_RUNNING; });
}

Report Aggregator::report() const {
  Report r;
  r.pulses = pulses_;
  const assemble::AssemblerStats st = assembly_->stats();
  const std::map<uint16_t, uint64_t> host_drops = assembly_->drops();
  if (figures_) {
    std::lock_guard<std::mutex> g(figures_->mu);
    r.frames = figures_->frames;
    r.first_seq = figures_->first_seq;
    r.last_seq = figures_->last_seq;
    r.seconds = r.frames > 1 ? double(figures_->last_merged_ns - figures_->first_merged_ns) / 1e9 : 0;
    r.merged = figures_->merged;
  }
  r.fps = r.seconds > 0 ? double(r.frames - 1) / r.seconds : 0;
  r.complete = st.complete;
  r.degraded = st.degraded;
  r.dropped = st.dropped;
  r.evicted = st.evicted;
  r.pending_frames = assembly_->pending();
  r.pipeline = pipeline_report();
  std::lock_guard<std::mutex> g(mu_);
  r.running = run_started_;
  if (server_) r.server = server_->stats();
  r.origin = origin_;
  r.last_pulse = last_pulse_seq_;
  r.rate_hz = rig_.trigger.rate_hz;
  r.deadline_ms = rig_.assembly.deadline_ms;
  for (const auto& n : nodes_) {
    NodeReport nr = n->rep;
    nr.connected = n->connected;
    nr.state = n->state;
    auto it = st.nodes.find(n->id);
    if (it != st.nodes.end()) {
      nr.late = it->second.late;
      nr.missing = it->second.missing;
      nr.rejected += it->second.rejected;
      nr.features = it->second.features;
      nr.features_late = it->second.features_late;
      nr.unpulsed = it->second.unpulsed;
    }
    auto hd = host_drops.find(n->id);
    if (hd != host_drops.end()) nr.host_queue_drops = hd->second;
    r.nodes.push_back(std::move(nr));
  }
  return r;
}

}  // namespace vc::aggregator
