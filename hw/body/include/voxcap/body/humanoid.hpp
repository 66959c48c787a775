// Any humanoid BVH clip mapped onto the standard joints, in metres in the world frame (z up, the
// performer facing -y in the clip's first frame): which file joint is which standard joint
// (naming conventions, else the hierarchy), the file's units, its up axis and facing, its frame
// rate, and the clip placed in the capture volume. The alias table is in hw/body/README.md.
//
//  - Names: every joint name is split into words (case changes, '_', '.', ' ', digits kept;
//    "prefix:", "Bip01" and a first word most joints share, like "Character1_", dropped), a side is read from
//    a left/right/l/r word or an l/r first letter glued to a known part ("lhumerus"), and limbs are found
//    from the hand and foot upwards: the wrist is the topmost hand/wrist joint of a side, the elbow the
//    nearest forearm/lowerarm/elbow/radius joint above it, the shoulder the nearest
//    arm/upperarm/humerus/shoulder joint above that (so MotionBuilder's LeftShoulder clavicle above LeftArm,
//    3dsMax's LeftCollar and SMPL's L_Collar are skipped); legs the same with foot/ankle,
//    leg/lowerleg/shin/calf/knee/tibia and upleg/upperleg/thigh/femur/hip. Covers cgspeed's MotionBuilder and
//    3dsMax CMU conversions, Mixamo, MotionBuilder HumanIK, Unity/Unreal humanoids, SMPL, 3ds Max Biped,
//    Blender and CMU ASF names. The neck is the topmost neck* joint above the head (else the head's parent);
//    spine is the joint between hips and neck nearest their midpoint. voxcap's own skeleton (the standard
//    joint names, as voxcap sim's truth/motion.bvh of a built-in motion) is convention "voxcap": its head
//    joint is the head centre and its End Sites are head_top and the hand tips.
//  - Hierarchy (convention "hierarchy"), where the names do not decide (Joint1..JointN, a hand named
//    otherwise): in the rest pose (any: T, A, arms down) a chain is long when its path is at least 8 % of
//    the pose's size and 35 % of the path from the hips to where it leaves; the hips are the first joint
//    from the root where three long chains leave; an extremity is a chain that never branches into long
//    chains again; the hips' two longest extremities are the legs, the chain with three or more the
//    spine; the extremities leaving the spine are the arms and the head (the one that continues the
//    hips->spine direction). On an arm or leg: the wrist or ankle is where the chain branches into parts
//    shorter than the bone before them (fingers, heel and toes), else the three joints whose segments
//    best have a human limb's proportions (forearm/upper arm 0.87, hand 0.34 of both; shank/thigh 1,
//    foot 0.23) and cover most of the chain; joints at their parent's place are no limb joints. The head
//    is the joint of its chain nearest a tenth of the body height (twice the leg) above the neck's base.
//    Left and right: up is hips->head, forward is where the feet point (ankle to toe, rest pose),
//    left = up x forward; a clip whose feet point nowhere (no toe joint or End Site) is refused.
//  - Refusal: a clip neither the names nor the hierarchy map throws one line: "<file>: not a humanoid
//    hierarchy: no joint for <standard joint> (looked for <names>); by the hierarchy: <what is missing>".
//  - Channels: joints may carry six channels; position channels whose values lie nearer the OFFSET than
//    zero replace it (BvhClip::positions_absolute), others add to it.
//  - Toes: a toe joint by name below the ankle, else the next joint on the ankle's longest chain (a toe
//    or an End Site); a foot with neither gets a made-up End Site ("<ankle>_toe") 0.16 leg lengths
//    forward and 0.07 down from the ankle in the rest pose.
//  - Units: cgspeed files (LHipJoint and RHipJoint) are CMU units, 0.056444 m/unit; otherwise a
//    rest pose 1.0-2.3 tall is metres, 100-230 centimetres, 1000-2300 millimetres, 50-85 inches, and
//    anything else is scaled so the rest pose is height_m tall. HumanoidOptions::scale overrides
//    (voxcap sim / rig --bvh-scale).
//  - Axes: the rest pose's hips->head axis becomes +z, then a rotation about z makes the performer
//    face -y in the clip's first frame (left hip and shoulder towards +x). Nothing assumes a T-pose.
//  - Placement: the root path's x/y bounding box is centred on the origin (then moved, when
//    HumanoidOptions::start_within_*_m ask it, so the first frame's root is that near the origin)
//    and the clip's lowest toe joint sits toe_height_m above the floor.
//    HumanoidOptions::keep_placement takes a file in the world frame as it is (hw/sim does so for a
//    dataset's own truth/motion.bvh).
//  - Frames: frame 0 is skipped when it is a converter's synthetic T-pose (all rotation values
//    integers, unlike frame 1). A frame time within one unit of its last written digit of 1/n
//    snaps to 1/n (".0083333" = 1/120). cgspeed files of CMU subjects 75, 88, 141, 143 (captured
//    at 60 fps, written as 120) use 1/60 s. HumanoidOptions::frame_time_s overrides.
// Limits: one person, a tree with two arms and two legs; a mirrored (left-handed) export maps
// with its sides as named (by the hierarchy: as its feet say); units of a nameless cgspeed file are
// not recognised (scaled to the height instead).
#pragma once

