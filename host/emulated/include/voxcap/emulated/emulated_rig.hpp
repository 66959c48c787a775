// The emulated rig: everything of a real rig on one machine (DESIGN.md, "Emulation").
//
// EmulatedRig writes a virtual rig (calibration from hw/sim's default ring, a rig.toml with a udp
// trigger), runs the host aggregator in this process and one `voxcap-edge` process per node with
// `sim` cameras and the udp trigger input, all on 127.0.0.1 with ports picked free. Merged frames can
// be scored against ground truth by the scorer, a consumer stage of the host's pipeline (a live one:
// it drops the oldest frames when behind, counted): the hull carved from the simulator's TRUE
// silhouettes (the same carving rule as the edges, then the AND over nodes — what a perfect
// subtraction would give) and the true body occupancy, per body part; and the edges' own masks (their
// SILHOUETTE messages, which the rig asks for on every scored frame) against the true silhouettes and
// floor shadows. A second consumer stage, the feature scorer, scores the tracked features (the edges'
// 2D FEATURES and the host's 3D ones) on every frame. Nodes can be killed and restarted (fault tests). Used
// by `voxcap rig --emulated`, the integration tests and `voxcap bench host`.
#pragma once

#include <sys/types.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "voxcap/aggregator/aggregator.hpp"
#include "voxcap/emulated/pose_scorer.hpp"
#include "voxcap/sim/body.hpp"
#include "voxcap/sim/scene.hpp"

namespace vc::emulated {

struct Options {
  int nodes = 3;                // edge processes (2 cameras each)
  std::string motion = "wave";  // built-in motion name or a BVH file
  double bvh_scale = 0;         // metres per unit of a BVH motion; 0: detected (hw/body/README.md)
  int width = 640, height = 480;
  double rate_hz = 60;
  int grid = 64;  // voxels per axis over the 2.24 m cube of the volume
  double noise = 2.0;
  uint64_t seed = 1;
  std::string appearance = "default";  // hw/sim appearance preset (skin and clothes)
  std::string room = "default";        // hw/sim room preset (default | camouflage)
  std::string carve =
      "subpixel";            // the edges' carve rule (rig.toml [carving] rule): subpixel | footprint | centre
  int silhouette_scale = 1;  // the edges' masks sent for scoring, downscaled by 1..16
  std::string missing_policy = "degraded";  // drop | degraded
  double deadline_ms = 100;
  // Score the merged frames whose seq is a multiple of k against ground truth (0: never); the edges
  // send their masks for the same frames (rig.toml [silhouettes] every = k). With k > 0 the tracked
  // features are scored too, on every frame.
  int truth_every = 10;
  std::filesystem::path workdir;      // rig.yaml, rig.toml, edge logs; empty: a fresh temp folder
  std::filesystem::path edge_binary;  // empty: voxcap-edge beside this executable
  std::filesystem::path record_dir;   // record the session in a new folder below this; empty: no recording
  bool quiet = true;                  // edges log warnings only, host info lines suppressed
  log::Fn host_log;  // the host's lines (a test's capture); none: spdlog (errors only when quiet)
  // Authenticated control (proto/SPEC.md "Authentication"): a fresh rig key in the workdir (rig.key,
  // 0600), named in its rig.toml and given to every edge, so the demo runs the real path. false: the
  // keyless loopback rig.
  bool keyed = true;
  // Score every frame's fitted pose against the virtual rig's true joints (pose_scorer.hpp), keeping
  // the poses too with keep_poses (for writing the take).
  bool score_poses = false;
  bool keep_poses = false;
  // More stages for the host's pipeline (a viewer, a test's probe), added after the recorder and the
  // scorer, before the rig starts.
  std::function<void(pipeline::Pipeline&)> stages;

