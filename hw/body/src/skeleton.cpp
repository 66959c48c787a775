// Skeleton forward kinematics and rotation helpers (Euler angles in any Tait-Bryan order, the
// minimal rotation between two directions, quaternion slerp). Everything is double precision:
// ground truth written from here is compared against at the millimetre level, BVH round trips
// at the micrometre level.
#include "voxcap/body/skeleton.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "voxcap/body/joints.hpp"

namespace vc::body {

int Skeleton::find(std::string_view name) const {
  for (std::size_t j = 0; j < joints.size(); ++j) {
    if (joints[j].name == name) return static_cast<int>(j);
  }
  return -1;
}

std::vector<int> Skeleton::children(int j) const {
  std::vector<int> out;
  for (std::size_t c = 0; c < joints.size(); ++c) {
    if (joints[c].parent == j) out.push_back(static_cast<int>(c));
  }
  return out;
}

bool Skeleton::valid(std::string* why) const {
  auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  if (joints.empty()) return fail("no joints");
  if (joints[0].parent != -1) return fail("joint 0 must be the root");
  for (std::size_t j = 1; j < joints.size(); ++j) {
    if (joints[j].parent < 0 || joints[j].parent >= static_cast<int>(j)) {
      return fail("joint " + joints[j].name + ": parent must precede it");
    }
  }
  return true;
}

void forward_kinematics(const Skeleton& skeleton, const Pose& pose, std::vector<glm::dvec3>* p_world,
                        std::vector<glm::dmat3>* R_world) {
  const std::size_t n = skeleton.joints.size();
  if (pose.local.size() != n) throw std::invalid_argument("forward_kinematics: pose/skeleton size mismatch");
  if (!pose.translation.empty() && pose.translation.size() != n) {
    throw std::invalid_argument("forward_kinematics: translation/skeleton size mismatch");
  }
  std::vector<glm::dmat3> W_local;
  std::vector<glm::dmat3>& W = R_world ? *R_world : W_local;
  W.resize(n);
  p_world->resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    const SkeletonJoint& joint = skeleton.joints[j];
    const glm::dvec3 offset = pose.translation.empty() ? joint.offset : joint.offset + pose.translation[j];
    if (joint.parent < 0) {
      (*p_world)[j] = pose.root_position + offset;
      W[j] = pose.local[j];
    } else {
      const auto p = static_cast<std::size_t>(joint.parent);
      (*p_world)[j] = (*p_world)[p] + W[p] * offset;
      W[j] = W[p] * pose.local[j];
    }
  }
}

Pose rest_pose(const Skeleton& skeleton, const glm::dvec3& root_position) {
  Pose pose;
  pose.root_position = root_position;
  pose.local.assign(skeleton.joints.size(), glm::dmat3(1.0));
  return pose;
}

glm::dvec3 rest_vector(const Skeleton& skeleton, int j, int e) {
  glm::dvec3 v(0, 0, 0);
  for (int k = e; k != j; k = skeleton.joints[static_cast<std::size_t>(k)].parent) {
    if (k < 0) throw std::logic_error("rest_vector: not a descendant");
    v += skeleton.joints[static_cast<std::size_t>(k)].offset;
  }
  return v;
}

glm::dmat3 from_rows(double a00, double a01, double a02, double a10, double a11, double a12, double a20,
                     double a21, double a22) {
  return glm::dmat3(a00, a10, a20, a01, a11, a21, a02, a12, a22);
}

glm::dmat3 rot_x(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return from_rows(1, 0, 0, 0, c, -s, 0, s, c);
}
glm::dmat3 rot_y(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return from_rows(c, 0, s, 0, 1, 0, -s, 0, c);
}
glm::dmat3 rot_z(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return from_rows(c, -s, 0, s, c, 0, 0, 0, 1);
}

glm::dmat3 rot_axis(const glm::dvec3& axis, double a) {
  const double n = glm::length(axis);
  if (n == 0 || a == 0) return glm::dmat3(1.0);
  const glm::dvec3 k = axis / n;
  const double c = std::cos(a), s = std::sin(a), v = 1 - c;
  return from_rows(c + k[0] * k[0] * v, k[0] * k[1] * v - k[2] * s, k[0] * k[2] * v + k[1] * s,
                   k[1] * k[0] * v + k[2] * s, c + k[1] * k[1] * v, k[1] * k[2] * v - k[0] * s,
                   k[2] * k[0] * v - k[1] * s, k[2] * k[1] * v + k[0] * s, c + k[2] * k[2] * v);
}

