// Frame assembly on the host: group what the nodes send by trigger seq into one pipeline::Frame —
// partial hulls, FEATURES and SILHOUETTEs (per camera) and STATS — and intersect the hulls.
//
// A frame is merged as soon as every node that is currently running has sent its HULL for that seq
// or has already sent something about a later seq, or when its deadline (trigger time + deadline)
// passes. A node handles its frames in pulse order and sends a frame's FEATURES, SILHOUETTEs and HULL
// before anything of the next one, on one TCP connection (proto/SPEC.md, HULL): once its message about
// seq n+1 is here, its HULL for seq n is not coming (the camera missed the pulse, the edge dropped the
// frame), so waiting out the deadline for it only delays the frame. Frames leave in seq order. The merge is
// the AND of the partial hulls, done on the RLE streams directly in one pass over all of them (vc_rle_and_n,
// no bitset in between). When a configured node is missing from a frame, the policy decides: Drop the frame,
// or merge what came and mark it degraded. A HULL for a frame that was already emitted is late: counted per
// node and discarded. FEATURES and SILHOUETTEs join the frame of their seq (they never hold it back; late
// ones are counted and discarded); STATS are not about one seq and join the next frame the assembler emits.
// With AssemblerOptions::merge false the frames leave unmerged (the host's pipeline merges them in its
// merge stage, merge_stage.hpp); merge() below is that step.
//
// Memory is bounded whatever the nodes do: at most max_pending frames wait; a newer seq beyond that
// evicts the oldest pending frame, which is resolved early as if its deadline had passed. Pure logic:
// no clocks (times are passed in), no sockets, no threads.
//
// Trusting seq (AssemblerOptions::pulsed_only, what the host runs): the host tells the assembler every
// pulse it sends (pulse()). A HULL, FEATURES or SILHOUETTE is then taken only for a seq the host has
// pulsed (at most pulse_slack ahead of the last pulse, for a message that overtook the pulse's note),
// and a frame's deadline runs from the host's own time of that pulse, never from the t_trigger_ns a
// node wrote. The high-water mark of resolved seqs (what makes a hull "late") therefore never moves
// past the last pulse: one message with seq 2^62, or a pulse time of 0, cannot make every later
// frame late. What is refused is counted per node (`unpulsed`).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "voxcap/pipeline/frame.hpp"

namespace vc::assemble {

enum class MissingPolicy { Drop, Degraded };

struct PartialHull {
  uint16_t node_id = 0;
  uint64_t seq = 0;
  uint64_t t_trigger_ns = 0;   // host CLOCK_MONOTONIC time of the pulse
  uint64_t t_received_ns = 0;  // when the host finished receiving it
  uint32_t grid_id = 0;
  uint64_t voxel_count = 0;
  uint64_t occupied = 0;
  std::vector<uint8_t> rle;  // proto/ RLE (voxcap/rle.h)
};

// What the assembler emits: the pipeline's frame (t_assembled_ns and, when merged here, t_merged_ns
// are the `now` at which it was resolved).
using MergedFrame = pipeline::Frame;

struct AssemblerOptions {
  std::vector<uint16_t> nodes;  // the configured nodes (all of them, running or not)
  uint32_t grid_id = 0;
  uint64_t voxel_count = 0;
  uint64_t deadline_ns = 50'000'000;
  MissingPolicy policy = MissingPolicy::Drop;
  size_t max_pending = 64;        // frames waiting at most
  bool merge = true;              // AND the hulls when a frame is resolved; false: leave it to merge()
  size_t max_stats_waiting = 16;  // STATS kept per node until the next frame leaves (the oldest go)
  bool pulsed_only = false;       // take a seq only after pulse() named it (see above); the host's setting
  uint64_t pulse_slack = 1;       // with pulsed_only: how far past the last pulse a seq may be

  bool valid(std::string* why) const;
};

struct NodeCounters {
  uint64_t received = 0;              // partial hulls accepted
  uint64_t missing = 0;               // frames resolved without this node's hull
  uint64_t late = 0;                  // hulls that came after their frame was resolved
  uint64_t rejected = 0;              // wrong grid, wrong size, duplicate, inconsistent RLE
  uint64_t features = 0;              // FEATURES messages that joined a frame
  uint64_t features_late = 0;         // FEATURES for a frame already resolved
  uint64_t features_rejected = 0;     // a second one of a camera for a frame, or a camera >= 8
  uint64_t silhouettes = 0;           // SILHOUETTEs that joined a frame
  uint64_t silhouettes_late = 0;      // SILHOUETTEs for a frame already resolved (or older than all kept)
  uint64_t silhouettes_rejected = 0;  // a second one of a camera for a frame, or a camera >= 8
  uint64_t unpulsed = 0;              // pulsed_only: HULL/FEATURES/SILHOUETTE for a seq never pulsed
};

struct AssemblerStats {
  uint64_t complete = 0;  // frames merged with every configured node
  uint64_t degraded = 0;  // frames merged with some node missing (policy Degraded)
  uint64_t dropped = 0;   // frames dropped for a missing node (policy Drop)
  uint64_t evicted = 0;   // frames resolved early because max_pending was reached
  std::map<uint16_t, NodeCounters> nodes;
};

class Assembler {
 public:
  explicit Assembler(AssemblerOptions options);  // throws std::invalid_argument when !options.valid()

