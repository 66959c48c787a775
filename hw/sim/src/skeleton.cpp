// Skeleton forward kinematics and rotation helpers (Euler angles in any Tait-Bryan order, the
// minimal rotation between two directions, quaternion slerp). Everything is double precision:
// the ground truth written from here is compared against at the millimetre level.
#include "voxcap/sim/skeleton.hpp"

#include <cmath>
#include <stdexcept>

namespace vc::sim {

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

void forward_kinematics(const Skeleton& skeleton, const Pose& pose, std::vector<cv::Vec3d>* p_world,
                        std::vector<cv::Matx33d>* R_world) {
  const std::size_t n = skeleton.joints.size();
  if (pose.local.size() != n) throw std::invalid_argument("forward_kinematics: pose/skeleton size mismatch");
  std::vector<cv::Matx33d> W_local;
  std::vector<cv::Matx33d>& W = R_world ? *R_world : W_local;
  if (!pose.translation.empty() && pose.translation.size() != n) {
    throw std::invalid_argument("forward_kinematics: translation/skeleton size mismatch");
  }
  W.resize(n);
  p_world->resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    const SkeletonJoint& joint = skeleton.joints[j];
    const cv::Vec3d offset =
        pose.translation.empty() ? joint.offset : joint.offset + pose.translation[j];
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

Pose rest_pose(const Skeleton& skeleton, const cv::Vec3d& root_position) {
  Pose pose;
  pose.root_position = root_position;
  pose.local.assign(skeleton.joints.size(), cv::Matx33d::eye());
  return pose;
}

cv::Matx33d rot_x(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return {1, 0, 0, 0, c, -s, 0, s, c};
}
cv::Matx33d rot_y(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return {c, 0, s, 0, 1, 0, -s, 0, c};
}
cv::Matx33d rot_z(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return {c, -s, 0, s, c, 0, 0, 0, 1};
}

cv::Matx33d rot_axis(const cv::Vec3d& axis, double a) {
  const double n = cv::norm(axis);
  if (n == 0 || a == 0) return cv::Matx33d::eye();
  const cv::Vec3d k = axis / n;
  const double c = std::cos(a), s = std::sin(a), v = 1 - c;
  return {c + k[0] * k[0] * v,        k[0] * k[1] * v - k[2] * s, k[0] * k[2] * v + k[1] * s,
          k[1] * k[0] * v + k[2] * s, c + k[1] * k[1] * v,        k[1] * k[2] * v - k[0] * s,
          k[2] * k[0] * v - k[1] * s, k[2] * k[1] * v + k[0] * s, c + k[2] * k[2] * v};
}

cv::Matx33d rot_between(const cv::Vec3d& from, const cv::Vec3d& to) {
  const double nf = cv::norm(from), nt = cv::norm(to);
  if (nf == 0 || nt == 0) return cv::Matx33d::eye();
  const cv::Vec3d a = from / nf, b = to / nt;
  const double c = a.dot(b);
  if (c < -1 + 1e-12) {
    // Opposite directions: half a turn about any axis perpendicular to a.
    cv::Vec3d perp = a.cross(cv::Vec3d(1, 0, 0));
    if (cv::norm(perp) < 1e-6) perp = a.cross(cv::Vec3d(0, 1, 0));
    return rot_axis(perp, M_PI);
  }
  const cv::Vec3d v = a.cross(b);
  const cv::Matx33d vx(0, -v[2], v[1], v[2], 0, -v[0], -v[1], v[0], 0);
  return cv::Matx33d::eye() + vx + vx * vx * (1.0 / (1.0 + c));
}

cv::Matx33d orthonormalize(const cv::Matx33d& R) {
  cv::Matx33d U, Vt;
  cv::Vec3d w;
  cv::SVD::compute(R, w, U, Vt);
  cv::Matx33d out = U * Vt;
  if (cv::determinant(out) < 0) {
    for (int r = 0; r < 3; ++r) U(r, 2) = -U(r, 2);
    out = U * Vt;
  }
  return out;
}

cv::Vec4d quat_from_matrix(const cv::Matx33d& R) {
  const double tr = R(0, 0) + R(1, 1) + R(2, 2);
  cv::Vec4d q;
  if (tr > 0) {
    const double s = std::sqrt(tr + 1.0) * 2;
    q = {0.25 * s, (R(2, 1) - R(1, 2)) / s, (R(0, 2) - R(2, 0)) / s, (R(1, 0) - R(0, 1)) / s};
  } else if (R(0, 0) > R(1, 1) && R(0, 0) > R(2, 2)) {
    const double s = std::sqrt(1.0 + R(0, 0) - R(1, 1) - R(2, 2)) * 2;
    q = {(R(2, 1) - R(1, 2)) / s, 0.25 * s, (R(0, 1) + R(1, 0)) / s, (R(0, 2) + R(2, 0)) / s};
  } else if (R(1, 1) > R(2, 2)) {
    const double s = std::sqrt(1.0 + R(1, 1) - R(0, 0) - R(2, 2)) * 2;
    q = {(R(0, 2) - R(2, 0)) / s, (R(0, 1) + R(1, 0)) / s, 0.25 * s, (R(1, 2) + R(2, 1)) / s};
  } else {
    const double s = std::sqrt(1.0 + R(2, 2) - R(0, 0) - R(1, 1)) * 2;
    q = {(R(1, 0) - R(0, 1)) / s, (R(0, 2) + R(2, 0)) / s, (R(1, 2) + R(2, 1)) / s, 0.25 * s};
  }
  return q / cv::norm(q);
}

cv::Matx33d matrix_from_quat(const cv::Vec4d& qin) {
  const cv::Vec4d q = qin / cv::norm(qin);
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  return {1 - 2 * (y * y + z * z), 2 * (x * y - z * w),     2 * (x * z + y * w),
          2 * (x * y + z * w),     1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
          2 * (x * z - y * w),     2 * (y * z + x * w),     1 - 2 * (x * x + y * y)};
}

cv::Matx33d slerp(const cv::Matx33d& a, const cv::Matx33d& b, double t) {
  if (t <= 0) return a;
  if (t >= 1) return b;
  const cv::Vec4d qa = quat_from_matrix(a);
  cv::Vec4d qb = quat_from_matrix(b);
  double d = qa.dot(qb);
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
      const cv::Vec3d ta = a.translation.empty() ? cv::Vec3d() : a.translation[j];
      const cv::Vec3d tb = b.translation.empty() ? cv::Vec3d() : b.translation[j];
      out.translation[j] = ta * (1 - t) + tb * t;
    }
  }
  return out;
}

