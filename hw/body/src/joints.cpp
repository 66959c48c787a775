#include "voxcap/body/joints.hpp"

#include <array>

namespace vc::body {
namespace {

struct JointInfo {
  std::string_view name;
  Joint parent;               // itself for the root
  std::string_view bvh_name;  // "" for end points
};

constexpr std::array<JointInfo, kJointCount> kJoints = {{
    {"hips", Joint::hips, "Hips"},
    {"spine", Joint::hips, "Spine"},
    {"neck", Joint::spine, "Neck"},
    {"head", Joint::neck, "Head"},
    {"head_top", Joint::head, ""},
    {"l_shoulder", Joint::spine, "LeftArm"},
    {"l_elbow", Joint::l_shoulder, "LeftForeArm"},
    {"l_wrist", Joint::l_elbow, "LeftHand"},
    {"l_hand_tip", Joint::l_wrist, ""},
    {"r_shoulder", Joint::spine, "RightArm"},
    {"r_elbow", Joint::r_shoulder, "RightForeArm"},
    {"r_wrist", Joint::r_elbow, "RightHand"},
    {"r_hand_tip", Joint::r_wrist, ""},
    {"l_hip", Joint::hips, "LeftUpLeg"},
    {"l_knee", Joint::l_hip, "LeftLeg"},
    {"l_ankle", Joint::l_knee, "LeftFoot"},
    {"l_toe", Joint::l_ankle, "LeftToeBase"},
    {"r_hip", Joint::hips, "RightUpLeg"},
    {"r_knee", Joint::r_hip, "RightLeg"},
    {"r_ankle", Joint::r_knee, "RightFoot"},
    {"r_toe", Joint::r_ankle, "RightToeBase"},
}};

constexpr std::array<std::string_view, kFeatureCount> kFeatureNames = {"head", "l_hand", "r_hand", "l_foot",
                                                                       "r_foot"};

bool in_range(int j) {
  return j >= 0 && j < kJointCount;
}

}  // namespace

std::string_view joint_name(Joint j) {
  return joint_name(static_cast<int>(j));
}
std::string_view joint_name(int j) {
  return in_range(j) ? kJoints[static_cast<std::size_t>(j)].name : "?";
}

int joint_from_name(std::string_view name) {
  for (int j = 0; j < kJointCount; ++j) {
    if (kJoints[static_cast<std::size_t>(j)].name == name) return j;
  }
  return -1;
}

int joint_parent(int j) {
  if (!in_range(j)) return -1;
  const int p = static_cast<int>(kJoints[static_cast<std::size_t>(j)].parent);
  return p == j ? -1 : p;
}

bool joint_is_end(int j) {
  return in_range(j) && kJoints[static_cast<std::size_t>(j)].bvh_name.empty();
}

std::string_view joint_bvh_name(int j) {
  return in_range(j) ? kJoints[static_cast<std::size_t>(j)].bvh_name : "";
}

std::string_view feature_name(Feature f) {
  return kFeatureNames[static_cast<std::size_t>(f)];
}

Joint feature_joint(Feature f) {
  switch (f) {
    case Feature::head:
      return Joint::head;
    case Feature::l_hand:
      return Joint::l_wrist;
    case Feature::r_hand:
      return Joint::r_wrist;
    case Feature::l_foot:
      return Joint::l_ankle;
    default:
      return Joint::r_ankle;
  }
}

}  // namespace vc::body
