// The fitted pose as the VMC protocol's bones (protocol.vmc.info: "/VMC/Ext/Root/Pos",
// "/VMC/Ext/Bone/Pos"): Unity's HumanBodyBones with each bone's local position and local rotation, in
// Unity's frame.
//
// Frames. VMC speaks Unity's frame: left-handed, Y up, metres; a humanoid avatar faces +Z with its left
// hand on -X. voxcap's world (DESIGN.md) is right-handed, z up, metres; the standard skeleton's rest
// T-pose faces -y with its left hand on +x (hw/body). One fixed map takes the second onto the first:
//
//   p_unity = M p_world,   M = [-1 0 0; 0 0 1; 0 -1 0]   (x_u = -x, y_u = z, z_u = -y)
//
// det M = -1: the reflection that changes the handedness. It keeps the floor the floor (y_u = z) and
// the rest T-pose the avatar's rest (facing -y -> +Z, left +x -> -X), so a performer facing -y in the
// rig faces +Z in Unity. A rotation R (world) becomes M R M^T, a proper rotation in Unity's axes; as a
// quaternion (w, v) it becomes (w, det(M) M v) = (w; v_x, -v_z, v_y) — the vector part of a rotation
// is an axial vector, so the reflection flips it once more (the same rotation seen in a mirror turns
// the other way). Unity's Quaternion is the usual Hamilton product acting on column vectors, sent in
// the order q.x q.y q.z q.w; we send w >= 0 and |q| = 1 (to float precision).
//
// Bones. The rotations are relative to a T-pose rest whose bone frames are all aligned with the world
// (every local rotation is the identity in the rest pose), which is what VRM 0.x avatars are
// normalised to and what EVMC4U, VSeeFace and the VMC add-ons apply as Transform.localRotation. They
// come from the one place the take (host/export) makes them: hw/body's standard humanoid with the
// fitted segment lengths (take::rest_skeleton, one per body version) and take::skeleton_pose's joint
// rotations, here re-expressed by M. So the VMC stream, take.bvh and joints.csv show the same motion.
// VMC bone <- standard joint: Hips <- hips, Spine <- spine (the pivot that carries the whole chest,
// which the model holds rigid), Chest (derived: identity, halfway up Spine -> Neck), Neck <- neck,
// Head <- head, {Left,Right}UpperArm/LowerArm/Hand <- shoulder/elbow/wrist, {Left,Right}UpperLeg/
// LowerLeg/Foot/Toes <- hip/knee/ankle/toe. The arms hang off Chest (no shoulder or UpperChest bones:
// a receiver leaves those at their rest, which keeps the sent rotations exact on a VRM 0.x avatar).
// Local positions are the performer's fitted skeleton in that hierarchy (Hips: its world position, the
// Root being the world origin with identity rotation, as model-less senders send it); receivers that
// apply positions beyond Hips to an avatar of other proportions will stretch it.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include "voxcap/body/skeleton.hpp"
#include "voxcap/pipeline/frame.hpp"

namespace vc::stream {

// ---- Frames ----
glm::dvec3 unity_from_world(const glm::dvec3& p_world);  // M p
glm::dmat3 unity_from_world(const glm::dmat3& R_world);  // M R M^T
struct UnityQuat {                                       // VMC's order: q.x q.y q.z q.w
  double x = 0, y = 0, z = 0, w = 1;
};
UnityQuat unity_quat(const glm::dmat3& R_world);  // of M R M^T; unit, w >= 0

// ---- Bones ----
enum class VmcBone : uint8_t {
  Hips,
  Spine,
  Chest,
  Neck,
  Head,
  LeftUpperArm,
  LeftLowerArm,
  LeftHand,
  RightUpperArm,
  RightLowerArm,
  RightHand,
  LeftUpperLeg,
  LeftLowerLeg,
  LeftFoot,
  LeftToes,
  RightUpperLeg,
  RightLowerLeg,
  RightFoot,
  RightToes,
};
inline constexpr int kVmcBoneCount = 19;
std::string_view vmc_bone_name(int b);  // Unity's HumanBodyBones name ("LeftUpperArm"); "?" out of range
int vmc_bone_parent(int b);             // the bone whose frame its local transform is in; -1: the Root

struct VmcTransform {
  glm::dvec3 p{0, 0, 0};  // local position, metres, Unity's axes (in the parent's frame)
  UnityQuat q;            // local rotation
};

struct VmcPose {
  VmcTransform root;                              // the world origin, identity ("root")
  std::array<VmcTransform, kVmcBoneCount> bones;  // by VmcBone
};

// Fitted poses -> VMC bones. Keeps the rest skeleton of the current body version: the fitting model is
// rigid within one version, so its first pose gives the lengths the take's medians would; a new
// body_version (the fitter re-initialised) makes a new rest.
class VmcPoser {
 public:
  // A valid pose (state != none) whose coordinates are all finite, else std::invalid_argument.
  VmcPose pose(const pipeline::Pose& p);
  uint64_t rests_built() const { return rests_; }
  const body::Skeleton& rest() const { return rest_; }

 private:
  bool have_rest_ = false;
  uint32_t version_ = 0;
  bool pelvis_triangle_ = true;
  body::Skeleton rest_;
  uint64_t rests_ = 0;
};

}  // namespace vc::stream