  // Which configured nodes are running now: a frame only waits for these. A node that is not running
  // still makes a frame degraded (or dropped) when its hull is missing.
  void set_running(uint16_t node_id, bool running);

  // One node's partial hull. Frames that became complete are appended to `out`. Returns false when
  // the hull was rejected or late (counted).
  bool add(PartialHull hull, uint64_t now_ns, std::vector<MergedFrame>& out);
  // One node's FEATURES (one camera) for frame `seq`. They join the frame without holding it back.
  // Returns false when late or not from a configured node.
  bool add_features(uint16_t node_id, uint64_t seq, uint64_t t_trigger_ns, const vc_features& features,
                    uint64_t now_ns, std::vector<MergedFrame>& out);
  // One node's SILHOUETTE (one camera) for frame `seq`: joins the frame like FEATURES (never holds it
  // back; late ones are counted and discarded). At most one per camera and frame, camera <
  // VC_PROTO_MAX_CAMERAS, so a frame's silhouettes are bounded. Returns false when late, rejected or
  // not from a configured node.
  bool add_silhouette(uint16_t node_id, uint64_t seq, uint64_t t_trigger_ns, pipeline::Silhouette silhouette,
                      uint64_t now_ns, std::vector<MergedFrame>& out);
  // The host sent pulse seq at t_ns (its CLOCK_MONOTONIC). With pulsed_only a seq is taken only once
  // pulsed, and its frame's deadline runs from t_ns. Pulses go up; an older seq is ignored.
  void pulse(uint64_t seq, uint64_t t_ns);
  uint64_t last_pulse() const { return last_pulse_; }

  // One node's STATS: they go with the next frame that leaves the assembler.
  void add_stats(uint16_t node_id, const vc_stats& stats);

  // Resolves every frame whose deadline passed at now_ns (in seq order), appending merged ones.
  void poll(uint64_t now_ns, std::vector<MergedFrame>& out);

  // The earliest deadline of the frames pending (host clock), or 0 when none is: what the caller's
  // thread waits for when no message comes (poll() then).
  uint64_t next_deadline_ns() const;

  // Resolves everything pending (at stop).
  void flush(uint64_t now_ns, std::vector<MergedFrame>& out);

  const AssemblerStats& stats() const { return stats_; }
  size_t pending() const { return pending_.size(); }
  size_t pending_bytes() const;
  const AssemblerOptions& options() const { return opt_; }

 private:
  struct Pending {
    uint64_t t_trigger_ns = 0;
    uint64_t t_first_rx_ns = 0, t_last_rx_ns = 0;
    std::map<uint16_t, pipeline::NodePart> parts;  // node -> what it sent
  };
  // The pending frame of seq, made when it is new (evicting the oldest at max_pending); nullptr when
  // seq is late (counted in `late`).
  Pending* slot(uint64_t seq, uint64_t t_trigger_ns, uint64_t now_ns, std::vector<MergedFrame>& out,
                uint64_t& late);
  void resolve(uint64_t seq, Pending& p, uint64_t now_ns, std::vector<MergedFrame>& out);
  // pulsed_only: false (counted in nc.unpulsed) when seq was not pulsed; t_trigger_ns becomes the
  // host's time of the pulse when it is known.
  bool trusted(uint64_t seq, uint64_t& t_trigger_ns, NodeCounters& nc) const;
  // Every running node sent its hull for seq, or a message about a later seq (its hull is not coming).
  bool complete(uint64_t seq, const Pending& p) const;
  // Resolves, in seq order, every pending frame that is complete or whose deadline passed at now_ns
  // (check_deadlines), appending the merged ones.
  void resolve_ready(uint64_t now_ns, bool check_deadlines, std::vector<MergedFrame>& out);
  // A message about seq from node (accepted): nothing older than seq will come from it.
  void note_seen(uint16_t node_id, uint64_t seq);

  AssemblerOptions opt_;
  std::map<uint16_t, bool> running_;
  std::map<uint16_t, uint64_t> seen_;  // per node: 1 + the highest seq it sent anything about (0: none)
  std::map<uint64_t, Pending> pending_;
  bool any_resolved_ = false;
  uint64_t max_resolved_ = 0;
  AssemblerStats stats_;
  std::vector<uint8_t> tmp_;  // merge scratch, reused
  std::map<uint16_t, std::vector<vc_stats>> stats_waiting_;
  bool any_pulse_ = false;
  uint64_t last_pulse_ = 0;
  struct PulseTime {
    uint64_t seq = 0, t_ns = 0;
  };
  std::vector<PulseTime> pulse_times_;  // ring of the last max_pending pulses, by seq % size
};

// The merged hull of a frame: the AND of its nodes' partial hulls into frame.rle, its occupied count,
// merged = true and t_merged_ns = now_ns. Throws std::runtime_error when the frame has no hull or the
// result does not cover voxel_count voxels.
void merge(pipeline::Frame& frame, std::vector<uint8_t>& scratch, uint64_t now_ns);

// AND of several RLE streams of the same grid into out (vc_rle_and_n; `scratch` is its output buffer,
// kept between calls so that a steady stream of frames does not allocate it again). One hull is
// validated and copied. Throws std::runtime_error on none, malformed input or different totals.
void intersect(const std::vector<const std::vector<uint8_t>*>& hulls, std::vector<uint8_t>& out,
               std::vector<uint8_t>& scratch);

}  // namespace vc::assemble
