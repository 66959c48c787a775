// Fitted pose -> VMC bones in Unity's frame. The frames, the quaternion convention and the bone table
// are explained in vmc_pose.hpp; the joint rotations are host/export's (take::skeleton_pose).
#include "voxcap/stream/vmc_pose.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "voxcap/body/joints.hpp"
#include "voxcap/export/take.hpp"

namespace vc::stream {
namespace {

using body::Joint;

// M: voxcap's world -> Unity (rows): x_u = -x, y_u = z, z_u = -y.
const glm::dmat3 kM = body::from_rows(-1, 0, 0, 0, 0, 1, 0, -1, 0);

struct BoneDef {
  std::string_view name;
  int parent;  // VmcBone, -1: the Root
  int joint;   // the standard joint whose local rotation it carries; -1: none (Chest)
};

constexpr int J(Joint j) {
  return static_cast<int>(j);
}
constexpr int B(VmcBone b) {
  return static_cast<int>(b);
}

constexpr std::array<BoneDef, kVmcBoneCount> kBones = {{
    {"Hips", -1, J(Joint::hips)},
    {"Spine", B(VmcBone::Hips), J(Joint::spine)},
    {"Chest", B(VmcBone::Spine), -1},
    {"Neck", B(VmcBone::Chest), J(Joint::neck)},
    {"Head", B(VmcBone::Neck), J(Joint::head)},
    {"LeftUpperArm", B(VmcBone::Chest), J(Joint::l_shoulder)},
    {"LeftLowerArm", B(VmcBone::LeftUpperArm), J(Joint::l_elbow)},
    {"LeftHand", B(VmcBone::LeftLowerArm), J(Joint::l_wrist)},
    {"RightUpperArm", B(VmcBone::Chest), J(Joint::r_shoulder)},
    {"RightLowerArm", B(VmcBone::RightUpperArm), J(Joint::r_elbow)},
    {"RightHand", B(VmcBone::RightLowerArm), J(Joint::r_wrist)},
    {"LeftUpperLeg", B(VmcBone::Hips), J(Joint::l_hip)},
    {"LeftLowerLeg", B(VmcBone::LeftUpperLeg), J(Joint::l_knee)},
    {"LeftFoot", B(VmcBone::LeftLowerLeg), J(Joint::l_ankle)},
    {"LeftToes", B(VmcBone::LeftFoot), J(Joint::l_toe)},
    {"RightUpperLeg", B(VmcBone::Hips), J(Joint::r_hip)},
    {"RightLowerLeg", B(VmcBone::RightUpperLeg), J(Joint::r_knee)},
    {"RightFoot", B(VmcBone::RightLowerLeg), J(Joint::r_ankle)},
    {"RightToes", B(VmcBone::RightFoot), J(Joint::r_toe)},
}};

size_t ix(int j) {
  return static_cast<size_t>(j);
}

bool finite(const pipeline::Pose& p) {
  for (const auto& q : p.p_world)
    for (double v : q)
      if (!std::isfinite(v)) return false;
  return true;
}

}  // namespace

glm::dvec3 unity_from_world(const glm::dvec3& p_world) {
  return kM * p_world;
}

glm::dmat3 unity_from_world(const glm::dmat3& R_world) {
  return kM * R_world * glm::transpose(kM);
}

UnityQuat unity_quat(const glm::dmat3& R_world) {
  const glm::dquat q = body::quat_from_matrix(unity_from_world(R_world));
  const double n = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  const double s = (q.w < 0 ? -1.0 : 1.0) / n;  // q and -q are one rotation: send w >= 0
  return {q.x * s, q.y * s, q.z * s, q.w * s};
}

std::string_view vmc_bone_name(int b) {
  return b >= 0 && b < kVmcBoneCount ? kBones[ix(b)].name : "?";
}

int vmc_bone_parent(int b) {
  return b >= 0 && b < kVmcBoneCount ? kBones[ix(b)].parent : -1;
}

VmcPose VmcPoser::pose(const pipeline::Pose& p) {
  if (!p.valid()) throw std::invalid_argument("vmc: no pose in this frame");
  if (!finite(p)) throw std::invalid_argument("vmc: the pose has a coordinate that is not finite");
  if (!have_rest_ || p.body_version != version_) {
    rest_ = take::rest_skeleton({&p}, &pelvis_triangle_);
    version_ = p.body_version;
    have_rest_ = true;
    ++rests_;
  }
  const body::Pose sp = take::skeleton_pose(rest_, pelvis_triangle_, p);
  auto off = [&](Joint j) { return rest_.joints[ix(J(j))].offset; };
  // Chest halfway up the Spine pivot's bone to the neck; its children's offsets from there.
  const glm::dvec3 chest = 0.5 * off(Joint::neck);

  VmcPose out;
  for (int b = 0; b < kVmcBoneCount; ++b) {
    const BoneDef& d = kBones[ix(b)];
    VmcTransform& t = out.bones[ix(b)];
    glm::dvec3 p_local;
    if (b == B(VmcBone::Hips))
      p_local = sp.root_position;  // the Root is the world origin
    else if (b == B(VmcBone::Chest))
      p_local = chest;
    else if (d.parent == B(VmcBone::Chest))
      p_local = rest_.joints[ix(d.joint)].offset - chest;  // neck and shoulders: in the Spine frame
    else
      p_local = rest_.joints[ix(d.joint)].offset;
    t.p = unity_from_world(p_local);
    t.q = d.joint < 0 ? UnityQuat{} : unity_quat(sp.local[ix(d.joint)]);
  }
  return out;
}

}  // namespace vc::stream