namespace {

int axis_index(char c) {
  switch (c) {
    case 'X': case 'x': return 0;
    case 'Y': case 'y': return 1;
    case 'Z': case 'z': return 2;
    default: return -1;
  }
}

cv::Matx33d rot_about(int axis, double a) {
  return axis == 0 ? rot_x(a) : axis == 1 ? rot_y(a) : rot_z(a);
}

}  // namespace

cv::Matx33d matrix_from_euler(std::string_view order, const cv::Vec3d& degrees) {
  if (order.size() != 3) throw std::invalid_argument("euler order must have 3 axes");
  cv::Matx33d R = cv::Matx33d::eye();
  for (int i = 0; i < 3; ++i) {
    const int ax = axis_index(order[static_cast<std::size_t>(i)]);
    if (ax < 0) throw std::invalid_argument("euler order must use X, Y, Z");
    R = R * rot_about(ax, degrees[i] * M_PI / 180.0);
  }
  return R;
}

cv::Vec3d euler_from_matrix(std::string_view order, const cv::Matx33d& R) {
  if (order.size() != 3) throw std::invalid_argument("euler order must have 3 axes");
  const int i = axis_index(order[0]), j = axis_index(order[1]), k = axis_index(order[2]);
  if (i < 0 || j < 0 || k < 0 || i == j || j == k || i == k) {
    throw std::invalid_argument("euler_from_matrix: only Tait-Bryan orders (three distinct axes)");
  }
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
  return cv::Vec3d(a, b, c) * (180.0 / M_PI);
}

}  // namespace vc::sim
