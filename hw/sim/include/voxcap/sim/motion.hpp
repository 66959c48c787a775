// Motions that drive the performer: built-in procedural motions on the standard skeleton, or a
// BVH clip mapped onto the standard joints (hw/body's humanoid mapping). Every motion starts with the
// initialization pose of the method (facing the front cameras at -y, legs together, arms spread
// horizontally), held for lead_hold_s and blended (slerp per joint) into the motion over lead_blend_s.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "voxcap/body/humanoid.hpp"
#include "voxcap/body/skeleton.hpp"
#include "voxcap/sim/body.hpp"

namespace vc::sim {

// Skeletons, poses and the BVH mapping are the body library's (hw/body, GLM types).
using body::BvhMapping;
using body::Pose;
using body::Skeleton;

struct MotionOptions {
  std::string source = "walk";  // a built-in name (builtin_motion_names()) or a path ending in .bvh
  double fps = 60;              // output (camera) rate; frame f is at t = f / fps
  double lead_hold_s = 1.0;     // initialization pose
  double lead_blend_s = 0.5;    // blend into the motion's first pose
  double bvh_frame_time_s = 0;  // 0: the file's (see README: CMU subjects captured at 60 fps)
  double bvh_scale = 0;         // metres per BVH unit; 0: by naming convention (README)
  bool loop = false;            // BVH: loop the clip instead of holding its last frame
  // BVH: the performer starts (lead-in and first frame) at most this far from the volume's axis
  // along x (their left, the init pose's spread arms) and y (where they face), the path otherwise
  // centred (hw/body's HumanoidOptions::start_within_*_m): the default 2.5 m volume's half size
  // less half the init pose's arm span (0.9 m at 1.75 m) in x, less the body's depth and feet
  // (0.35 m) in y. A clip travelling further than the volume then starts inside it and is counted
  // in frames_outside_volume once it leaves, instead of taking the init pose outside. 0: centred.
  double bvh_start_within_x_m = 0.35;
  double bvh_start_within_y_m = 0.9;

  bool valid(std::string* why) const;
};

class Motion {
 public:
  // Throws std::invalid_argument for an unknown built-in name or invalid options, and
  // std::runtime_error for an unreadable or non-humanoid BVH (message names the file).
  static Motion create(const MotionOptions& options, const BodyDescription& body);

  const std::string& name() const;
  double fps() const;
  int lead_in_frames() const;  // frames before the motion proper (hold + blend)
  int natural_frames() const;  // lead-in + the clip (BVH) or + one cycle (built-in)
  // The body's pose at a frame (any frame >= 0; BVH clips hold their last frame or loop).
  BodyPose body_pose(int frame) const;
  // The underlying skeleton (metres, world-aligned root) and its pose.
  const Skeleton& skeleton() const;
  Pose skeleton_pose(int frame) const;
  const FootGeometry& feet() const;
  const BodyDescription& body() const;
  // nullptr for built-in motions.
  const BvhMapping* bvh() const;
  // BVH clip time at a frame (seconds from first_frame; negative during the lead-in).
  double clip_time(int frame) const;

  struct Impl;

 private:
  explicit Motion(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}
  std::shared_ptr<const Impl> impl_;
};

struct BuiltinMotion {
  std::string name;
  std::string description;
  double cycle_s;  // one cycle of the motion (after the lead-in)
};
const std::vector<BuiltinMotion>& builtin_motions();

// The standard skeleton of the built-in motions (body::standard_skeleton): one joint per Joint
// (same index), offsets from the body description's segment lengths in the initialization pose
// (world axes: x left of the performer, -y forward, z up); head_top and the hand tips are End Sites.
body::StandardSegments standard_segments(const BodyDescription& body);
Skeleton standard_skeleton(const BodyDescription& body);

}  // namespace vc::sim
