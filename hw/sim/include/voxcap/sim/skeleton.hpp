// Articulated skeletons and their poses: a joint tree with offsets (metres, in the parent's frame),
// one local rotation per joint, forward kinematics, and the rotation helpers the motions need.
//
// Convention (the BVH one): p_parent = R_local * p_child + offset, so a joint's world position is
// p_j = p_parent + W_parent * offset_j and its world rotation W_j = W_parent * R_local_j. The root's
// world rotation is local[0] and its position root_position (+ its offset).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

namespace vc::sim {

struct SkeletonJoint {
  std::string name;
  int parent = -1;      // index into Skeleton::joints, -1 for the root (joint 0)
  cv::Vec3d offset{0, 0, 0};  // metres, in the parent's frame
  bool end_site = false;      // a BVH "End Site": no channels, never rotated
};

struct Skeleton {
  std::vector<SkeletonJoint> joints;  // parents come before children; joints[0] is the root

  int find(std::string_view name) const;  // -1 if absent (exact, case-sensitive)
  std::vector<int> children(int j) const;
  bool valid(std::string* why) const;
};

struct Pose {
  cv::Vec3d root_position{0, 0, 0};   // world, metres
  std::vector<cv::Matx33d> local;     // one per joint; local[0] is the root's world rotation
  // Optional per-joint translations added to the offsets (BVH position channels on non-root
  // joints); empty means none.
  std::vector<cv::Vec3d> translation;
};

// World positions and rotations of every joint.
void forward_kinematics(const Skeleton& skeleton, const Pose& pose, std::vector<cv::Vec3d>* p_world,
                        std::vector<cv::Matx33d>* R_world = nullptr);

// Identity rotations at the root position.
Pose rest_pose(const Skeleton& skeleton, const cv::Vec3d& root_position = {0, 0, 0});

// Rotation helpers (radians).
cv::Matx33d rot_x(double a);
cv::Matx33d rot_y(double a);
cv::Matx33d rot_z(double a);
cv::Matx33d rot_axis(const cv::Vec3d& axis, double a);  // axis need not be unit
// The smallest rotation taking direction `from` to direction `to` (neither need be unit).
cv::Matx33d rot_between(const cv::Vec3d& from, const cv::Vec3d& to);
// Re-orthonormalise (nearest rotation by polar decomposition through SVD).
cv::Matx33d orthonormalize(const cv::Matx33d& R);

// Unit quaternions (w, x, y, z) for interpolation.
cv::Vec4d quat_from_matrix(const cv::Matx33d& R);
cv::Matx33d matrix_from_quat(const cv::Vec4d& q);
// Spherical linear interpolation along the shorter arc, t in [0, 1].
cv::Matx33d slerp(const cv::Matx33d& a, const cv::Matx33d& b, double t);
// Per-joint slerp of rotations and lerp of the root position; poses of the same skeleton.
Pose blend(const Pose& a, const Pose& b, double t);

// Euler angles as a BVH writes them: order is a string of 3 axes ("ZYX" means R = Rz * Ry * Rx),
// degrees. euler_from_matrix inverts matrix_from_euler (for the Tait-Bryan orders).
cv::Matx33d matrix_from_euler(std::string_view order, const cv::Vec3d& degrees);
cv::Vec3d euler_from_matrix(std::string_view order, const cv::Matx33d& R);

}  // namespace vc::sim