  bool valid(std::string* why) const;
};

// The body part groups of the per-part figures are hw/sim's (voxcap/sim/body.hpp).
using sim::kPartGroups;
using sim::part_group;
using sim::part_group_names;

// An edge mask against the truth, averaged over the scored frames that had it. A mask that does not
// fit its camera (size, scale, RLE, count) is counted as bad and not scored; a scored frame without it
// is counted as missing, never scored as perfect.
struct SilhouetteScore {
  uint64_t frames = 0;         // scored frames with this mask
  uint64_t missing = 0;        // scored frames without it
  uint64_t bad = 0;            // masks received that do not fit the camera
  double recall = 0;           // share of true body pixels the edge called foreground
  double precision = 0;        // share of the edge's foreground pixels that are body
  double shadow_kept = 0;      // share of true floor-shadow pixels the edge called foreground
  uint64_t shadow_frames = 0;  // frames with floor shadow in view (shadow_kept's average)
};

// The tracked features (head, hands, feet: vc_feature_id order) against the virtual rig's truth,
// scored on every merged frame of the run (the feature scorer, feature_scorer.cpp, has the rules).
inline constexpr int kTrackedFeatures = 5;
inline constexpr std::array<const char*, kTrackedFeatures> kTrackedFeatureNames = {
    "head", "left_hand", "right_hand", "left_foot", "right_foot"};

struct FeatureScore {
  // 3D (Frame::features3d against hw/sim's joints: head centre, wrists, ankles), over the frames where
  // at least two cameras see the part (Scene::features(...).visible): frames_visible of them.
  uint64_t frames_visible = 0;
  uint64_t frames_triangulated = 0;           // ... with a triangulated position: err3d's samples
  uint64_t frames_lost = 0;                   // ... without one, once it had been triangulated
  uint64_t frames_to_acquire = 0;             // ... without one, before its first triangulation (start-up)
  double err3d_p50_mm = 0, err3d_p95_mm = 0;  // NaN without samples
  // Losses: runs of consecutive lost-while-visible frames (frames where fewer than two cameras see the
  // part pause a run); a run still open at the end counts with its length so far.
  uint64_t losses = 0;
  uint64_t recover_max_frames = 0;
  double recover_p95_frames = 0;
  // Triangulated with confidence above the documented threshold (FeatureAccuracy::confident) and more
  // than 10 cm from the truth, in any frame.
  uint64_t confident_wrong = 0;
  // 2D: the edges' FEATURES in state tracking against the truth's 2D features while visible, per
  // camera frame (the edges' left/right are image-side labels: each camera's pair is paired with the
  // true pair the way that fits best).
  uint64_t views_visible = 0;                 // camera frames where the part is visible
  uint64_t views_untracked = 0;               // ... and the edge did not report it tracking
  double err2d_p50_px = 0, err2d_p95_px = 0;  // NaN without samples
};

struct FeatureAccuracy {
  uint64_t frames = 0;   // merged frames scored
  double confident = 0;  // the triangulation's documented threshold ([triangulation] confident)
  std::array<FeatureScore, kTrackedFeatures> features{};
};

struct Accuracy {
  uint64_t frames = 0;  // frames scored
  double agree = 0;     // mean fraction of all voxels equal to the true-silhouette hull
  double min_agree = 1;
  double iou_silhouette_hull = 0;  // mean IoU of occupied voxels vs the true-silhouette hull
  double body_recall = 0;          // mean fraction of true body voxels inside the merged hull
  // Mean share of merged-hull voxels within one voxel (26-neighbourhood) of a true body voxel, over
  // the frames with a non-empty hull (hull_precision_frames).
  double hull_precision = 0;
  uint64_t hull_precision_frames = 0;
  // Per part group (part_group_names()): mean share of its true voxels inside the merged hull, over
  // the frames where it had any.
  std::array<double, kPartGroups> part_recall{};
  std::array<uint64_t, kPartGroups> part_frames{};
  std::string reference_carve;  // the carve rule of the true-silhouette hull (the edges')
  // From the edges' real masks (SILHOUETTE messages), per rig camera (node k: cameras 2k and 2k+1),
  // and over all cameras (means over every scored frame and camera).
  std::vector<SilhouetteScore> cameras;
  SilhouetteScore silhouettes;
  // The tracked features, scored on every frame (not only every truth_every-th).
  FeatureAccuracy features;
};

struct Result {
  aggregator::Report report;  // taken while the run was still going (before the edges stop)
  // Taken once the edges and then the host stopped: pending frames flushed, every stage drained, the
  // recording closed. Its frames are what the session holds (the session line counts these).
  aggregator::Report final_report;
  pipeline::PipelineReport stages;  // every stage once all drained at stop: what each finally saw
  Accuracy accuracy;
  PoseAccuracy poses;   // with Options::score_poses
  uint64_t origin = 0;  // the run's origin seq: the virtual rig's frame 0
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

// The virtual rig as the edges render it (motion, rate, BVH scale, seed, noise, appearance, room) on
// the calibration `cal`: the one truth every scorer of the emulated rig compares with.
sim::SceneOptions truth_scene_options(const Options& o, const rig::Calibration& cal);

// Peak resident set of this process so far, and now (kB), from /proc/self/status.
long rss_kb();
long peak_rss_kb();

}  // namespace vc::emulated
