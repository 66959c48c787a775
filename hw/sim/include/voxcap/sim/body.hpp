// The synthetic performer: a small body description (height, segment lengths, limb radii),
// appearance presets, and the volumetric body — 20 "scaled capsules" (a capsule in a frame with per-axis
// radii: an ellipsoid when its core segment has zero length, a round capsule when the radii are equal) placed
// on the joints.
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "voxcap/body/joints.hpp"

namespace vc::sim {

// The standard joints and tracked features are the body library's (hw/body); the performer is
// built on them.
using body::Feature;
using body::feature_joint;
using body::feature_name;
using body::Joint;
using body::joint_from_name;
using body::joint_name;
using body::kFeatureCount;
using body::kJointCount;

// Body parts, one primitive each.
enum class Part : int {
  pelvis,
  abdomen,
  chest,
  shoulders,
  neck,
  head,
  l_upper_arm,
  l_forearm,
  l_hand,
  r_upper_arm,
  r_forearm,
  r_hand,
  l_thigh,
  l_shank,
  l_foot,
  l_toes,
  r_thigh,
  r_shank,
  r_foot,
  r_toes,
};
inline constexpr int kPartCount = 20;
std::string_view part_name(Part p);
enum class Material : int { skin, shirt, trousers };
Material part_material(Part p);
// The body part groups that accuracy figures report (the emulated rig's scorer, `voxcap bench
// silhouettes`): the 20 parts with head = head + neck, torso = pelvis, abdomen, chest and shoulder
// girdle, foot = foot + toes, and each upper arm, forearm, hand, thigh and shank on its own.
inline constexpr int kPartGroups = 14;
const std::array<std::string_view, kPartGroups>& part_group_names();  // "head", "torso", "l_upper_arm", ...
// The group of a Part index (0..19); std::out_of_range for anything else.
int part_group(int part);
// The parts that belong to a feature (a feature is occluded only by other parts).
bool part_of_feature(Part p, Feature f);

// Body dimensions (metres). Segment lengths shape the built-in motions' skeleton; a BVH clip
// brings its own segment lengths and only the radii and hand/foot/head sizes are used.
struct BodyDescription {
  double height_m = 1.75;
  // Segment lengths.
  double ankle_height_m = 0.08;    // ankle joint above the sole
  double shank_m = 0.43;           // knee -> ankle
  double thigh_m = 0.43;           // hip joint -> knee
  double pelvis_drop_m = 0.07;     // hips (root) -> hip joints, downwards
  double hip_half_width_m = 0.09;  // hips -> hip joint, sideways
  double hips_to_spine_m = 0.17;
  double spine_to_neck_m = 0.30;
  double shoulder_half_width_m = 0.18;  // spine axis -> shoulder joint, sideways
  double shoulder_drop_m = 0.04;        // shoulder joints below the neck base
  double upper_arm_m = 0.30;
  double forearm_m = 0.26;
  double hand_m = 0.19;          // wrist -> fingertips
  double foot_forward_m = 0.14;  // ankle -> ball of the foot, forwards
  double heel_back_m = 0.05;     // heel behind the ankle
  double toes_m = 0.06;          // ball -> toe tips
  // Sizes (half extents / radii).
  cv::Vec3d head_radii_m{0.078, 0.097, 0.115};  // sideways, front-back, vertical
  double neck_radius_m = 0.055;
  cv::Vec3d chest_radii_m{0.165, 0.11, 0.09};  // sideways, front-back, cap height
  cv::Vec3d abdomen_radii_m{0.145, 0.10, 0.08};
  cv::Vec3d pelvis_radii_m{0.17, 0.11, 0.10};
  double upper_arm_radius_m = 0.05;
  double forearm_radius_m = 0.04;
  double hand_half_width_m = 0.045;
  double hand_half_thickness_m = 0.017;
  double thigh_radius_m = 0.075;
  double shank_radius_m = 0.055;
  double shoulder_radius_m = 0.06;  // the shoulder girdle, shoulder to shoulder
  double foot_half_width_m = 0.045;
  double foot_half_height_m = 0.035;
  double toes_half_height_m = 0.022;