glm::dmat3 rot_between(const glm::dvec3& from, const glm::dvec3& to) {
  const double nf = glm::length(from), nt = glm::length(to);
  if (nf == 0 || nt == 0) return glm::dmat3(1.0);
  const glm::dvec3 a = from / nf, b = to / nt;
  const double c = glm::dot(a, b);
  if (c < -1 + 1e-12) {
    // Opposite directions: half a turn about any axis perpendicular to a.
    glm::dvec3 perp = glm::cross(a, glm::dvec3(1, 0, 0));
    if (glm::length(perp) < 1e-6) perp = glm::cross(a, glm::dvec3(0, 1, 0));
    return rot_axis(perp, M_PI);
  }
  const glm::dvec3 v = glm::cross(a, b);
  const glm::dmat3 vx = from_rows(0, -v[2], v[1], v[2], 0, -v[0], -v[1], v[0], 0);
  return glm::dmat3(1.0) + vx + vx * vx * (1.0 / (1.0 + c));
}

glm::dquat quat_from_matrix(const glm::dmat3& M) {
  auto R = [&](int r, int c) { return M[c][r]; };
  const double tr = R(0, 0) + R(1, 1) + R(2, 2);
  glm::dquat q;
  if (tr > 0) {
    const double s = std::sqrt(tr + 1.0) * 2;
    q = glm::dquat(0.25 * s, (R(2, 1) - R(1, 2)) / s, (R(0, 2) - R(2, 0)) / s, (R(1, 0) - R(0, 1)) / s);
  } else if (R(0, 0) > R(1, 1) && R(0, 0) > R(2, 2)) {
    const double s = std::sqrt(1.0 + R(0, 0) - R(1, 1) - R(2, 2)) * 2;
    q = glm::dquat((R(2, 1) - R(1, 2)) / s, 0.25 * s, (R(0, 1) + R(1, 0)) / s, (R(0, 2) + R(2, 0)) / s);
  } else if (R(1, 1) > R(2, 2)) {
    const double s = std::sqrt(1.0 + R(1, 1) - R(0, 0) - R(2, 2)) * 2;
    q = glm::dquat((R(0, 2) - R(2, 0)) / s, (R(0, 1) + R(1, 0)) / s, 0.25 * s, (R(1, 2) + R(2, 1)) / s);
  } else {
    const double s = std::sqrt(1.0 + R(2, 2) - R(0, 0) - R(1, 1)) * 2;
    q = glm::dquat((R(1, 0) - R(0, 1)) / s, (R(0, 2) + R(2, 0)) / s, (R(1, 2) + R(2, 1)) / s, 0.25 * s);
  }
  return glm::normalize(q);
}

glm::dmat3 matrix_from_quat(const glm::dquat& qin) {
  const glm::dquat q = glm::normalize(qin);
  const double w = q.w, x = q.x, y = q.y, z = q.z;
  return from_rows(1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),  //
                   2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),  //
                   2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y));
}

glm::dmat3 slerp(const glm::dmat3& a, const glm::dmat3& b, double t) {
  if (t <= 0) return a;
  if (t >= 1) return b;
  const glm::dquat qa = quat_from_matrix(a);
  glm::dquat qb = quat_from_matrix(b);
  double d = glm::dot(qa, qb);
  if (d < 0) {
    qb = -qb;
    d = -d;
  }
  if (d > 1 - 1e-12) return matrix_from_quat(qa * (1 - t) + qb * t);
  const double theta = std::acos(d);
  const double s = std::sin(theta);
  return matrix_from_quat(qa * (std::sin((1 - t) * theta) / s) + qb * (std::sin(t * theta) / s));
}

Pose blend(const Pose& a, const Pose& b, double t) {
  if (a.local.size() != b.local.size()) throw std::invalid_argument("blend: poses of different skeletons");
  if (t <= 0) return a;
  if (t >= 1) return b;
  Pose out;
  out.root_position = a.root_position * (1 - t) + b.root_position * t;
  out.local.resize(a.local.size());
  for (std::size_t j = 0; j < a.local.size(); ++j) out.local[j] = slerp(a.local[j], b.local[j], t);
  if (!a.translation.empty() || !b.translation.empty()) {
    out.translation.resize(a.local.size());
    for (std::size_t j = 0; j < a.local.size(); ++j) {
      const glm::dvec3 ta = a.translation.empty() ? glm::dvec3(0) : a.translation[j];
      const glm::dvec3 tb = b.translation.empty() ? glm::dvec3(0) : b.translation[j];
      out.translation[j] = ta * (1 - t) + tb * t;
    }
  }
  return out;
}

namespace {

int axis_index(char c) {
  switch (c) {
    case 'X':
    case 'x':
      return 0;
    case 'Y':
    case 'y':
      return 1;
    case 'Z':
    case 'z':
      return 2;
    default:
      return -1;
  }
}

glm::dmat3 rot_about(int axis, double a) {
  return axis == 0 ? rot_x(a) : axis == 1 ? rot_y(a) : rot_z(a);
}

}  // namespace

glm::dmat3 matrix_from_euler(std::string_view order, const glm::dvec3& degrees) {
  if (order.size() != 3) throw std::invalid_argument("euler order must have 3 axes");
  glm::dmat3 R(1.0);
  for (int i = 0; i < 3; ++i) {
    const int ax = axis_index(order[static_cast<std::size_t>(i)]);
    if (ax < 0) throw std::invalid_argument("euler order must use X, Y, Z");
    R = R * rot_about(ax, degrees[i] * M_PI / 180.0);
  }
  return R;
}

