// The method's two-layer skeleton (section 8.1) and its forward kinematics.
//
// Layer 1: 10 segments and 7 joints, rooted at the head (the tracked head feature). The neck hangs
// below the head; the torso (neck joint) carries the shoulders and, through the pelvis, the hip
// joints; each arm is one segment shoulder -> wrist, each leg one segment hip -> ankle, of variable
// length (the distance to the tracked hand or foot). Layer 2 splits each limb into upper arm +
// forearm (thigh + shank) of fixed lengths joined by a hinge: the bend phi follows from the law of
// cosines, the remaining angle rho turns the bent limb about its layer-1 segment. Cylinder samples
// around the layer-2 segments (model.cpp: cylinder_sample_pattern) measure how well a bent limb lies
// in the hull.
//
// rho is kept as a bend direction: the unit vector from the layer-1 segment to the elbow (knee), in
// the frame of the limb's root (the torso for arms, the pelvis for legs), so it never has the
// singular direction an angle about a fixed reference has; rho(t) = rho(t-1) + xi is that vector
// turned by xi about the segment (host/fit/README.md).
//
// Frames: world (DESIGN.md, metres, z up); the torso frame's columns are the performer's right (x),
// the way they face (y) and up the spine (z), as pipeline::Pose::torso_R_world.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include "voxcap/pipeline/frame.hpp"

namespace vc::fit {

using Vec3 = glm::dvec3;
using Mat3 = glm::dmat3;

enum class Limb : int { l_arm, r_arm, l_leg, r_leg };
inline constexpr int kLimbCount = 4;
inline bool is_arm(int limb) {
  return limb < 2;
}
// -1 for the performer's left limbs, +1 for the right ones (the sign along the torso's x axis).
inline double limb_side(int limb) {
  return limb % 2 == 0 ? -1.0 : 1.0;
}
const char* limb_name(int limb);  // "l_arm", "r_arm", "l_leg", "r_leg"

// The body's dimensions (metres): what initialization measures and body.toml overrides.
struct BodyModel {
  double neck_to_head_m = 0.155;        // neck base -> head centre (the root), straight down
  double spine_m = 0.47;                // neck base -> pelvis centre (hips), along the torso's -z
  double shoulder_half_width_m = 0.18;  // torso axis -> shoulder joint, along x
  double shoulder_drop_m = 0.04;        // shoulder joints below the neck base
  double hip_half_width_m = 0.09;       // pelvis centre -> hip joint, along x
  double pelvis_drop_m = 0.07;          // hip joints below the pelvis centre
  double upper_arm_m = 0.30, forearm_m = 0.26;
  double thigh_m = 0.43, shank_m = 0.43;
  // Limb radii of the cylinder samples.
  double upper_arm_radius_m = 0.05, forearm_radius_m = 0.04;
  double thigh_radius_m = 0.075, shank_radius_m = 0.055;
  // The torso cylinder (elliptic, about the spine): half extents along x and y.
  double torso_half_width_m = 0.165, torso_half_depth_m = 0.11;
  double head_to_top_m = 0.115;  // head centre -> top of the head (informative)

  double upper_m(int limb) const { return is_arm(limb) ? upper_arm_m : thigh_m; }
  double lower_m(int limb) const { return is_arm(limb) ? forearm_m : shank_m; }
  double upper_radius_m(int limb) const { return is_arm(limb) ? upper_arm_radius_m : thigh_radius_m; }
  double lower_radius_m(int limb) const { return is_arm(limb) ? forearm_radius_m : shank_radius_m; }
  bool valid(std::string* why) const;
};

// The layer-1 parameters of one frame.
struct Layer1 {
  Vec3 head_world{0, 0, 1.6};                // the root: the head feature
  Vec3 neck_world{0, 0, 1.45};               // neck base
  Mat3 R_torso_world{1.0};                   // the neck joint's rotation: x right, y facing, z up the spine
  Mat3 R_pelvis_world{1.0};                  // the pelvis joint's: the torso's heading, level (the method)
  std::array<Vec3, kLimbCount> end_world{};  // wrist / ankle goals (the hands' and feet's features)
};

// The layer-2 parameters: per limb, the unit bend direction in its root's frame (torso for arms,
// pelvis for legs); it needs not be perpendicular to the segment (its perpendicular part is used).
struct Layer2 {
  std::array<Vec3, kLimbCount> bend_local{Vec3(0, -1, 0), Vec3(0, -1, 0), Vec3(0, 1, 0), Vec3(0, 1, 0)};
  // Per limb, how much longer (metres) than the root-to-goal distance the law of cosines takes the
  // layer-1 segment: > 0 the fitter's answer to noisy goals of a straight limb, < 0 to a bend near full
  // reach that the measured lengths cannot tell (README, "Near-straight limbs", "Near full reach").
  std::array<double, kLimbCount> slack_m{};
};

// One limb in the world: root (shoulder / hip joint), the hinge (elbow / knee) and the end.
struct LimbPose {
  Vec3 root, hinge, end;
  double bend_rad = 0;  // phi's complement: 0 straight, pi folded
};

// The limb's root joint (shoulder or hip) for layer-1 parameters.
Vec3 limb_root(const BodyModel& body, const Layer1& l1, int limb);
// The pelvis centre (the hips joint).
Vec3 pelvis_centre(const BodyModel& body, const Layer1& l1);
// The hinge on the circle of the law of cosines at bend direction `bend_world` (any vector not along
// the segment; its part perpendicular to the segment is used). The end stays at `end` even when it
// is out of reach (then the hinge lies on the segment, in proportion to the two lengths). With
// slack_m != 0 the hinge is placed as if the end were that much further along the segment (nearer,
// when negative: the lower segment then reaches the end that much longer than lower_m).
LimbPose solve_limb(const Vec3& root, const Vec3& end, double upper_m, double lower_m, const Vec3& bend_world,
                    double slack_m = 0);
// The root frame of a limb (R_torso for arms, R_pelvis for legs).
inline const Mat3& limb_frame(const Layer1& l1, int limb) {
  return is_arm(limb) ? l1.R_torso_world : l1.R_pelvis_world;
}

// Forward kinematics of both layers: the 15 joints of pipeline::Pose (PoseJoint order).
std::array<Vec3, pipeline::kPoseJointCount> forward_kinematics(const BodyModel& body, const Layer1& l1,
                                                               const Layer2& l2);

// The level rotation with the heading of R (its x axis projected on the floor; z stays world up).
Mat3 level_heading(const Mat3& R);

// Eigenvalues (descending) and unit eigenvectors (vecs[i] for vals[i]) of the symmetric 3x3 matrix A
// (destroyed) by cyclic Jacobi rotations: exact to rounding in a few sweeps, no allocation (the torso
// PCA runs it every frame; cv::eigen goes through cv::Mat).
void eigen_sym3(double A[3][3], double vals[3], Vec3 vecs[3]);

// Cylinder samples of one limb in the unit frame: (t, r, cos a, sin a) with t in [0, 1] along the
// segment, r in [0, 1] of the radius; the first `upper` of them belong to the upper segment. A fixed,
// even spread (golden-angle spiral per segment), the same for every limb and frame.
struct SamplePattern {
  struct S {
    float t, r, c, s;
  };
  std::vector<S> samples;
  int upper = 0;
};
SamplePattern cylinder_sample_pattern(int samples);

}  // namespace vc::fit
