// The emulated rig: everything of a real rig on one machine (DESIGN.md, "Emulation").
//
// EmulatedRig writes a virtual rig (calibration from hw/sim's default ring, a rig.toml with a udp
// trigger), runs the host aggregator in this process and one `voxcap-edge` process per node with
// `sim` cameras and the udp trigger input, all on 127.0.0.1 with ports picked free. Merged frames can
// be scored against ground truth by the scorer, a consumer stage of the host's pipeline (a live one:
// it drops the oldest frames when behind, counted): the hull carved from the simulator's TRUE
// silhouettes (the same carving rule as the edges, then the AND over nodes — what a perfect
// subtraction would give) and the true body occupancy. Nodes can be killed and restarted (fault
// tests). Used by `voxcap rig --emulated`, the integration tests and `voxcap bench host`.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "voxcap/aggregator/aggregator.hpp"

namespace vc::emulated {

struct Options {
  int nodes = 3;                // edge processes (2 cameras each)
  std::string motion = "wave";  // built-in motion name or a BVH file
  int width = 640, height = 480;
  double rate_hz = 60;
  int grid = 64;  // voxels per axis over the 2.24 m cube of the volume
  double noise = 2.0;
  uint64_t seed = 1;
  std::string missing_policy = "degraded";  // drop | degraded
  double deadline_ms = 100;
  int truth_every = 10;               // score every k-th merged frame against ground truth (0: never)
  std::filesystem::path workdir;      // rig.yaml, rig.toml, edge logs; empty: a fresh temp folder
  std::filesystem::path edge_binary;  // empty: voxcap-edge beside this executable
  std::filesystem::path record_dir;   // record the session in a new folder below this; empty: no recording
  bool quiet = true;                  // edges log warnings only, host info lines suppressed
  // More stages for the host's pipeline (a viewer, a test's probe), added after the recorder and the
  // scorer, before the rig starts.
  std::function<void(pipeline::Pipeline&)> stages;

  bool valid(std::string* why) const;
};

struct Accuracy {
  uint64_t frames = 0;  // frames scored
  double agree = 0;     // mean fraction of all voxels equal to the true-silhouette hull
  double min_agree = 1;
  double iou_silhouette_hull = 0;  // mean IoU of occupied voxels vs the true-silhouette hull
  double body_recall = 0;          // mean fraction of true body voxels inside the merged hull
};

struct Result {
  aggregator::Report report;        // taken while the run was still going (before the edges stop)
  pipeline::PipelineReport stages;  // every stage once all drained at stop: what each finally saw
  Accuracy accuracy;
  uint64_t frames_wanted = 0;
  double wall_seconds = 0;
  long host_rss_start_kb = 0, host_rss_end_kb = 0;
  std::filesystem::path workdir;
  std::filesystem::path session_dir;  // the recorded session (with Options::record_dir)
};

class EmulatedRig {
 public:
  explicit EmulatedRig(Options options);  // throws std::invalid_argument
  ~EmulatedRig();                         // stops everything

  // Writes the rig, starts the host and the edges; returns when every node is running (throws
  // std::runtime_error after timeout_s, with the edges' last log lines).
  void start(double timeout_s = 30);
  // Runs until `frames` frames were merged (counted from the run's origin) or timeout_s passed.
  void run_frames(uint64_t frames, double timeout_s);
  void run_seconds(double seconds);
  Result stop();  // STOP, edges terminated (SIGTERM, then SIGKILL), host stopped

  // Fault injection.
  void kill_node(int k, int signal = 9);  // the edge process of node k (waits until it is gone)
  void signal_node(int k, int signal);    // e.g. SIGSTOP / SIGCONT: a stalled node
  void restart_node(int k);
  bool node_running(int k) const;
  uint64_t merged_frames() const;
  aggregator::Report report() const;
  uint16_t host_port() const;
  const std::filesystem::path& workdir() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Peak resident set of this process so far, and now (kB), from /proc/self/status.
long rss_kb();
long peak_rss_kb();

}  // namespace vc::emulated
