// Camera model: the OpenCV pinhole model with radial/tangential distortion, written out so that
// project() matches cv::projectPoints exactly (same formula and operation order), plus its inverse
// (Newton iteration on the 2x2 distortion map) for per-pixel viewing rays.
#include "voxcap/rig/camera.hpp"

#include <cmath>
#include <sstream>

namespace vc::rig {
namespace {

bool finite(const cv::Matx33d& m) {
  for (int i = 0; i < 9; ++i) {
    if (!std::isfinite(m.val[i])) return false;
  }
  return true;
}

void set_why(std::string* why, const std::string& text) {
  if (why) *why = text;
}

}  // namespace

cv::Vec3d Camera::to_cam(const cv::Vec3d& p_world) const {
  return R_cam_from_world * p_world + t_cam_from_world;
}

cv::Vec2d Camera::distort(const cv::Vec2d& xy) const {
  const double k1 = dist[0], k2 = dist[1], p1 = dist[2], p2 = dist[3], k3 = dist[4];
  const double x = xy[0], y = xy[1];
  const double r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
  const double a1 = 2 * x * y, a2 = r2 + 2 * x * x, a3 = r2 + 2 * y * y;
  const double cdist = 1 + k1 * r2 + k2 * r4 + k3 * r6;
  return {x * cdist + p1 * a1 + p2 * a2, y * cdist + p1 * a3 + p2 * a1};
}

cv::Point2d Camera::project(const cv::Vec3d& p_world) const {
  const cv::Vec3d p_cam = to_cam(p_world);
  const double z = p_cam[2] != 0 ? 1.0 / p_cam[2] : 1.0;
  const cv::Vec2d xd = distort({p_cam[0] * z, p_cam[1] * z});
  return {xd[0] * K(0, 0) + K(0, 2), xd[1] * K(1, 1) + K(1, 2)};
}

cv::Vec2d Camera::undistort(const cv::Point2d& px) const {
  const cv::Vec2d target((px.x - K(0, 2)) / K(0, 0), (px.y - K(1, 2)) / K(1, 1));
  if (!has_distortion()) return target;
  const double k1 = dist[0], k2 = dist[1], p1 = dist[2], p2 = dist[3], k3 = dist[4];
  cv::Vec2d xy = target;
  for (int it = 0; it < 50; ++it) {
    const cv::Vec2d f = distort(xy) - target;
    if (std::abs(f[0]) + std::abs(f[1]) < 1e-15) break;
    const double x = xy[0], y = xy[1];
    const double r2 = x * x + y * y, r4 = r2 * r2;
    const double radial = 1 + k1 * r2 + k2 * r4 + k3 * r4 * r2;
    const double dradial = k1 + 2 * k2 * r2 + 3 * k3 * r4;  // d radial / d r2
    const double jxx = radial + 2 * x * x * dradial + 2 * p1 * y + 6 * p2 * x;
    const double jxy = 2 * x * y * dradial + 2 * p1 * x + 2 * p2 * y;
    const double jyx = 2 * x * y * dradial + 2 * p1 * x + 2 * p2 * y;
    const double jyy = radial + 2 * y * y * dradial + 6 * p1 * y + 2 * p2 * x;
    const double det = jxx * jyy - jxy * jyx;
    if (std::abs(det) < 1e-12) break;  // beyond the model's monotonic range; keep the best guess
    xy -= cv::Vec2d((jyy * f[0] - jxy * f[1]) / det, (-jyx * f[0] + jxx * f[1]) / det);
  }
  return xy;
}

cv::Vec3d Camera::ray_world(const cv::Point2d& px) const {
  const cv::Vec2d xy = undistort(px);
  return cv::normalize(R_cam_from_world.t() * cv::Vec3d(xy[0], xy[1], 1.0));
}

cv::Vec3d Camera::center_world() const {
  return -(R_cam_from_world.t() * t_cam_from_world);
}

cv::Matx34d Camera::projection_matrix() const {
  cv::Matx34d Rt;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) Rt(r, c) = R_cam_from_world(r, c);
    Rt(r, 3) = t_cam_from_world[r];
  }
  return K * Rt;
}

bool Camera::has_distortion() const {
  for (int i = 0; i < 5; ++i) {
    if (dist[i] != 0) return true;
  }
  return false;
}

bool Camera::in_image(const cv::Point2d& px) const {
  return px.x >= -0.5 && px.y >= -0.5 && px.x < width - 0.5 && px.y < height - 0.5;
}

bool Camera::valid(std::string* why) const {
  std::ostringstream os;
  if (width <= 0 || height <= 0 || width > kMaxImageSide || height > kMaxImageSide) {
    os << "image size must be in [1, " << kMaxImageSide << "] pixels, got " << width << "x" << height;
  } else if (!finite(K) || !finite(R_cam_from_world)) {
    os << "K and R must be finite";
  } else if (!(K(0, 0) > 0) || !(K(1, 1) > 0)) {
    os << "focal lengths K(0,0) and K(1,1) must be positive";
  } else if (K(0, 1) != 0 || K(1, 0) != 0 || K(2, 0) != 0 || K(2, 1) != 0 || K(2, 2) != 1) {
    os << "K must be [fx 0 cx; 0 fy cy; 0 0 1] (skew is not supported: cv::projectPoints ignores it)";
  } else if (!std::isfinite(t_cam_from_world[0]) || !std::isfinite(t_cam_from_world[1]) ||
             !std::isfinite(t_cam_from_world[2])) {
    os << "t must be finite";
  } else if (!std::isfinite(dist[0]) || !std::isfinite(dist[1]) || !std::isfinite(dist[2]) ||
             !std::isfinite(dist[3]) || !std::isfinite(dist[4])) {
    os << "distortion coefficients must be finite";
  } else {
    const cv::Matx33d RtR = R_cam_from_world.t() * R_cam_from_world;
    const double err = cv::norm(RtR - cv::Matx33d::eye(), cv::NORM_INF);
    if (err > 1e-6 || cv::determinant(R_cam_from_world) < 0) {
      os << "R must be a rotation (orthonormal, det +1); |R^T R - I| = " << err;
    } else {
      return true;
    }
  }
  set_why(why, os.str());
  return false;
}

Camera Camera::look_at(std::string name, int width, int height, double focal_px, const cv::Vec3d& eye_world,
                       const cv::Vec3d& target_world, const cv::Vec3d& up_world) {
  const cv::Vec3d forward = cv::normalize(target_world - eye_world);
  const cv::Vec3d right = cv::normalize(forward.cross(up_world));
  const cv::Vec3d down = forward.cross(right);
  Camera cam;
  cam.name = std::move(name);
  cam.width = width;
  cam.height = height;
  cam.K = cv::Matx33d(focal_px, 0, (width - 1) * 0.5, 0, focal_px, (height - 1) * 0.5, 0, 0, 1);
  cam.R_cam_from_world = cv::Matx33d(right[0], right[1], right[2], down[0], down[1], down[2], forward[0],
                                     forward[1], forward[2]);
  cam.t_cam_from_world = -(cam.R_cam_from_world * eye_world);
  return cam;
}

}  // namespace vc::rig
