// A take: the fitted poses of a recording (or of a live run) as one animation of hw/body's standard
// humanoid, written as BVH (Blender and retargeting tools import it as is) and as joints.csv, both from
// the same forward kinematics, so the two agree to rounding.
//
// The skeleton: hw/body's 21 standard joints (Hips root; Spine, Neck, Head, LeftArm, LeftForeArm,
// LeftHand, LeftUpLeg, LeftLeg, LeftFoot, LeftToeBase and the Right* twins; head top and hand tips as
// End Sites). Its rest pose is a T-pose (facing -y, arms along +-x, legs straight down) with the fitted
// segment lengths: the model is rigid within one body_version, so each length is the median over that
// version's poses (upper arm, forearm, thigh, shank, neck to head, hips to neck, per side), and the
// hip and shoulder joints sit where the median over the poses puts them in the pelvis and chest frames.
// Joints the model does not fit are derived and say so: the Spine pivot 1 cm above the hips centre
// (the Spine bone then carries the whole chest, which the model holds rigid: neck and shoulders are
// exact whatever the pelvis does), the head top, hand tips and toes at the standard proportions of the fitted
// segments, the head turning with the neck, each hand with its forearm and each foot with its shank.
//
// Each frame: the rotation of every joint that points its bone at the fitted position of its child;
// the pelvis frame from its triangle (hips centre over the hip joints' midpoint, the hip line across;
// a model whose hips centre lies on the hip line uses the hips-to-neck axis instead), the chest frame
// from the Spine pivot to the neck and the shoulder line; each upper limb's
// roll puts the elbow (knee) hinge on its rest axis, so that the bend is a rotation about the forearm's
// (shank's) hinge; a straight limb keeps the smallest rotation from its parent. The fitted joints are
// reproduced exactly when the frame's segment lengths are the rest lengths (always within one
// body_version of a rigid fit); otherwise every bone keeps its fitted direction with the rest length.
//
// When the body model changes during the take (a re-initialization: a new body_version), the rest
// pose is the body version with the most posed frames, and the frames of the others are written with
// its lengths (their bone directions kept); the count is reported (Take::other_version_frames).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "voxcap/body/bvh.hpp"
#include "voxcap/body/skeleton.hpp"
#include "voxcap/pipeline/frame.hpp"

namespace vc::take {

// One frame of the input: its frame number (the virtual rig's frame, or seq - origin of a recording)
// and its pose (state none: no pose for this frame).
struct PosedFrame {
  int64_t frame = 0;
  pipeline::Pose pose;
};

struct Take {
  body::Skeleton skeleton;        // the standard skeleton (body::is_standard), T-pose with the fitted lengths
  uint32_t body_version = 0;      // whose lengths the rest pose has
  bool pelvis_triangle = true;    // the pelvis frame from its triangle (else the hips-to-neck axis)
  int64_t first_frame = 0;        // frame number of the take's first frame (BVH frame k is first_frame + k)
  std::vector<body::Pose> poses;  // one per frame from the first pose to the last, consecutive
  // Per take frame: the pose's state, or PoseState::None where the frame had no pose and the previous
  // pose is held (in the BVH; joints.csv leaves such frames out).
  std::vector<pipeline::PoseState> states;
  std::vector<uint32_t> body_versions;  // per take frame (of the held pose where held)

  // How the input was used (for the caller to report; nothing is dropped silently).
  uint64_t before_first = 0;          // input frames before the first pose (initialization): left out
  uint64_t after_last = 0;            // input frames after the last pose: left out
  uint64_t held = 0;                  // take frames without a pose (in the input or missing from it)
  uint64_t missing = 0;               // of those, frame numbers the input did not have at all
  uint64_t other_version_frames = 0;  // posed frames of another body version than the rest pose's
};

// Builds the take from frames in increasing frame number (duplicates: the last wins). Throws
// std::invalid_argument when no frame has a pose, or a pose holds a coordinate that is not finite.
Take make_take(const std::vector<PosedFrame>& frames);

// The rest skeleton for one body version's poses (make_take's), and the standard-skeleton pose for
// one fitted pose (root position and local rotations) on it. Exposed for the tests.
body::Skeleton rest_skeleton(const std::vector<const pipeline::Pose*>& poses, bool* pelvis_triangle);
body::Pose skeleton_pose(const body::Skeleton& skeleton, bool pelvis_triangle, const pipeline::Pose& pose);

struct WriteOptions {
  double frame_time_s = 1.0 / 60;  // the recording's frame period
  double units_per_metre = 1.0;    // BVH only: 1 metres (default), 100 centimetres
  bool valid(std::string* why) const;
};

// BVH of the take: body::BvhWriteOptions::blender() (Y up, the performer facing +Z, standard names),
// in metres or centimetres. Throws std::runtime_error naming the path on I/O errors.
void write_bvh(const std::filesystem::path& path, const Take& take, const WriteOptions& options);

// joints.csv, long form: "frame,joint,x,y,z,state,fitted" — one row per frame with a pose and per
// named BVH joint (18: the 21 standard joints less the 3 End Sites: head top, hand tips), joint names as in
// the BVH, x y z in metres in the world frame (z up) from the same forward kinematics as the BVH, state as
// pipeline::pose_state_name, fitted 1 for the 15 joints the model fits and 0 for the derived ones
// (Spine, LeftToeBase, RightToeBase). Returns the rows written.
uint64_t write_joints_csv(const std::filesystem::path& path, const Take& take);

// World positions of every skeleton joint of take frame k (forward kinematics), metres.
std::vector<glm::dvec3> take_positions(const Take& take, size_t k);

}  // namespace vc::take
