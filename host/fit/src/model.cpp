#include "voxcap/fit/model.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <glm/geometric.hpp>

namespace vc::fit {

const char* limb_name(int limb) {
  static constexpr const char* kNames[kLimbCount] = {"l_arm", "r_arm", "l_leg", "r_leg"};
  return limb >= 0 && limb < kLimbCount ? kNames[limb] : "?";
}

bool BodyModel::valid(std::string* why) const {
  struct Item {
    const char* name;
    double v, lo, hi;
  };
  const Item items[] = {
      {"neck_to_head_m", neck_to_head_m, 0.02, 0.6},
      {"spine_m", spine_m, 0.1, 1.5},
      {"shoulder_half_width_m", shoulder_half_width_m, 0.03, 0.6},
      {"shoulder_drop_m", shoulder_drop_m, -0.3, 0.3},
      {"hip_half_width_m", hip_half_width_m, 0.01, 0.5},
      {"pelvis_drop_m", pelvis_drop_m, -0.3, 0.4},
      {"upper_arm_m", upper_arm_m, 0.05, 1.0},
      {"forearm_m", forearm_m, 0.05, 1.0},
      {"thigh_m", thigh_m, 0.05, 1.5},
      {"shank_m", shank_m, 0.05, 1.5},
      {"upper_arm_radius_m", upper_arm_radius_m, 0.005, 0.3},
      {"forearm_radius_m", forearm_radius_m, 0.005, 0.3},
      {"thigh_radius_m", thigh_radius_m, 0.005, 0.4},
      {"shank_radius_m", shank_radius_m, 0.005, 0.4},
      {"torso_half_width_m", torso_half_width_m, 0.03, 0.8},
      {"torso_half_depth_m", torso_half_depth_m, 0.03, 0.8},
      {"head_to_top_m", head_to_top_m, 0.0, 0.5},
  };
  for (const Item& i : items)
    if (!(i.v >= i.lo && i.v <= i.hi)) {
      if (why) *why = fmt::format("{}: must be in [{}, {}] m, got {}", i.name, i.lo, i.hi, i.v);
      return false;
    }
  return true;
}

Vec3 pelvis_centre(const BodyModel& body, const Layer1& l1) {
  return l1.neck_world + l1.R_torso_world * Vec3(0, 0, -body.spine_m);
}

Vec3 limb_root(const BodyModel& body, const Layer1& l1, int limb) {
  const double side = limb_side(limb);
  if (is_arm(limb))
    return l1.neck_world +
           l1.R_torso_world * Vec3(side * body.shoulder_half_width_m, 0, -body.shoulder_drop_m);
  return pelvis_centre(body, l1) +
         l1.R_pelvis_world * Vec3(side * body.hip_half_width_m, 0, -body.pelvis_drop_m);
}

LimbPose solve_limb(const Vec3& root, const Vec3& end, double upper_m, double lower_m, const Vec3& bend_world,
                    double slack_m) {
  LimbPose p{root, root, end, 0};
  const Vec3 seg0 = end - root;
  const double d0 = glm::length(seg0);
  const double d = std::max(1e-6, d0 + slack_m);
  const Vec3 seg = d0 > 1e-9 ? seg0 * (d / d0) : seg0;
  const double reach = upper_m + lower_m;
  if (d0 < 1e-9) {  // degenerate: fold along the bend direction
    p.hinge = root + upper_m * glm::normalize(bend_world + Vec3(0, 0, 1e-12));
    p.bend_rad = M_PI;
    return p;
  }
  const Vec3 u = seg / d;
  if (d >= reach) {  // out of reach: straight, the hinge in proportion (the end stays at the goal)
    p.hinge = root + (upper_m / reach) * seg;
    return p;
  }
  // Law of cosines (the method's phi): the hinge's distance a along u and h off the segment.
  const double dd = std::max(d, std::abs(upper_m - lower_m) + 1e-6);
  const double a = (upper_m * upper_m - lower_m * lower_m + dd * dd) / (2 * dd);
  const double h = std::sqrt(std::max(0.0, upper_m * upper_m - a * a));
  Vec3 perp = bend_world - glm::dot(bend_world, u) * u;
  double n = glm::length(perp);
  if (n < 1e-9) {  // bend along the segment: any perpendicular
    const Vec3 any = std::abs(u.z) < 0.9 ? Vec3(0, 0, 1) : Vec3(1, 0, 0);
    perp = glm::cross(u, any);
    n = glm::length(perp);
  }
  p.hinge = root + a * u + (h / n) * perp;
  const Vec3 up = p.hinge - root, lo = (root + seg) - p.hinge;
  const double c = glm::dot(up, lo) / std::max(1e-12, glm::length(up) * glm::length(lo));
  p.bend_rad = std::acos(std::clamp(c, -1.0, 1.0));
  return p;
}

std::array<Vec3, pipeline::kPoseJointCount> forward_kinematics(const BodyModel& body, const Layer1& l1,
                                                               const Layer2& l2) {
  using J = pipeline::PoseJoint;
  std::array<Vec3, pipeline::kPoseJointCount> p{};
  auto at = [&p](J j) -> Vec3& { return p[static_cast<size_t>(j)]; };
  at(J::head) = l1.head_world;
  at(J::neck) = l1.neck_world;
  at(J::hips) = pelvis_centre(body, l1);
  static constexpr J kJoints[kLimbCount][3] = {{J::l_shoulder, J::l_elbow, J::l_wrist},
                                               {J::r_shoulder, J::r_elbow, J::r_wrist},
                                               {J::l_hip, J::l_knee, J::l_ankle},
                                               {J::r_hip, J::r_knee, J::r_ankle}};
  for (int limb = 0; limb < kLimbCount; ++limb) {
    const size_t li = static_cast<size_t>(limb);
    const LimbPose lp =
        solve_limb(limb_root(body, l1, limb), l1.end_world[li], body.upper_m(limb), body.lower_m(limb),
                   limb_frame(l1, limb) * l2.bend_local[li], l2.slack_m[li]);
    at(kJoints[li][0]) = lp.root;
    at(kJoints[li][1]) = lp.hinge;
    at(kJoints[li][2]) = lp.end;
  }
  return p;
}

Mat3 level_heading(const Mat3& R) {
  Vec3 x(R[0].x, R[0].y, 0);
  if (glm::length(x) < 1e-6) {  // x straight up or down: the heading from y
    const Vec3 y(R[1].x, R[1].y, 0);
    x = glm::cross(y, Vec3(0, 0, 1));
  }
  x = glm::normalize(x);
  const Vec3 z(0, 0, 1);
  return Mat3(x, glm::cross(z, x), z);
}

void eigen_sym3(double A[3][3], double vals[3], Vec3 vecs[3]) {
  double V[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  static constexpr int kPairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  for (int sweep = 0; sweep < 32; ++sweep) {
    const double off = A[0][1] * A[0][1] + A[0][2] * A[0][2] + A[1][2] * A[1][2];
    const double diag = A[0][0] * A[0][0] + A[1][1] * A[1][1] + A[2][2] * A[2][2];
    if (off <= 1e-30 * diag || off == 0) break;
    for (const auto& pq : kPairs) {
      const int p = pq[0], q = pq[1];
      if (A[p][q] == 0) continue;
      const double theta = (A[q][q] - A[p][p]) / (2 * A[p][q]);
      const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1));
      const double c = 1 / std::sqrt(t * t + 1), sn = t * c;
      for (int k = 0; k < 3; ++k) {  // A J
        const double akp = A[k][p], akq = A[k][q];
        A[k][p] = c * akp - sn * akq;
        A[k][q] = sn * akp + c * akq;
      }
      for (int k = 0; k < 3; ++k) {  // J^T (A J)
        const double apk = A[p][k], aqk = A[q][k];
        A[p][k] = c * apk - sn * aqk;
        A[q][k] = sn * apk + c * aqk;
      }
      for (int k = 0; k < 3; ++k) {
        const double vkp = V[k][p], vkq = V[k][q];
        V[k][p] = c * vkp - sn * vkq;
        V[k][q] = sn * vkp + c * vkq;
      }
    }
  }
  int order[3] = {0, 1, 2};  // by eigenvalue, descending (three compare-and-swaps)
  auto swap_if = [&A, &order](int i, int j) {
    if (A[order[j]][order[j]] > A[order[i]][order[i]]) std::swap(order[i], order[j]);
  };
  swap_if(0, 1);
  swap_if(1, 2);
  swap_if(0, 1);
  for (int r = 0; r < 3; ++r) {
    const int c = order[r];
    vals[r] = A[c][c];
    vecs[r] = glm::normalize(Vec3(V[0][c], V[1][c], V[2][c]));
  }
}

SamplePattern cylinder_sample_pattern(int samples) {
  SamplePattern sp;
  const int n_up = samples / 2, n_lo = samples - n_up;
  sp.upper = n_up;
  sp.samples.reserve(static_cast<size_t>(samples));
  constexpr double kGolden = 2.399963229728653;  // golden angle, rad
  for (int seg = 0; seg < 2; ++seg) {
    const int n = seg == 0 ? n_up : n_lo;
    for (int i = 0; i < n; ++i) {
      const double t = (i + 0.5) / n;
      const double r = std::sqrt(std::fmod(0.5 + i * 0.6180339887498949, 1.0));
      const double a = i * kGolden;
      sp.samples.push_back({static_cast<float>(t), static_cast<float>(r), static_cast<float>(std::cos(a)),
                            static_cast<float>(std::sin(a))});
    }
  }
  return sp;
}

}  // namespace vc::fit
