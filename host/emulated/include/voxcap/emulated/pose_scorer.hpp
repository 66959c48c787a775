// The fitted skeleton against the virtual rig's truth (voxcap demo, voxcap eval): a consumer stage of
// the host's pipeline that sees every frame (a block queue: it is cheap, microseconds a frame) and
// compares each frame's pose (pipeline::Pose, from the fitting stage) with hw/sim's true joints of the
// same frame (the virtual rig's frame = seq - origin).
//
// Mapping: the 15 PoseJoints carry hw/body's standard joint names (hips, neck, head, l_shoulder, ...,
// r_ankle) and are compared with the simulator's standard joints of the same names, one to one (the
// model's root, the head feature, is `head`, the head centre; its pelvis centre is `hips`).
//
// Counting: `frames` are the merged frames from the first pose on (the frames before it are the
// initialization, `init_frames`); `fitted_frames` those of them with a pose; a frame where a true joint
// (any of the 21, the head top, hand tips and toes included) lies outside the grid's box has part of
// the body outside the capture volume: counted in `frames_outside_volume` and left out of the errors.
// MPJPE: the mean over the scored frames of the mean joint distance; PA-MPJPE the same after the
// similarity transform (rotation, translation, scale) that best aligns the frame's 15 fitted joints
// with the truth (Procrustes, per frame). An arm inside the torso: a fitted elbow or wrist inside the
// true torso volume (the simulator's pelvis, abdomen, chest and shoulder-girdle primitives).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "voxcap/aggregator/aggregator.hpp"
#include "voxcap/export/take.hpp"
#include "voxcap/pipeline/frame.hpp"
#include "voxcap/pipeline/pipeline.hpp"
#include "voxcap/pipeline/timing.hpp"
#include "voxcap/rig/calibration.hpp"

namespace vc::sim {
class Scene;
}

namespace vc::emulated {

struct PoseAccuracy {
  uint64_t merged_frames = 0;          // frames the scorer saw from the origin on
  uint64_t init_frames = 0;            // before the first pose (initialization)
  uint64_t frames = 0;                 // from the first pose on
  uint64_t fitted_frames = 0;          // of those, with a pose (state not none)
  uint64_t frames_outside_volume = 0;  // of the fitted ones, part of the true body outside the grid's box
  uint64_t scored_frames = 0;          // fitted, body inside: what the errors average over
  uint64_t arm_in_torso_frames = 0;    // fitted frames with an elbow or wrist inside the true torso
  uint64_t predicted_frames = 0, reinitialized_frames = 0;  // by the pose's state
  double mpjpe_mm = 0, pa_mpjpe_mm = 0;
  std::array<double, pipeline::kPoseJointCount> per_joint_mm{};  // mean per PoseJoint
  double max_joint_mm = 0;                                       // the worst joint of any scored frame
  double fps = 0;  // poses per second: fitted frames over the span of their t_fitted_ns
  double latency_p50_ms = 0, latency_p99_ms = 0, latency_max_ms = 0;  // trigger -> pose, fitted frames
  // Where the fitted frames' time went (pipeline/timing.hpp): per segment over all and over the
  // slowest 1%; and each frame's stamps (kept with the poses, for voxcap demo --timing-csv).
  pipeline::LatencySplit latency_split;
  std::vector<pipeline::FrameTiming> timing;
  std::vector<take::PosedFrame>
      poses;  // every frame's pose by the virtual rig's frame number (kept when asked)
};

class PoseScorer : public pipeline::Stage {
 public:
  static constexpr pipeline::QueueOptions kQueue{1024, pipeline::Overflow::Block};
  // `scene_options` as the edges render (the motion, its rate and the body); `grid` the rig's voxel grid.
  // keep_poses: keep every frame's pose (PoseAccuracy::poses) for writing the take.
  PoseScorer(std::unique_ptr<sim::Scene> scene, const rig::VoxelGrid& grid, bool keep_poses);
  ~PoseScorer() override;
  std::string name() const override { return "pose-score"; }
  void configure(const pipeline::StageContext& ctx) override;
  void set_origin(uint64_t origin);
  void process(pipeline::Frame& frame) override;
  PoseAccuracy accuracy() const;

  // One frame's figures (exposed for tests): per-joint errors, metres, and the Procrustes-aligned mean.
  static void joint_errors(const pipeline::Pose& pose,
                           const std::array<std::array<double, 3>, pipeline::kPoseJointCount>& truth,
                           std::array<double, pipeline::kPoseJointCount>* err_m, double* pa_mean_m);

 private:
  std::unique_ptr<sim::Scene> scene_;
  rig::VoxelGrid grid_;
  bool keep_poses_;
  std::atomic<uint64_t> origin_{0};
  std::atomic<bool> started_{false};
  mutable std::mutex mu_;  // everything below
  PoseAccuracy acc_;
  bool seen_pose_ = false;
  double sum_mpjpe_ = 0, sum_pa_ = 0;
  std::array<double, pipeline::kPoseJointCount> sum_joint_{};
  aggregator::Latency latency_;  // trigger -> pose: bounded reservoir, as the host's own latency figures
  uint64_t t_first_ns_ = 0, t_last_ns_ = 0;
  pipeline::TimingLog timing_;  // the fitted frames' stamps
};

}  // namespace vc::emulated
