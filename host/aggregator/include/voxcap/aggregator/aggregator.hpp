// The host aggregator: runs the rig. It owns the session server (edges connect), the trigger
// generator, and the frame assembler, and drives every node through its session on its own:
//
//   HELLO (checked: node in the rig, two cameras of the calibrated sizes,   → CONFIG
//          from its nodes[].address when given, and not connected already: a second HELLO for a
//          connected node is refused and the live node stays)
//   node reports CONFIGURED (HEARTBEAT)                                     → BACKGROUND
//   node reports READY: the run starts when every node is READY; START(origin) carries the run's
//   origin seq (the first pulse streamed; emulated cameras show motion frame seq − origin), and a
//   node that (re)joins later gets the same origin, so it rejoins in step with the others.
//   node reports RUNNING                                                     → the assembler waits for it
//   connection lost                                                           → frames go on without it
//
// The session server's thread only decodes, runs this state machine and hands HULL, FEATURES and STATS
// to the assembly stage's queue without waiting (assembly_stage.hpp); heartbeats never wait for a
// stage. Frames then flow through the host's pipeline (voxcap/pipeline/pipeline.hpp):
//
//   assemble ─► merge ─► [stages added with pipeline().then()] ─┬─► figures (fps, latency; internal)
//                                                               └─► [consumers added with pipeline().tap()]
//
// Per-stage latency (trigger → hull at edge → received → merged), fps, per-node drops and every
// stage's queue, drops and time are kept for report() and the log.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "voxcap/aggregator/assembly_stage.hpp"
#include "voxcap/assemble/assembler.hpp"
#include "voxcap/base/log.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/pipeline/pipeline.hpp"
#include "voxcap/proto.h"
#include "voxcap/session/server.hpp"
#include "voxcap/trigger/generator.hpp"