  // Head top above the floor when standing straight, from the segment lengths (== height_m).
  double standing_height_m() const;
  // Neck base -> head centre, what is left of height_m after the other segments.
  double neck_to_head_m() const;
  // All lengths and sizes scaled by height / 1.75 (the defaults are an adult of 1.75 m).
  static BodyDescription adult(double height_m);
  bool valid(std::string* why) const;
};

// Colours are linear-ish RGB albedo in [0, 255].
struct Appearance {
  std::string name;
  cv::Vec3d skin, shirt, trousers;
  cv::Vec3d albedo(Material m) const {
    return m == Material::skin ? skin : m == Material::shirt ? shirt : trousers;
  }
};
std::vector<Appearance> appearance_presets();
// Throws std::invalid_argument naming the known presets.
Appearance appearance_preset(std::string_view name);

// The body's pose in the world: every standard joint's position and its frame. The frame is the
// identity in the initialization pose (facing -y: x = the performer's left, z = up) and turns
// with the joint; it orients hands, feet and the head.
struct BodyPose {
  std::array<cv::Vec3d, kJointCount> p_world;
  std::array<cv::Matx33d, kJointCount> R_world;
  const cv::Vec3d& p(Joint j) const { return p_world[static_cast<std::size_t>(j)]; }
  const cv::Matx33d& R(Joint j) const { return R_world[static_cast<std::size_t>(j)]; }
};

// A scaled capsule: the points q (local: q = R^T (p - center)) with
// dist((qx/r0, qy/r1, qz/r2), segment (0,0,-h/r2)..(0,0,+h/r2)) <= 1.
struct Primitive {
  Part part = Part::pelvis;
  cv::Vec3d center{0, 0, 0};
  cv::Matx33d R = cv::Matx33d::eye();  // columns: local axes in the world
  cv::Vec3d radii{0.1, 0.1, 0.1};
  double half_length = 0;  // of the core segment along local z, metres
  // Derived (set by finalize()): world -> scaled-local linear map and its core half length.
  cv::Matx33d to_local = cv::Matx33d::eye();
  double core = 0;

  void finalize();
  bool contains(const cv::Vec3d& p_world) const;
  // First intersection of o + t*d (d need not be unit) with t > t_min; returns false if none.
  bool intersect(const cv::Vec3d& o, const cv::Vec3d& d, double t_min, double* t_hit) const;
  // Whether the segment a..b touches the primitive.
  bool touches_segment(const cv::Vec3d& a, const cv::Vec3d& b) const;
  // Outward unit normal at a surface point.
  cv::Vec3d normal(const cv::Vec3d& p_world) const;
  // The same with one end already mapped to scaled-local coordinates (to_local(p)), for loops that
  // cast many rays from one camera centre or towards one light.
  cv::Vec3d to_local_point(const cv::Vec3d& p_world) const { return to_local * (p_world - center); }
  bool intersect_from_local(const cv::Vec3d& o_local, const cv::Vec3d& d_world, double t_min,
                            double* t_hit) const;
  // Both ends local: the line o_local + t * d_local (d_local = to_local * d_world, so t is the same).
  bool intersect_local(const cv::Vec3d& o_local, const cv::Vec3d& d_local, double t_min, double* t_hit) const;
  bool touches_segment_from_local(const cv::Vec3d& a_local, const cv::Vec3d& b_world) const;
  // Axis-aligned world bounding box corners (the 8 corners of the local box, in world).
  std::array<cv::Vec3d, 8> box_corners() const;
};

// Heights that a skeleton brings with it (BVH clips differ from the description): the ankle
// joint's height above the sole when standing.
struct FootGeometry {
  double ankle_height_m = 0.08;
};

// The body's primitives for a pose (kPartCount of them, indexed by Part).
void build_primitives(const BodyPose& pose, const BodyDescription& body, const FootGeometry& feet,
                      std::vector<Primitive>* out);

}  // namespace vc::sim
