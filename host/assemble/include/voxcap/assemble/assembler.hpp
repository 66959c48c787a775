// Frame assembly on the host: group the nodes' partial hulls by trigger seq and intersect them.
//
// A frame is merged as soon as every node that is currently running has sent its HULL for that seq,
// or when its deadline (trigger time + deadline) passes. The merge is the AND of the partial hulls,
// done on the RLE streams directly in one pass over all of them (vc_rle_and_n, no bitset in between).
// When a configured node is missing from a frame, the policy decides: Drop the frame, or merge what
// came and mark it degraded.
// A HULL for a frame that was already emitted is late: counted per node and discarded.
//
// Memory is bounded whatever the nodes do: at most max_pending frames wait; a newer seq beyond that
// evicts the oldest pending frame, which is resolved early as if its deadline had passed. Pure logic:
// no clocks (times are passed in), no sockets, no threads.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

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
  std::vector<uint8_t> rle;    // proto/ RLE (voxcap/rle.h)
};

struct MergedFrame {
  uint64_t seq = 0;
  uint64_t t_trigger_ns = 0;
  uint64_t t_first_rx_ns = 0, t_last_rx_ns = 0;  // first and last partial hull received
  uint64_t t_merged_ns = 0;                      // the `now` at which it was merged
  uint32_t grid_id = 0;
  uint64_t voxel_count = 0;
  uint64_t occupied = 0;
  bool degraded = false;                         // some configured node is missing
  std::vector<uint16_t> present, missing;        // node ids
  std::vector<uint8_t> rle;                      // the merged hull
};

struct AssemblerOptions {
  std::vector<uint16_t> nodes;   // the configured nodes (all of them, running or not)
  uint32_t grid_id = 0;
  uint64_t voxel_count = 0;
  uint64_t deadline_ns = 50'000'000;
  MissingPolicy policy = MissingPolicy::Drop;
  size_t max_pending = 64;       // frames waiting at most

  bool valid(std::string* why) const;
};

struct NodeCounters {
  uint64_t received = 0;  // partial hulls accepted
  uint64_t missing = 0;   // frames resolved without this node's hull
  uint64_t late = 0;      // hulls that came after their frame was resolved
  uint64_t rejected = 0;  // wrong grid, wrong size, duplicate, inconsistent RLE
};

struct AssemblerStats {
  uint64_t complete = 0;   // frames merged with every configured node
  uint64_t degraded = 0;   // frames merged with some node missing (policy Degraded)
  uint64_t dropped = 0;    // frames dropped for a missing node (policy Drop)
  uint64_t evicted = 0;    // frames resolved early because max_pending was reached
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

  // Resolves every frame whose deadline passed at now_ns (in seq order), appending merged ones.
  void poll(uint64_t now_ns, std::vector<MergedFrame>& out);

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
    std::map<uint16_t, std::vector<uint8_t>> hulls;  // node -> RLE
  };
  void resolve(uint64_t seq, Pending& p, uint64_t now_ns, std::vector<MergedFrame>& out);
  bool complete(const Pending& p) const;

  AssemblerOptions opt_;
  std::map<uint16_t, bool> running_;
  std::map<uint64_t, Pending> pending_;
  bool any_resolved_ = false;
  uint64_t max_resolved_ = 0;
  AssemblerStats stats_;
  std::vector<uint8_t> tmp_;  // merge scratch, reused
};

// AND of several RLE streams of the same grid into out (vc_rle_and_n; `scratch` is its output buffer,
// kept between calls so that a steady stream of frames does not allocate it again). One hull is
// validated and copied. Throws std::runtime_error on none, malformed input or different totals.
void intersect(const std::vector<const std::vector<uint8_t>*>& hulls, std::vector<uint8_t>& out,
               std::vector<uint8_t>& scratch);

}  // namespace vc::assemble
