// Internals shared by motion.cpp (lead-in, BVH clips) and builtin_motions.cpp (procedural
// motions): the motion's implementation record and a small poser that sets joint rotations by
// aiming bones at directions. Skeleton maths is GLM (hw/body); the body pose handed to the
// renderer is converted to OpenCV types in body_pose_from, through body/glm_cv.hpp.
#pragma once

#include <functional>
#include <optional>
#include <vector>

#include "voxcap/sim/motion.hpp"

namespace vc::sim {
namespace detail {

// Where a standard joint comes from: p = lerp(p[a], p[b], w) + R_canon(frame_joint) * canon_offset.
struct JointSource {
  int a = -1;
  int b = -1;
  double w = 0;
  int frame_joint = -1;
  glm::dvec3 canon_offset{0, 0, 0};
};

}  // namespace detail

struct Motion::Impl {
  std::string name;
  MotionOptions options;
  BodyDescription body;
  Skeleton skeleton;  // metres
  FootGeometry feet;
  Pose init;                               // the initialization pose
  Pose first;                              // the motion's pose at tau = 0 (blend target)
  std::function<Pose(double tau)> sample;  // the motion proper, tau >= 0 seconds
  double length_s = 0;                     // clip length or one cycle
  std::optional<BvhMapping> bvh;
  std::array<detail::JointSource, kJointCount> sources;
  std::vector<glm::dmat3> canon;  // per skeleton joint: world rotation -> canonical frame
};

namespace detail {
using MotionData = Motion::Impl;

// Sets a pose joint by joint, parents first, keeping world rotations.
class Poser {
 public:
  Poser(const Skeleton& skeleton, const std::vector<int>& aim_child);
  void root(const glm::dvec3& position, const glm::dmat3& R_world);
  // Local rotation relative to the parent.
  void local(int joint, const glm::dmat3& R_local);
  // Rotate the joint (minimal rotation from the parent's frame, then `twist` radians about the
  // bone) so that its bone towards aim_child[joint] points along d_world.
  void aim(int joint, const glm::dvec3& d_world, double twist = 0);
  const glm::dmat3& world(int joint) const { return W_[static_cast<std::size_t>(joint)]; }
  Pose& pose() { return pose_; }

 private:
  const Skeleton& sk_;
  const std::vector<int>& aim_child_;
  Pose pose_;
  std::vector<glm::dmat3> W_;
};

// Built-in motions (builtin_motions.cpp): fills name, skeleton, feet, init, sample, length_s,
// sources, canon. Throws std::invalid_argument for an unknown name.
void make_builtin(const std::string& name, const BodyDescription& body, MotionData* out);

// Sole of the lowest foot point (heel, ball, toe tips) for a body pose, as the body primitives
// place the feet.
double lowest_sole_z(const BodyPose& pose, const BodyDescription& body, const FootGeometry& feet);

// Standard joints from a skeleton pose.
BodyPose body_pose_from(const MotionData& m, const Pose& pose);

// BVH clips (motion.cpp).
void make_bvh(const std::string& path, const MotionOptions& opt, const BodyDescription& body, MotionData* m);

}  // namespace detail
}  // namespace vc::sim