namespace vc::aggregator {

// The CONFIG message body for one node, from the rig configuration. node_minor is the protocol minor
// version of the node's HELLO: a 2.0 node (minor 0) gets carve_rule, silhouette_every and
// silhouette_scale as 0 (its `reserved`: centre carving, no SILHOUETTE), as proto/SPEC.md "Evolution" says.
vc_config make_config_message(const config::RigConfig& rig, const config::NodeConfig& node, uint32_t grid_id,
                              uint8_t node_minor = VC_PROTO_VERSION_MINOR);
// nodes[].address as the IPv4 addresses a node's connection may come from: an IPv4 address itself, a
// host name's IPv4 addresses, none for "any" (or a name that does not resolve).
std::vector<std::string> resolve_ipv4(const std::string& address);
// The rig key named in rig.toml (`key = ...`), read as the host reads it before it starts (voxcap
// config check runs the same): a regular file, not readable by group or others, one line of 64 hex
// digits. Empty without a key. Throws config::ConfigError (file rig.toml, key "key", one line) when
// the file is missing, too open or malformed.
std::vector<uint8_t> load_rig_key(const config::RigConfig& rig);
// A stable id for the rig's grid (CRC32C of its parameters).
uint32_t grid_id(const rig::VoxelGrid& grid);

// One camera's full image of one frame, from a FRAME (protocol 2.4) a node sent because the host asked
// (Aggregator::grab). Owned copy: the decoder's view dies with the message.
struct CameraFrame {
  uint16_t node_id = 0;
  uint16_t node_camera = 0;  // the node's camera index (HELLO order)
  std::string camera;        // the rig's name for it (nodes[].cameras)
  uint64_t seq = 0, t_trigger_ns = 0;
  int width = 0, height = 0;
  uint16_t format = VC_FRAME_GRAY8;  // vc_frame_format: gray8 (1 byte per pixel) or rgb8 (R G B)
  std::vector<uint8_t> pixels;       // width * height * channels, rows without padding
};
// Where FRAMEs go: called on the session server's thread, must not block (queue and return).
using FrameSink = std::function<void(CameraFrame&&)>;

struct Options {
  // origin = last pulse + this much time in pulses (at least 6): START must reach every node, and each
  // must be streaming (emulated cameras reopen for the run) before the origin pulse.
  double start_margin_s = 0.3;
  bool start_trigger = true;  // false: tests drive pulses themselves via note_pulse()
  log::Fn log;  // the aggregator's, the sessions' and the stages' lines; none: spdlog, "voxcap-host: ..."
  double log_every_s = 5;    // a line of figures (fps, latency, per-node drops, stages) this often; 0: never
  AssemblyOptions assembly;  // the assembly stage's queue and deadline polling
};

struct Latency {                              // nanoseconds
  static constexpr size_t kReservoir = 4096;  // p99 rests on ~40 values above it
  uint64_t n = 0;
  double sum = 0;
  uint64_t max = 0;
  std::vector<uint64_t> samples;  // a uniform sample of all values (reservoir), for percentiles
  uint64_t rng = 0x9E3779B97F4A7C15ull;
  void add(uint64_t v);
  double mean_ms() const { return n ? sum / double(n) / 1e6 : 0; }
  double max_ms() const { return double(max) / 1e6; }
  double percentile_ms(double p) const;
};

struct NodeReport {
  uint16_t id = 0;
  std::string name;
  bool connected = false;
  uint32_t state = VC_STATE_IDLE;
  uint64_t joins = 0, leaves = 0;
  uint64_t hellos_refused = 0;  // HELLOs for this node refused: already connected, or a wrong address
  uint64_t hulls = 0, late = 0, missing = 0, rejected = 0;
  uint64_t edge_queue_drops = 0, edge_frames_without_pulse = 0, edge_pulses_without_frame = 0;
  uint64_t host_queue_drops = 0;  // its messages dropped because the assembly stage's queue was full
  uint64_t features = 0, features_late = 0;  // FEATURES that joined a frame / came after it
  uint64_t frames = 0;                       // FRAMEs (2.4) taken and handed to the frame sink
  uint64_t errors = 0;
  std::string last_error;
  // HULL, FEATURES, SILHOUETTE and FRAME refused before assembly, by reason: "not_running" (the node is
  // not in state running), "unpulsed" (a seq the host has not pulsed), "unrequested" (a FRAME no GRAB
  // in force asked for: another seq or camera, or no GRAB). Each reason is logged once per node.
  std::map<std::string, uint64_t> refused;
  uint64_t unpulsed = 0;  // refused by the assembler itself for a seq never pulsed (a second guard)
  // Messages on this node's connections (all of them, across rejoins) dropped by their MAC (keyed
  // rigs, protocol 2.3): a bad tag or none (forged), a counter used before (replayed), one ahead of
  // the next (reordered). The session server logs each; a connection with 16 is closed.
  struct MacRejected {
    uint64_t forged = 0, replayed = 0, reordered = 0;
    uint64_t total() const { return forged + replayed + reordered; }
  } mac_rejected;
  double edge_frame_ms = 0;  // trigger edge → HULL queued, as the edge's STATS say (mean)
  std::map<std::string, double> edge_stage_ms;  // mean per stage from the last STATS
  Latency rx;                                   // trigger → HULL received at the host
};

struct Report {
  uint64_t pulses = 0;
  uint64_t frames = 0, complete = 0, degraded = 0, dropped = 0, evicted = 0;
  uint64_t first_seq = 0, last_seq = 0;
  double seconds = 0;  // from the first merged frame to the last
  double fps = 0;
  Latency merged;  // trigger → merged
  std::vector<NodeReport> nodes;
  session::ServerStats server;        // connections accepted, dropped for undecodable bytes, timeouts, ...
  size_t pending_frames = 0;          // frames waiting in the assembler now
  pipeline::PipelineReport pipeline;  // every stage: assemble, merge, ..., figures, consumers
  bool running = false;               // the run has started (every node was READY once)
  uint64_t origin = 0;
  uint64_t last_pulse = 0;  // seq of the last pulse sent
  double rate_hz = 0;       // the trigger's rate
  double deadline_ms = 0;   // a frame's assembly deadline ([assembly] deadline_ms)
  // Pulses after the last merged frame that never merged, once the run started.
  uint64_t unmerged_pulses() const;
  // The run stopped merging: it started, and more than the deadline plus a second of pulses (at least
  // 64) after its last merged frame (or since its origin, when none merged) never merged. The summary
  // says so and `voxcap rig` exits non-zero.
  bool merging_stopped() const;
};

class Aggregator : public session::Handler {
 public:
  Aggregator(config::RigConfig rig, Options options);
  ~Aggregator() override;