glm::dvec3 euler_from_matrix(std::string_view order, const glm::dmat3& M) {
  if (order.size() != 3) throw std::invalid_argument("euler order must have 3 axes");
  const int i = axis_index(order[0]), j = axis_index(order[1]), k = axis_index(order[2]);
  if (i < 0 || j < 0 || k < 0 || i == j || j == k || i == k) {
    throw std::invalid_argument("euler_from_matrix: only Tait-Bryan orders (three distinct axes)");
  }
  auto R = [&](int r, int c) { return M[c][r]; };
  // R = R_i(a) R_j(b) R_k(c); e = +1 for cyclic (even) axis orders.
  const double e = ((i + 1) % 3 == j) ? 1.0 : -1.0;
  const double sb = std::clamp(e * R(i, k), -1.0, 1.0);
  double a, b, c;
  if (std::abs(sb) > 1 - 1e-12) {
    // Gimbal lock: only a +- c is defined; put it all in a.
    b = std::copysign(M_PI / 2, sb);
    c = 0;
    a = std::atan2(e * R(k, j), R(j, j));
  } else {
    b = std::asin(sb);
    a = std::atan2(-e * R(j, k), R(k, k));
    c = std::atan2(-e * R(i, j), R(i, i));
  }
  return glm::dvec3(a, b, c) * (180.0 / M_PI);
}

bool StandardSegments::valid(std::string* why) const {
  const double all[] = {hips_to_spine_m,       spine_to_neck_m, neck_to_head_m, head_to_top_m,
                        shoulder_half_width_m, upper_arm_m,     forearm_m,      hand_m,
                        hip_half_width_m,      pelvis_drop_m,   thigh_m,        shank_m,
                        foot_forward_m};
  std::ostringstream os;
  if (!std::all_of(std::begin(all), std::end(all), [](double v) { return v > 0 && v < 1.5; })) {
    os << "every segment length must be in (0, 1.5) m";
  } else if (!(shoulder_drop_m >= 0 && shoulder_drop_m <= spine_to_neck_m)) {
    os << "shoulder_drop_m must be in [0, spine_to_neck_m]";
  } else if (!(ankle_to_toe_drop_m >= -0.5 && ankle_to_toe_drop_m < 0.5)) {
    os << "ankle_to_toe_drop_m must be in [-0.5, 0.5) m";
  } else {
    return true;
  }
  if (why) *why = os.str();
  return false;
}

Skeleton standard_skeleton(const StandardSegments& b) {
  std::string why;
  if (!b.valid(&why)) throw std::invalid_argument("standard_skeleton: " + why);
  Skeleton sk;
  sk.joints.resize(kJointCount);
  auto set = [&](Joint j, const glm::dvec3& offset) {
    const int i = static_cast<int>(j);
    sk.joints[static_cast<std::size_t>(i)] = {std::string(joint_name(i)), joint_parent(i), offset,
                                              joint_is_end(i)};
  };
  set(Joint::hips, {0, 0, 0});
  set(Joint::spine, {0, 0, b.hips_to_spine_m});
  set(Joint::neck, {0, 0, b.spine_to_neck_m});
  set(Joint::head, {0, 0, b.neck_to_head_m});
  set(Joint::head_top, {0, 0, b.head_to_top_m});
  for (int side = 0; side < 2; ++side) {
    const double sg = side == 0 ? 1.0 : -1.0;
    const bool l = side == 0;
    set(l ? Joint::l_shoulder : Joint::r_shoulder,
        {sg * b.shoulder_half_width_m, 0, b.spine_to_neck_m - b.shoulder_drop_m});
    set(l ? Joint::l_elbow : Joint::r_elbow, {sg * b.upper_arm_m, 0, 0});
    set(l ? Joint::l_wrist : Joint::r_wrist, {sg * b.forearm_m, 0, 0});
    set(l ? Joint::l_hand_tip : Joint::r_hand_tip, {sg * b.hand_m, 0, 0});
    set(l ? Joint::l_hip : Joint::r_hip, {sg * b.hip_half_width_m, 0, -b.pelvis_drop_m});
    set(l ? Joint::l_knee : Joint::r_knee, {0, 0, -b.thigh_m});
    set(l ? Joint::l_ankle : Joint::r_ankle, {0, 0, -b.shank_m});
    set(l ? Joint::l_toe : Joint::r_toe, {0, -b.foot_forward_m, -b.ankle_to_toe_drop_m});
  }
  return sk;
}

bool is_standard(const Skeleton& skeleton) {
  if (skeleton.joints.size() != static_cast<std::size_t>(kJointCount)) return false;
  for (int j = 0; j < kJointCount; ++j) {
    const SkeletonJoint& jt = skeleton.joints[static_cast<std::size_t>(j)];
    if (jt.name != joint_name(j) || jt.parent != joint_parent(j) || jt.end_site != joint_is_end(j))
      return false;
  }
  return true;
}

}  // namespace vc::body
