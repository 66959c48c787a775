// The VMC pose: voxcap's world -> Unity's frame (a reflection: positions, rotation matrices and
// quaternions), and fitted poses -> bones: the rest pose gives identity rotations everywhere, a known
// pose gives the quaternions worked out by hand, any rigid pose is reproduced by the bones' own forward
// kinematics in Unity's frame.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/matrix.hpp>

#include "voxcap/body/joints.hpp"
#include "voxcap/stream/vmc_pose.hpp"

namespace vc::stream {
namespace {

using glm::dmat3;
using glm::dvec3;
constexpr double kPi = std::numbers::pi;

// The 15 fitted joints of standard-joint positions (the take's tests do the same).
pipeline::Pose pose_of(const std::vector<dvec3>& p_std, uint32_t version = 1) {
  pipeline::Pose out;
  out.state = pipeline::PoseState::Fitted;
  out.body_version = version;
  for (int j = 0; j < pipeline::kPoseJointCount; ++j) {
    const int b = body::joint_from_name(pipeline::pose_joint_name(j));
    const dvec3& q = p_std.at(static_cast<size_t>(b));
    out.p_world[static_cast<size_t>(j)] = {q.x, q.y, q.z};
  }
  return out;
}

// A body whose chest pivots just above the hips (the take's model: its Spine pivot is 1 cm up), posed
// by local rotations per standard joint, at a root position.
struct Body {
  body::Skeleton sk;
  Body() {
    body::StandardSegments seg;
    seg.hips_to_spine_m = 0.01;
    seg.spine_to_neck_m = 0.5;
    sk = body::standard_skeleton(seg);
  }
  pipeline::Pose posed(const body::Pose& bp, uint32_t version = 1) const {
    std::vector<dvec3> p;
    body::forward_kinematics(sk, bp, &p);
    return pose_of(p, version);
  }
  body::Pose rest(const dvec3& root = {0.2, -0.3, 0.95}) const { return body::rest_pose(sk, root); }
};

void expect_quat(const UnityQuat& q, double x, double y, double z, double w, const char* what) {
  EXPECT_NEAR(q.x, x, 1e-9) << what;
  EXPECT_NEAR(q.y, y, 1e-9) << what;
  EXPECT_NEAR(q.z, z, 1e-9) << what;
  EXPECT_NEAR(q.w, w, 1e-9) << what;
}

void expect_identity(const UnityQuat& q, const char* what) {
  expect_quat(q, 0, 0, 0, 1, what);
}

int bone(VmcBone b) {
  return static_cast<int>(b);
}
const VmcTransform& at(const VmcPose& p, VmcBone b) {
  return p.bones[static_cast<size_t>(b)];
}

TEST(UnityFrame, PositionsAreMirroredIntoYUpWithTheRestPoseFacingPlusZ) {
  // x_u = -x, y_u = z, z_u = -y.
  const dvec3 u = unity_from_world(dvec3(1, 2, 3));
  EXPECT_DOUBLE_EQ(u.x, -1);
  EXPECT_DOUBLE_EQ(u.y, 3);
  EXPECT_DOUBLE_EQ(u.z, -2);
  // Up stays up, the performer's front (-y) is Unity's forward (+Z), the left hand (+x) is on -X.
  EXPECT_EQ(unity_from_world(dvec3(0, 0, 1)), dvec3(0, 1, 0));
  EXPECT_EQ(unity_from_world(dvec3(0, -1, 0)), dvec3(0, 0, 1));
  EXPECT_EQ(unity_from_world(dvec3(1, 0, 0)), dvec3(-1, 0, 0));
  // A reflection (the handedness changes), but rotations stay proper rotations.
  const dmat3 M(unity_from_world(dvec3(1, 0, 0)), unity_from_world(dvec3(0, 1, 0)),
                unity_from_world(dvec3(0, 0, 1)));
  EXPECT_DOUBLE_EQ(glm::determinant(M), -1.0);
  const dmat3 R = body::rot_axis({0.3, -0.5, 0.8}, 1.1);
  EXPECT_NEAR(glm::determinant(unity_from_world(R)), 1.0, 1e-12);
  // M R M^T applied to M p is M (R p): the same motion seen in Unity's axes.
  const dvec3 p(0.4, -0.7, 1.3);
  const dvec3 a = unity_from_world(R) * unity_from_world(p), b = unity_from_world(R * p);
  EXPECT_NEAR(glm::length(a - b), 0, 1e-12);
}

TEST(UnityFrame, QuaternionsKeepWAndMirrorTheAxis) {
  // A turn about world z (up) by +t, counter-clockwise seen from above in a right-handed frame, is a
  // turn about Unity's Y by -t: (w; v) -> (w; v_x, -v_z, v_y).
  const double t = 0.7;
  expect_quat(unity_quat(body::rot_z(t)), 0, -std::sin(t / 2), 0, std::cos(t / 2), "about z");
  expect_quat(unity_quat(body::rot_x(t)), std::sin(t / 2), 0, 0, std::cos(t / 2), "about x");
  expect_quat(unity_quat(body::rot_y(t)), 0, 0, std::sin(t / 2), std::cos(t / 2), "about y");
  // Any rotation: unit, w >= 0, and the rule above against glm's own quaternion of the world rotation.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int k = 0; k < 200; ++k) {
    const dmat3 R = body::rot_axis({u(rng), u(rng), u(rng) + 1e-3}, 3.1 * u(rng));
    const UnityQuat q = unity_quat(R);
    EXPECT_NEAR(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w, 1.0, 1e-12);
    EXPECT_GE(q.w, 0.0);
    glm::dquat w = body::quat_from_matrix(R);
    if (w.w < 0) w = -w;
    EXPECT_NEAR(q.x, w.x, 1e-9);
    EXPECT_NEAR(q.y, -w.z, 1e-9);
    EXPECT_NEAR(q.z, w.y, 1e-9);
    EXPECT_NEAR(q.w, w.w, 1e-9);
  }
  expect_identity(unity_quat(dmat3(1.0)), "identity");
}

TEST(VmcBones, UnityNamesParentsFirst) {
  const char* names[] = {"Hips",          "Spine",         "Chest",        "Neck",          "Head",
                         "LeftUpperArm",  "LeftLowerArm",  "LeftHand",     "RightUpperArm", "RightLowerArm",
                         "RightHand",     "LeftUpperLeg",  "LeftLowerLeg", "LeftFoot",      "LeftToes",
                         "RightUpperLeg", "RightLowerLeg", "RightFoot",    "RightToes"};
  ASSERT_EQ(std::size(names), static_cast<size_t>(kVmcBoneCount));
  for (int b = 0; b < kVmcBoneCount; ++b) {
    EXPECT_EQ(vmc_bone_name(b), names[b]);
    EXPECT_LT(vmc_bone_parent(b), b);  // parents first; Hips is the Root's child (-1)
  }
  EXPECT_EQ(vmc_bone_parent(bone(VmcBone::Hips)), -1);
  EXPECT_EQ(vmc_bone_parent(bone(VmcBone::LeftUpperArm)), bone(VmcBone::Chest));
  EXPECT_EQ(vmc_bone_parent(bone(VmcBone::RightUpperLeg)), bone(VmcBone::Hips));
  EXPECT_EQ(vmc_bone_name(kVmcBoneCount), "?");
}

TEST(VmcPoser, TheRestPoseIsIdentityEverywhereWithTheHipsWhereThePerformerIs) {
  const Body b;
  VmcPoser poser;
  const VmcPose v = poser.pose(b.posed(b.rest({0.2, -0.3, 0.95})));
  expect_identity(v.root.q, "root");
  EXPECT_EQ(v.root.p, dvec3(0, 0, 0));
  for (int k = 0; k < kVmcBoneCount; ++k) expect_identity(v.bones[static_cast<size_t>(k)].q, "rest");
  const dvec3 hips = at(v, VmcBone::Hips).p;
  EXPECT_NEAR(hips.x, -0.2, 1e-12);
  EXPECT_NEAR(hips.y, 0.95, 1e-12);
  EXPECT_NEAR(hips.z, 0.3, 1e-12);
  // Local positions: the fitted lengths in Unity's axes: the left arm out along -X, the legs down -Y.
  const body::StandardSegments seg;
  const dvec3 fore = at(v, VmcBone::LeftLowerArm).p;
  EXPECT_NEAR(fore.x, -seg.upper_arm_m, 1e-9);
  EXPECT_NEAR(fore.y, 0, 1e-9);
  EXPECT_NEAR(fore.z, 0, 1e-9);
  EXPECT_NEAR(at(v, VmcBone::RightHand).p.x, seg.forearm_m, 1e-9);
  EXPECT_NEAR(at(v, VmcBone::LeftLowerLeg).p.y, -seg.thigh_m, 1e-9);
  EXPECT_NEAR(at(v, VmcBone::LeftFoot).p.y, -seg.shank_m, 1e-9);
  EXPECT_GT(at(v, VmcBone::LeftToes).p.z, 0);      // toes forward: +Z
  EXPECT_LT(at(v, VmcBone::LeftUpperLeg).p.x, 0);  // the performer's left: -X
  EXPECT_GT(at(v, VmcBone::RightUpperArm).p.x, 0);
  EXPECT_GT(at(v, VmcBone::Head).p.y, 0);
  EXPECT_EQ(poser.rests_built(), 1u);
}

// Worked by hand (vmc_pose.hpp's rule (w; v) -> (w; v_x, -v_z, v_y)): the body turned 90 degrees to its
// left about the vertical, the left arm hanging down, the right forearm bent 90 degrees forwards, the
// left knee bent 90 degrees backwards.
TEST(VmcPoser, AKnownPoseGivesTheQuaternionsWorkedOutByHand) {
  const Body b;
  body::Pose bp = b.rest({0, 0, 0.95});
  const double h = std::sqrt(0.5);
  bp.local[static_cast<size_t>(body::Joint::hips)] = body::rot_z(kPi / 2);
  // Left upper arm: from +x (T-pose) to -z (down): about +y by 90 degrees.
  bp.local[static_cast<size_t>(body::Joint::l_shoulder)] = body::rot_y(kPi / 2);
  // Right forearm: from -x to -y (the performer's front): about +z by 90 degrees.
  bp.local[static_cast<size_t>(body::Joint::r_elbow)] = body::rot_z(kPi / 2);
  // Left shank: from -z (down) to +y (backwards): about +x by 90 degrees.
  bp.local[static_cast<size_t>(body::Joint::l_knee)] = body::rot_x(kPi / 2);
  VmcPoser poser;
  const VmcPose v = poser.pose(b.posed(bp));
  // Hips: +90 about world z is -90 about Unity's Y: (0, -sin 45, 0, cos 45). In Unity a turn about +Y
  // by -90 takes the avatar's forward +Z to -X, its own left: the performer turned to the left.
  expect_quat(at(v, VmcBone::Hips).q, 0, -h, 0, h, "Hips");
  // About +y (world) by 90 -> about Unity's +Z by 90: Unity's left arm -X turns to -Y, down.
  expect_quat(at(v, VmcBone::LeftUpperArm).q, 0, 0, h, h, "LeftUpperArm");
  // About +z (world) by 90 -> about Unity's Y by -90: the right forearm +X turns to +Z, forwards.
  expect_quat(at(v, VmcBone::RightLowerArm).q, 0, -h, 0, h, "RightLowerArm");
  // About +x (world) by 90 -> about Unity's +X by 90: the shank -Y turns to -Z, backwards.
  expect_quat(at(v, VmcBone::LeftLowerLeg).q, h, 0, 0, h, "LeftLowerLeg");
  for (VmcBone k : {VmcBone::Spine, VmcBone::Chest, VmcBone::Neck, VmcBone::Head, VmcBone::LeftLowerArm,
                    VmcBone::LeftHand, VmcBone::RightUpperArm, VmcBone::RightHand, VmcBone::LeftUpperLeg,
                    VmcBone::LeftFoot, VmcBone::RightUpperLeg, VmcBone::RightLowerLeg, VmcBone::RightFoot})
    expect_identity(at(v, k).q, std::string(vmc_bone_name(bone(k))).c_str());
  // The directions, in Unity's axes, checked on the rotations themselves.
  auto apply = [](const UnityQuat& q, const dvec3& d) { return glm::dquat(q.w, q.x, q.y, q.z) * d; };
  const dvec3 arm = apply(at(v, VmcBone::LeftUpperArm).q, {-1, 0, 0});
  EXPECT_NEAR(glm::length(arm - dvec3(0, -1, 0)), 0, 1e-9);
  const dvec3 fore = apply(at(v, VmcBone::RightLowerArm).q, {1, 0, 0});
  EXPECT_NEAR(glm::length(fore - dvec3(0, 0, 1)), 0, 1e-9);
  const dvec3 shank = apply(at(v, VmcBone::LeftLowerLeg).q, {0, -1, 0});
  EXPECT_NEAR(glm::length(shank - dvec3(0, 0, -1)), 0, 1e-9);
  const dvec3 facing = apply(at(v, VmcBone::Hips).q, {0, 0, 1});
  EXPECT_NEAR(glm::length(facing - dvec3(-1, 0, 0)), 0, 1e-9);
}

// The bones' own forward kinematics in Unity's frame (what a receiver computes: from the Root, each
// bone at its parent's position plus the parent's rotation of its local position, turned by its local
// rotation) puts every fitted joint at M p_world, whatever the rotations, on a rigid body.
TEST(VmcPoser, TheBonesReproduceARigidBodyInUnitysFrame) {
  const Body b;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> ang(-1.2, 1.2);
  VmcPoser poser;
  for (int f = 0; f < 30; ++f) {
    body::Pose bp = b.rest({0.05 * f, -0.02 * f, 0.9});
    for (size_t j = 0; j < b.sk.joints.size(); ++j) {
      const double z = ang(rng), y = ang(rng), x = ang(rng);
      bp.local[j] = body::rot_z(z) * body::rot_y(y) * body::rot_x(x);
    }
    const pipeline::Pose p = b.posed(bp);
    const VmcPose v = poser.pose(p);
    std::array<dvec3, kVmcBoneCount> pos;
    std::array<dmat3, kVmcBoneCount> rot;
    for (int k = 0; k < kVmcBoneCount; ++k) {
      const VmcTransform& t = v.bones[static_cast<size_t>(k)];
      const dmat3 local = glm::mat3_cast(glm::dquat(t.q.w, t.q.x, t.q.y, t.q.z));
      const int parent = vmc_bone_parent(k);
      const dvec3 pp = parent < 0 ? v.root.p : pos[static_cast<size_t>(parent)];
      const dmat3 pr = parent < 0 ? dmat3(1.0) : rot[static_cast<size_t>(parent)];
      pos[static_cast<size_t>(k)] = pp + pr * t.p;
      rot[static_cast<size_t>(k)] = pr * local;
    }
    const std::pair<VmcBone, pipeline::PoseJoint> fitted[] = {
        {VmcBone::Hips, pipeline::PoseJoint::hips},
        {VmcBone::Neck, pipeline::PoseJoint::neck},
        {VmcBone::Head, pipeline::PoseJoint::head},
        {VmcBone::LeftUpperArm, pipeline::PoseJoint::l_shoulder},
        {VmcBone::LeftLowerArm, pipeline::PoseJoint::l_elbow},
        {VmcBone::LeftHand, pipeline::PoseJoint::l_wrist},
        {VmcBone::RightUpperArm, pipeline::PoseJoint::r_shoulder},
        {VmcBone::RightLowerArm, pipeline::PoseJoint::r_elbow},
        {VmcBone::RightHand, pipeline::PoseJoint::r_wrist},
        {VmcBone::LeftUpperLeg, pipeline::PoseJoint::l_hip},
        {VmcBone::LeftLowerLeg, pipeline::PoseJoint::l_knee},
        {VmcBone::LeftFoot, pipeline::PoseJoint::l_ankle},
        {VmcBone::RightUpperLeg, pipeline::PoseJoint::r_hip},
        {VmcBone::RightLowerLeg, pipeline::PoseJoint::r_knee},
        {VmcBone::RightFoot, pipeline::PoseJoint::r_ankle}};
    for (const auto& [vb, pj] : fitted) {
      const auto& w = p.p_world[static_cast<size_t>(pj)];
      const dvec3 want = unity_from_world(dvec3(w[0], w[1], w[2]));
      EXPECT_NEAR(glm::length(pos[static_cast<size_t>(bone(vb))] - want), 0, 1e-6)
          << "frame " << f << " " << vmc_bone_name(bone(vb));
    }
    for (const VmcTransform& t : v.bones) {
      EXPECT_NEAR(t.q.x * t.q.x + t.q.y * t.q.y + t.q.z * t.q.z + t.q.w * t.q.w, 1, 1e-12);
      EXPECT_GE(t.q.w, 0);
    }
  }
  EXPECT_EQ(poser.rests_built(), 1u);  // one body version: one rest skeleton
}

TEST(VmcPoser, ANewBodyVersionMakesANewRestAndBadPosesAreRefused) {
  const Body b;
  VmcPoser poser;
  poser.pose(b.posed(b.rest(), 1));
  poser.pose(b.posed(b.rest(), 1));
  EXPECT_EQ(poser.rests_built(), 1u);
  // The fitter re-initialised with longer legs: the new rest has them.
  Body tall;
  body::StandardSegments seg;
  seg.hips_to_spine_m = 0.01;
  seg.spine_to_neck_m = 0.5;
  seg.thigh_m = 0.5;
  tall.sk = body::standard_skeleton(seg);
  const VmcPose v = poser.pose(tall.posed(tall.rest(), 2));
  EXPECT_EQ(poser.rests_built(), 2u);
  EXPECT_NEAR(at(v, VmcBone::LeftLowerLeg).p.y, -0.5, 1e-9);

  pipeline::Pose none;
  EXPECT_THROW(poser.pose(none), std::invalid_argument);
  pipeline::Pose nan = b.posed(b.rest());
  nan.p_world[3][1] = std::nan("");
  EXPECT_THROW(poser.pose(nan), std::invalid_argument);
  nan.p_world[3][1] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(poser.pose(nan), std::invalid_argument);
}

}  // namespace
}  // namespace vc::stream
