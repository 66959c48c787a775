// The standard joints every motion maps to and every fit produces, their hierarchy, the tracked
// features, and the names the standard skeleton is exported under in BVH. World frame, metres.
#pragma once

#include <string_view>

namespace vc::body {

// joints.csv and the fitters use these names (joint_name). Parents precede children.
enum class Joint : int {
  hips,      // pelvis centre, the root
  spine,     // mid-back (thorax base); orients the chest
  neck,      // base of the neck
  head,      // centre of the head (the head feature)
  head_top,  // top of the head
  l_shoulder,
  l_elbow,
  l_wrist,
  l_hand_tip,
  r_shoulder,
  r_elbow,
  r_wrist,
  r_hand_tip,
  l_hip,
  l_knee,
  l_ankle,
  l_toe,  // l_toe: ball of the foot (toe joint)
  r_hip,
  r_knee,
  r_ankle,
  r_toe,
};
inline constexpr int kJointCount = 21;
std::string_view joint_name(Joint j);
std::string_view joint_name(int j);          // "?" out of range
int joint_from_name(std::string_view name);  // -1 if unknown
// The standard hierarchy: hips is the root (-1); head_top and the hand tips are end points
// (BVH End Sites), everything else carries a rotation.
int joint_parent(int j);
bool joint_is_end(int j);
// The joint's BVH name in exported files (BvhWriteOptions::standard_names): the MotionBuilder /
// Mixamo names that Blender's BVH importer and retargeting tools (Rokoko, Auto-Rig Pro, HumanIK)
// recognise: Hips, Spine, Neck, Head, LeftArm, LeftForeArm, LeftHand, LeftUpLeg, LeftLeg,
// LeftFoot, LeftToeBase, and the Right* twins. End points have no name in BVH ("" here).
std::string_view joint_bvh_name(int j);

// Tracked features (2D/3D): head -> Joint::head, hands -> wrists, feet -> ankles.
enum class Feature : int { head, l_hand, r_hand, l_foot, r_foot };
inline constexpr int kFeatureCount = 5;
std::string_view feature_name(Feature f);
Joint feature_joint(Feature f);

}  // namespace vc::body
