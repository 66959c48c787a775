// The assembly stage: the head of the host's pipeline. The session server's thread hands it what the
// nodes send (post_*: never waits — when its queue is full the message is dropped and counted for its
// node); on its own thread it groups them by seq (assemble::Assembler, unmerged), resolves each frame
// when every running node's HULL is in (or the node moved past it) or at its deadline, and pushes it into the
// pipeline, where it may wait for room (a Block stage further down holds back this thread, never the session
// thread).
//
// Lifecycle as every stage: configure (the constructor: options from the rig) → start → process (its
// thread: one message at a time; without one it waits for the earliest pending deadline, at most
// poll_ms) → stop (the queue is drained, pending frames are flushed into the pipeline).
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "voxcap/assemble/assembler.hpp"
#include "voxcap/base/log.hpp"
#include "voxcap/pipeline/pipeline.hpp"

namespace vc::aggregator {

struct AssemblyOptions {
  size_t queue = 1024;  // messages waiting at most (~8 s of 3 nodes at 60 Hz with FEATURES)
  int poll_ms = 5;      // the longest wait without a message (it waits for the earliest pending deadline)
  // Bytes one node may have waiting in the queue (hull and silhouette RLE, FEATURES, STATS): beyond
  // them its messages are dropped (counted as its drops) while the other nodes' still get in, so the
  // queue's memory is bounded by nodes x this, whatever one node sends (a HULL may be 8 MiB).
  size_t max_node_bytes = 64u << 20;
};

class AssemblyStage {
 public:
  // Frames go to `out` (borrowed; it must outlive this stage and be started before start()).
  AssemblyStage(assemble::AssemblerOptions assembler, AssemblyOptions options, pipeline::Pipeline& out,
                log::Fn log);
  ~AssemblyStage();  // stop()

  void start();
  void stop();  // idempotent

  // From the session thread; false when dropped (queue full, counted for the node) or stopped.
  bool post_hull(assemble::PartialHull hull);
  bool post_features(uint16_t node_id, uint64_t seq, uint64_t t_trigger_ns, const vc_features& features);
  bool post_stats(uint16_t node_id, const vc_stats& stats);
  // One SILHOUETTE (already copied out of the decoder's buffer): joins the frame of its seq.
  bool post_silhouette(uint16_t node_id, uint64_t seq, uint64_t t_trigger_ns,
                       pipeline::Silhouette silhouette);
  // Which nodes a frame waits for. Queued in order with the messages (never dropped, never waits):
  // hulls queued before a node started running are assembled as if it was not running yet.
  void set_running(uint16_t node_id, bool running);
  // The host sent pulse seq at t_ns (the trigger thread): the assembler takes that seq from now on
  // (assemble::AssemblerOptions::pulsed_only). Never waits, and never takes a place in the queue: the
  // notes wait in a ring of their own, as many as the assembler keeps pulse times for (its
  // max_pending), which the assembly thread empties before every message it takes (so a pulse is
  // known no later than in queue order). When the thread is held back longer than that, the oldest
  // notes are overwritten: those are the pulses the assembler would have forgotten by then anyway (it
  // keeps the last max_pending), and the newest, which moves its pulse mark, is always kept.
  void post_pulse(uint64_t seq, uint64_t t_ns);
  // Pulse notes waiting for the assembly thread now (at most pulse_ring_size()), and how many were
  // overwritten before it took them.
  size_t pulse_notes_waiting() const;
  size_t pulse_ring_size() const { return pulse_ring_.size(); }
  uint64_t pulse_notes_overwritten() const;

  assemble::AssemblerStats stats() const;
  size_t pending() const;
  pipeline::StageReport report() const;        // as "assemble"
  std::map<uint16_t, uint64_t> drops() const;  // per node: messages dropped for a full queue

 private:
  struct Features {
    uint16_t node_id;
    uint64_t seq, t_trigger_ns;
    vc_features features;
  };
  struct Stats {
    uint16_t node_id;
    vc_stats stats;
  };
  struct SilhouetteIn {
    uint16_t node_id;
    uint64_t seq, t_trigger_ns;
    pipeline::Silhouette silhouette;
  };
  struct Running {
    uint16_t node_id;
    bool running;
  };
  struct Pulse {
    uint64_t seq, t_ns;
  };
  using Input = std::variant<assemble::PartialHull, Features, Stats, Running, SilhouetteIn>;

  bool post(uint16_t node_id, Input in);
  void take_pulses();  // the assembly thread: the waiting pulse notes into the assembler (mu_ held)
  void note_drop(const char* why);  // the warning line, at most every 5 s
  static size_t bytes_of(const Input& in);
  void run();
  void forward(std::vector<assemble::MergedFrame>& frames);

  pipeline::Pipeline& out_;
  AssemblyOptions opt_;
  log::Fn log_;
  pipeline::BoundedQueue<Input> inbox_;
  mutable std::mutex mu_;  // the assembler, the figures below
  assemble::Assembler assembler_;
  uint64_t processed_ = 0;
  double busy_ns_sum_ = 0, busy_ns_max_ = 0;
  std::map<uint16_t, uint64_t> drops_;
  std::map<uint16_t, size_t> queued_bytes_;  // per node: bytes of its messages in inbox_
  uint64_t drops_logged_ = 0, last_drop_log_ns_ = 0;
  // The pulse notes (post_pulse): a ring, oldest first from pulse_head_; under pulse_mu_ only, so the
  // trigger thread never waits for the assembler.
  mutable std::mutex pulse_mu_;
  std::vector<Pulse> pulse_ring_;
  size_t pulse_head_ = 0, pulse_count_ = 0;
  uint64_t pulse_overwritten_ = 0;
  std::vector<Pulse> pulse_batch_;  // the assembly thread's copy, reused
  std::thread thread_;
  bool started_ = false, stopped_ = false;
};

}  // namespace vc::aggregator