#include <array>
#include <string>

#include "voxcap/body/bvh.hpp"
#include "voxcap/body/joints.hpp"
#include "voxcap/body/skeleton.hpp"

namespace vc::body {

struct HumanoidOptions {
  double height_m = 1.75;       // a clip of unknown units is scaled to this rest-pose height
  double toe_height_m = 0.022;  // the clip's lowest toe joint sits this high above the floor
  double scale = 0;             // metres per file unit; 0: from the naming convention or the height
  double frame_time_s = 0;      // 0: the file's (snapped, see above)
  // The file is in the world frame already (z up, metres unless scale is given, facing and
  // position as they are): no turn, no centring, no floor (voxcap sim's own truth/motion.bvh).
  bool keep_placement = false;
  // The performer starts in the capture volume: after the centring, the path is moved as little as
  // needed for the first frame's root to lie within +-start_within_x_m / _y_m of the origin (0: that
  // axis stays centred). A clip that travels further than the volume (a 3.5 m walk across a 2.5 m
  // volume) then starts inside it, where a real take starts with the initialization pose, and
  // leaves it on the far side, instead of starting and ending outside it with its middle centred.
  double start_within_x_m = 0;
  double start_within_y_m = 0;

  bool valid(std::string* why) const;
};

// How a clip was placed in the world:
//   p_world = R_world_from_file * (scale * p_file) + t_world_m
// for every joint position p_file of the file's own forward kinematics; the clip's frame
// first_frame + tau / frame_time_s is shown at clip time tau.
struct BvhMapping {
  // "cgspeed-motionbuilder", "cgspeed-3dsmax", "voxcap", "generic" (by the names) or "hierarchy"
  std::string convention;
  std::string units;  // "cmu", "m", "cm", "mm", "in", "height" (scaled to height_m) or "given"
  double scale = 1;   // metres per file unit
  glm::dmat3 R_world_from_file{1.0};
  glm::dvec3 t_world_m{0, 0, 0};
  double frame_time_s = 0;  // the one used
  int first_frame = 0;      // 1 when frame 0 is a converter's synthetic T-pose
  int frames = 0;           // frames in the file
  // Per standard joint: the file joint whose position it is, or -1 when derived (head is the
  // midpoint of the Head joint and its End Site; head_top and the hand tips have no file joint,
  // except in voxcap's own skeleton; a made-up toe has none).
  std::array<int, kJointCount> file_joint{};
  std::array<std::string, kJointCount> file_joint_name{};
  // File joints the standard joints are aimed at: the head's End Site (or first child), the
  // first joint past each wrist away from it (-1 if none).
  int head_end = -1, l_hand_end = -1, r_hand_end = -1;
  // The joint of HumanoidClip::skeleton each standard joint is found at (head: the Head joint itself;
  // head_top and the hand tips: their parent's; a made-up toe: the End Site appended for it).
  std::array<int, kJointCount> anchor{};
};

struct HumanoidClip {
  BvhClip clip;  // as read (file units and axes)
  BvhMapping map;
  // The file's hierarchy in metres, file axes, root offset moved into poses; made-up toe End Sites
  // appended after the file's joints (poses of the file get identity rotations for them).
  Skeleton skeleton;
  // Stands the file's rest pose (all rotations identity) upright, facing -y: the world rotation of
  // the root in the rest pose as the world would show it.
  glm::dmat3 R_world_from_rest{1.0};

  // The clip's length after first_frame (seconds).
  double length_s() const;
  // Frame f of the file (first_frame..frames-1) placed in the world: FK of `skeleton` gives
  // p_world of the mapping.
  Pose frame_pose(int frame) const;
  // The clip at time tau >= 0 after first_frame: slerp between the two neighbouring frames; after
  // the end the last frame is held, or with loop the clip starts again.
  Pose sample(double tau, bool loop = false) const;
};

// Maps a parsed clip. Throws std::invalid_argument for invalid options and std::runtime_error
// naming `source` for a clip that is not a humanoid (the missing joint and what was looked for).
HumanoidClip map_humanoid(BvhClip clip, const std::string& source, const HumanoidOptions& options = {});
// Reads and maps a file (the file name's stem takes part in the frame-rate rule above).
HumanoidClip read_humanoid(const std::string& path, const HumanoidOptions& options = {});

}  // namespace vc::body