  // The frame pipeline after assembly: merge is in it; add stages (then) and consumers (tap) before
  // start(), e.g. pipeline().tap(std::make_unique<RecordStage>(dir), RecordStage::kQueue).
  pipeline::Pipeline& pipeline() { return *pipeline_; }

  void start();  // configures and starts the stages, listens, starts the trigger; throws on failure
  void stop();   // STOP to every node, trigger off; pending frames flushed through every stage
  uint16_t port() const;
  uint64_t merged_frames() const;  // frames that left the chain so far

  Report report() const;
  bool all_running() const;
  // Full camera images (protocol 2.4): frames go to `sink` (set before start()). grab() sends GRAB
  // (every `every`-th frame as `format`, both cameras, no end) to every running node that speaks 2.4,
  // and again to each node that (re)starts running while it is in force; every 0 stops (GRAB with every
  // 0). Nodes older than 2.4 are skipped with a warning naming them. Their hulls merge as before.
  void set_frame_sink(FrameSink sink);
  void grab(uint16_t every, uint16_t format = VC_FRAME_GRAY8);

  // The pulse observer (the trigger thread calls it; tests may call it directly).
  void note_pulse(uint64_t seq, uint64_t t_ns);

  // session::Handler (server thread)
  std::string on_hello(session::ConnId conn, const vc_msg& hello, const std::string& peer) override;
  void on_message(session::ConnId conn, const vc_msg& msg, uint64_t t_rx_ns) override;
  void on_disconnect(session::ConnId conn, const std::string& reason) override;
  void on_tick(uint64_t now_ns) override;
  void on_mac_rejected(session::ConnId conn, uint16_t node_id, int code) override;

 private:
  struct Node;
  Node* by_conn(session::ConnId conn);
  void send(Node& n, const std::vector<uint8_t>& msg);
  void advance(Node& n);
  void set_running(Node& n);
  // HULL, FEATURES, SILHOUETTE from a node that is not running, or for a seq never pulsed: true when
  // refused (counted in its report by reason, logged once per reason).
  bool refuse(Node& n, const vc_msg& m);
  void send_grab(Node& n);  // the GRAB in force (grab_), or its stop, to one node
  void on_frame(Node& n, const vc_msg& m);
  void log(log::Level level, const std::string& line) const;
  pipeline::PipelineReport pipeline_report() const;

  // Counts the frames that leave the chain: fps and trigger -> merged latency (a Block consumer).
  class Figures;

  config::RigConfig rig_;
  Options opt_;
  log::Fn log_;  // opt_.log, or spdlog
  uint32_t grid_id_;
  std::unique_ptr<pipeline::Pipeline> pipeline_;
  Figures* figures_ = nullptr;  // owned by pipeline_
  std::unique_ptr<AssemblyStage> assembly_;
  std::unique_ptr<session::Server> server_;
  session::ServerOptions server_options_;  // as the server was made (its key included)
  std::unique_ptr<trigger::Generator> trigger_;
  mutable std::mutex mu_;
  std::vector<std::unique_ptr<Node>> nodes_;
  std::atomic<uint64_t> last_pulse_seq_{0}, pulses_{0};
  bool run_started_ = false;
  uint64_t origin_ = 0;
  vc_grab grab_{};  // the GRAB in force (every 0: none)
  FrameSink frame_sink_;
  uint64_t last_log_ns_ = 0, frames_at_log_ = 0;
};

}  // namespace vc::aggregator
