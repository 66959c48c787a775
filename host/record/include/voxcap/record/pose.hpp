// The fitted skeleton of a frame (pipeline::Pose, host/fit) in the session recording: a POSE record
// (the generic PoseRecord, no change to the bytes of the format) with the layout kPoseLayout.
//
// Layout "voxcap.pose15/1": joint_names = the 15 PoseJoint names (pipeline::pose_joint_name: hips,
// neck, head, l_shoulder, ..., r_ankle) in the first pose record of a session; values, 59 f64:
//   [0] state (pipeline::PoseState: 0 none, 1 fitted, 2 predicted, 3 reinitialized)
//   [1] body_version (an integer, 0 .. 2^32 - 1)
//   [2] confidence (0..1)
//   [3] t_fitted_ns >> 32, [4] t_fitted_ns & 0xFFFFFFFF (host CLOCK_MONOTONIC, split so that both
//       halves are exact in a double)
//   [5..13]  torso_R_world, row-major 3x3 (columns: the performer's right, forward, up)
//   [14..58] p_world of the 15 joints in PoseJoint order, x y z each, metres, world frame.
// The record stage writes one for every frame the fitting stage ran on (Pose::t_fitted_ns set), the
// initialization frames (state none) included.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "voxcap/pipeline/frame.hpp"
#include "voxcap/record/recorder.hpp"

namespace vc::record {

inline constexpr std::string_view kPoseLayout = "voxcap.pose15/1";
inline constexpr size_t kPoseValues = 5 + 9 + 3 * static_cast<size_t>(pipeline::kPoseJointCount);

// Fills *out (its vectors keep their capacity: no allocation once warmed up). with_names: also the 15
// joint names (the first pose record of a session); otherwise joint_names is left empty.
void to_record(uint64_t seq, const pipeline::Pose& pose, bool with_names, PoseRecord* out);

// The pose of a record of layout kPoseLayout. False with *why for any other layout, a wrong value
// count, joint names that are not the 15 PoseJoint names in order (when the record has names), a state
// out of range, a body_version that is not an integer in range, or a value that is not finite. A record
// read from a file is untrusted: nothing here trusts it further than these checks.
bool from_record(const PoseRecord& record, pipeline::Pose* out, std::string* why);

// A recorded frame as the pipeline's Frame again (seq, times, grid, nodes, the merged hull's RLE): what
// a replay or an offline re-fit starts from; features, poses and stats are added from their records.
pipeline::Frame frame_from_record(const FrameRecord& record);

// A triangulated feature (pipeline::Feature3D, host/triangulate) in a FEATURES3D record and back: the
// one mapping the record stage, a replay and an offline re-fit share. The record does not keep the
// clearance outside the hull (hull_clearance_m reads as -1, unknown); a state out of range (a record
// not checked by format::check) reads as inconsistent.
void to_record(const pipeline::Feature3D& feature, Features3DRecord::P* out);
pipeline::Feature3D feature3d_from_record(const Features3DRecord::P& record);

}  // namespace vc::record
