// Articulated skeletons and their poses (GLM, double precision): a joint tree with offsets (in the
// parent's frame), one local rotation per joint, forward kinematics, the rotation helpers motions
// and fitting need, and the standard skeleton built from segment lengths.
//
// Convention (the BVH one): p_parent = R_local * p_child + offset, so a joint's world position is
// p_j = p_parent + W_parent * offset_j and its world rotation W_j = W_parent * R_local_j. The root's
// world rotation is local[0] and its position root_position (+ its offset). Matrices are GLM's
// (column-major storage, R[c][r]; R * v is the usual product).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

namespace vc::body {

struct SkeletonJoint {
  std::string name;
  int parent = -1;             // index into Skeleton::joints, -1 for the root (joint 0)
  glm::dvec3 offset{0, 0, 0};  // in the parent's frame (metres, or a file's units)
  bool end_site = false;       // a BVH "End Site": no channels, never rotated
};

struct Skeleton {
  std::vector<SkeletonJoint> joints;  // parents come before children; joints[0] is the root

  int find(std::string_view name) const;  // -1 if absent (exact, case-sensitive)
  std::vector<int> children(int j) const;
  bool valid(std::string* why) const;
};

struct Pose {
  glm::dvec3 root_position{0, 0, 0};  // world
  std::vector<glm::dmat3> local;      // one per joint; local[0] is the root's world rotation
  // Optional per-joint translations added to the offsets (BVH position channels on non-root
  // joints); empty means none.
  std::vector<glm::dvec3> translation;
};

// World positions and rotations of every joint. Throws std::invalid_argument when the pose does
// not fit the skeleton.
void forward_kinematics(const Skeleton& skeleton, const Pose& pose, std::vector<glm::dvec3>* p_world,
                        std::vector<glm::dmat3>* R_world = nullptr);

// Identity rotations at the root position.
Pose rest_pose(const Skeleton& skeleton, const glm::dvec3& root_position = {0, 0, 0});

// The bone vector from joint j to its descendant e with identity rotations in between, in j's
// frame. Throws std::logic_error when e is not below j.
glm::dvec3 rest_vector(const Skeleton& skeleton, int j, int e);

// Rotation helpers (radians).
glm::dmat3 rot_x(double a);
glm::dmat3 rot_y(double a);
glm::dmat3 rot_z(double a);
glm::dmat3 rot_axis(const glm::dvec3& axis, double a);  // axis need not be unit
// The smallest rotation taking direction `from` to direction `to` (neither need be unit).
glm::dmat3 rot_between(const glm::dvec3& from, const glm::dvec3& to);
// A matrix from its rows (GLM constructors take columns).
glm::dmat3 from_rows(double a00, double a01, double a02, double a10, double a11, double a12, double a20,
                     double a21, double a22);

// Unit quaternions (glm::dquat is (w, x, y, z)) for interpolation.
glm::dquat quat_from_matrix(const glm::dmat3& R);
glm::dmat3 matrix_from_quat(const glm::dquat& q);
// Spherical linear interpolation along the shorter arc, t in [0, 1].
glm::dmat3 slerp(const glm::dmat3& a, const glm::dmat3& b, double t);
// Per-joint slerp of rotations and lerp of the root position; poses of the same skeleton.
Pose blend(const Pose& a, const Pose& b, double t);

// Euler angles as a BVH writes them: order is a string of 3 axes ("ZYX" means R = Rz * Ry * Rx),
// degrees. euler_from_matrix inverts matrix_from_euler (for the Tait-Bryan orders).
glm::dmat3 matrix_from_euler(std::string_view order, const glm::dvec3& degrees);
glm::dvec3 euler_from_matrix(std::string_view order, const glm::dmat3& R);

// Segment lengths of the standard skeleton (metres), in the initialization pose: facing -y,
// x = the performer's left, z up.
struct StandardSegments {
  double hips_to_spine_m = 0.17;
  double spine_to_neck_m = 0.30;
  double neck_to_head_m = 0.165;        // neck base -> head centre
  double head_to_top_m = 0.115;         // head centre -> top
  double shoulder_half_width_m = 0.18;  // spine axis -> shoulder joint, sideways
  double shoulder_drop_m = 0.04;        // shoulder joints below the neck base
  double upper_arm_m = 0.30;
  double forearm_m = 0.26;
  double hand_m = 0.19;            // wrist -> fingertips
  double hip_half_width_m = 0.09;  // hips -> hip joint, sideways
  double pelvis_drop_m = 0.07;     // hips -> hip joints, downwards
  double thigh_m = 0.43;
  double shank_m = 0.43;
  double foot_forward_m = 0.14;        // ankle -> ball of the foot, forwards
  double ankle_to_toe_drop_m = 0.058;  // ankle -> ball of the foot, downwards

  bool valid(std::string* why) const;
};
// One joint per Joint (same index and name, joint_parent hierarchy), offsets in the
// initialization pose (arms spread along +-x, legs straight down); head_top and the hand tips are
// End Sites. Throws std::invalid_argument for invalid segments.
Skeleton standard_skeleton(const StandardSegments& segments);
// Whether a skeleton has the standard joints, names and hierarchy (what standard_skeleton makes).
bool is_standard(const Skeleton& skeleton);

}  // namespace vc::body
