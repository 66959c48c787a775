// One frame of the rig, assembled by trigger `seq`: what every node sent for it, the merged hull, and
// (later) the pose. It travels down the host's stage pipeline (pipeline.hpp): the assembly stage
// creates it, the merge stage fills `rle`, later stages (triangulation, fitting) add their results,
// and the consumers at the end (recording, the emulated rig's scorer, a viewer) read it.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "voxcap/proto.h"

namespace vc::pipeline {

// One camera's silhouette as the edge sent it (SILHOUETTE, proto/SPEC.md): the edge's own mask after
// clean-up, exactly what it carved with, every `silhouette_every`-th frame (CONFIG). Pixels row-major,
// as a bitset in the RLE of voxcap/rle.h (bit x + width*y, LSB-first), at 1/scale of the camera's
// resolution (scale 1: the full mask; a scaled pixel is foreground when any pixel of its block is).
struct Silhouette {
  uint16_t camera = 0;             // the node's camera index
  uint16_t scale = 1;              // downscale factor, >= 1
  uint16_t width = 0, height = 0;  // of the (scaled) mask
  uint64_t foreground = 0;         // foreground pixels of the (scaled) mask
  std::vector<uint8_t> rle;        // width*height bits
};

// What one node sent for one frame.
struct NodePart {
  uint16_t node_id = 0;
  bool has_hull = false;
  uint64_t t_received_ns = 0;           // host CLOCK_MONOTONIC when its HULL was received
  uint64_t occupied = 0;                // occupied voxels of its partial hull, as the edge said
  std::vector<uint8_t> rle;             // its partial hull (proto/ RLE, voxcap/rle.h); empty without a HULL
  std::vector<vc_features> features;    // its FEATURES for this seq, one per camera, in arrival order
  std::vector<vc_stats> stats;          // STATS it sent while this frame was being assembled (not per seq)
  std::vector<Silhouette> silhouettes;  // its SILHOUETTEs for this seq, one per camera, when it sent any
};

// One tracked feature in 3D, from the triangulation stage (host/triangulate): where the views that
// report it agree. feature_id is the performer's own side (left_hand is the performer's left hand),
// agreed across views — not the edge's image-side label (host/triangulate/README.md, "Left and right").
enum class Feature3DState : uint8_t {
  Triangulated = 0,  // p_world holds the position (two or more consistent views)
  TooFewViews = 1,   // fewer than two views reported it (tracking/predicted, above the confidence floor)
  Inconsistent = 2,  // two or more views reported it but no two of them agree on one point
};
inline constexpr int kFeature3DStateCount = 3;
// "triangulated", "too_few_views", "inconsistent"; "?" for anything else.
inline const char* feature3d_state_name(Feature3DState s) {
  switch (s) {
    case Feature3DState::Triangulated:
      return "triangulated";
    case Feature3DState::TooFewViews:
      return "too_few_views";
    case Feature3DState::Inconsistent:
      return "inconsistent";
  }
  return "?";
}

struct Feature3D {
  uint16_t feature_id = 0;  // vc_feature_id
  Feature3DState state = Feature3DState::TooFewViews;
  std::array<double, 3> p_world{0, 0, 0};  // metres, world frame; only when Triangulated
  float confidence = 0;                    // 0..1 (host/triangulate/README.md, "Confidence")
  float reproj_px = 0;                     // RMS reprojection error over the views used, pixels
  std::vector<uint16_t> views;             // rig camera indices (calibration order) used, ascending
  // How far p_world lies outside the frame's merged hull, metres (0 inside; host/triangulate/README.md,
  // "On the body"); -1 when not known (no merged hull, the point outside the grid, not triangulated).
  float hull_clearance_m = -1;
  // A hand's or foot's left/right naming as the triangulation judged it (host/triangulate/README.md,
  // "Left and right"): false where it reported the naming untrusted (its confidence capped). True for
  // the head and where not known (features read back from a session older than format version 3). Recorded
  // in the session (FEATURES3D, host/record/README.md), so a re-fit sees what the live fit saw.
  bool name_trusted = true;
};

// The fitted skeleton of one frame, from the fitting stage (host/fit/README.md has the model and the
// rules). The 15 joints of the two-layer model, named like the standard joints of hw/body
// (joints.hpp) so that they compare with the virtual rig's truth one to one: the model's root (the
// head feature) is `head`, its pelvis centre `hips`.
enum class PoseJoint : uint8_t {
  hips,
  neck,
  head,
  l_shoulder,
  l_elbow,
  l_wrist,
  r_shoulder,
  r_elbow,
  r_wrist,
  l_hip,
  l_knee,
  l_ankle,
  r_hip,
  r_knee,
  r_ankle,
};
inline constexpr int kPoseJointCount = 15;
// The joint names above, as text ("hips", "l_wrist", ...): hw/body's standard joint names.
inline const char* pose_joint_name(int j) {
  static constexpr const char* kNames[kPoseJointCount] = {
      "hips",    "neck",  "head",   "l_shoulder", "l_elbow", "l_wrist", "r_shoulder", "r_elbow",
      "r_wrist", "l_hip", "l_knee", "l_ankle",    "r_hip",   "r_knee",  "r_ankle"};
  return j >= 0 && j < kPoseJointCount ? kNames[j] : "?";
}

enum class PoseState : uint8_t {
  None = 0,       // no pose: the stage has not run, or the body model is not initialized yet
  Fitted = 1,     // fitted to this frame's hull and features
  Predicted = 2,  // some limb had no usable feature: predicted from earlier frames, then fitted to the hull
  Reinitialized = 3,  // the fit had failed; the body model was initialized again on this frame
};

// "none", "fitted", "predicted", "reinitialized"; "?" for anything else.
inline const char* pose_state_name(PoseState s) {
  switch (s) {
    case PoseState::None:
      return "none";
    case PoseState::Fitted:
      return "fitted";
    case PoseState::Predicted:
      return "predicted";
    case PoseState::Reinitialized:
      return "reinitialized";
  }
  return "?";
}

struct Pose {
  PoseState state = PoseState::None;
  uint32_t body_version = 0;  // the body model in force (segment lengths); changes on re-initialization
  float confidence = 0;       // 0..1 (host/fit/README.md)
  // World frame (DESIGN.md), metres, by PoseJoint.
  std::array<std::array<double, 3>, kPoseJointCount> p_world{};
  // The torso's orientation in the world, row-major 3x3 whose columns are the performer's axes:
  // x toward the performer's right, y the way the performer faces, z up the spine (hips to neck);
  // right-handed. The limbs' orientation follows from the joint positions.
  std::array<double, 9> torso_R_world{1, 0, 0, 0, 1, 0, 0, 0, 1};
  uint64_t t_fitted_ns = 0;  // host CLOCK_MONOTONIC when the stage finished this frame
  bool valid() const { return state != PoseState::None; }
};

struct Frame {
  uint64_t seq = 0;                              // the trigger pulse counter
  uint64_t t_trigger_ns = 0;                     // host CLOCK_MONOTONIC of the pulse
  uint64_t t_first_rx_ns = 0, t_last_rx_ns = 0;  // first and last partial hull received
  uint64_t t_assembled_ns = 0;                   // left the assembler (complete, or its deadline passed)
  uint64_t t_merged_ns = 0;                      // the merged hull was ready
  // Each chain stage's (Pipeline::then, in chain order: StageContext::chain names them) start and end
  // of process() on this frame, host CLOCK_MONOTONIC, stamped by its StageRunner (0: not reached).
  // With the times above they say where a frame's time went: the wait in a stage's queue is its start
  // less the previous stage's end (the first's: t_assembled_ns).
  static constexpr size_t kTimedStages = 8;  // chain stages beyond these are not stamped
  std::array<uint64_t, kTimedStages> t_stage_start_ns{}, t_stage_end_ns{};
  uint32_t grid_id = 0;
  uint64_t voxel_count = 0;
  uint64_t occupied = 0;                   // occupied voxels of the merged hull
  bool degraded = false;                   // some configured node is missing
  bool merged = false;                     // `rle` and `occupied` hold the merged hull
  std::vector<uint16_t> present, missing;  // node ids, ascending
  std::vector<NodePart> nodes;             // one per node that sent anything for it, by node id
  std::vector<uint8_t> rle;                // the merged hull (AND of the partial hulls)

  // ---- The pose goes here. ----
  // The triangulation stage's 3D features: one per vc_feature_id (head, left_hand, ..., in id order)
  // once the stage ran, empty before it (or without it).
  std::vector<Feature3D> features3d;
  bool triangulated = false;  // the triangulation stage ran on this frame
  // The fitting stage's skeleton (host/fit): set once the stage ran on this frame.
  Pose pose;

  const NodePart* node(uint16_t id) const {
    for (const NodePart& p : nodes)
      if (p.node_id == id) return &p;
    return nullptr;
  }
};

// Frames move between stages by shared pointer: a stage in the chain owns the frame alone while it
// runs; the consumers at the end share it and only read it.
using FramePtr = std::shared_ptr<Frame>;

}  // namespace vc::pipeline
