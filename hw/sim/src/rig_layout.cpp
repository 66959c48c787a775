// Default camera ring. Azimuth 0 is the front (-y); the front pair sits at +-asin(spacing/2r),
// the other N-2 cameras at 360 k/(N-1) degrees, k = 1..N-2 (for 6 cameras: 72, 144, 216, 288).
// Each camera is turned so that the volume's projection is centred, then one focal length for
// all makes the volume as large as fits in every image.
#include "voxcap/sim/rig_layout.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace vc::sim {

bool RigLayout::valid(std::string* why) const {
  std::ostringstream os;
  if (cameras < 2 || cameras > 64) {
    os << "cameras must be in [2, 64], got " << cameras;
  } else if (width < 16 || height < 16 || width > 8192 || height > 8192) {
    os << "image size must be in [16, 8192], got " << width << "x" << height;
  } else if (!(radius_m > 0.5 && radius_m < 20) || !(height_m > 0 && height_m < 10)) {
    os << "radius_m must be in (0.5, 20) and height_m in (0, 10)";
  } else if (!(front_spacing_m > 0 && front_spacing_m < radius_m)) {
    os << "front_spacing_m must be in (0, radius_m)";
  } else if (!(volume_max_m[0] > volume_min_m[0] && volume_max_m[1] > volume_min_m[1] &&
               volume_max_m[2] > volume_min_m[2])) {
    os << "the volume must have a positive size";
  } else if (!(margin >= 0 && margin < 0.4)) {
    os << "margin must be in [0, 0.4)";
  } else if (!(voxel_m > 0)) {
    os << "voxel_m must be positive";
  } else {
    return true;
  }
  if (why) *why = os.str();
  return false;
}

rig::Calibration default_rig(const RigLayout& L) {
  std::string why;
  if (!L.valid(&why)) throw std::invalid_argument("rig layout: " + why);
  std::vector<double> azimuth;
  const double half = std::asin(0.5 * L.front_spacing_m / L.radius_m);
  azimuth.push_back(-half);
  azimuth.push_back(half);
  for (int k = 1; k <= L.cameras - 2; ++k) azimuth.push_back(2 * M_PI * k / (L.cameras - 1));

  auto corner = [&](int c) {
    return cv::Vec3d((c & 1) ? L.volume_max_m[0] : L.volume_min_m[0], (c & 2) ? L.volume_max_m[1] : L.volume_min_m[1],
                     (c & 4) ? L.volume_max_m[2] : L.volume_min_m[2]);
  };
  rig::Calibration calib;
  for (int i = 0; i < L.cameras; ++i) {
    const double a = azimuth[static_cast<std::size_t>(i)];
    const cv::Vec3d eye(L.radius_m * std::sin(a), -L.radius_m * std::cos(a), L.height_m);
    const std::string name = i < 2 ? "front" + std::to_string(i) : "ring" + std::to_string(i);
    // Start looking at look_at_m, then turn (without roll) until the volume's projection is
    // centred in the image, so that one focal length can make it fill the frame.
    cv::Vec3d target = L.look_at_m;
    rig::Camera cam;
    for (int it = 0; it < 8; ++it) {
      cam = rig::Camera::look_at(name, L.width, L.height, 1.0, eye, target);
      double x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL;
      for (int c = 0; c < 8; ++c) {
        const cv::Vec3d p = cam.to_cam(corner(c));
        if (p[2] <= 0.05) throw std::invalid_argument("rig layout: a camera is inside the volume");
        x0 = std::min(x0, p[0] / p[2]);
        x1 = std::max(x1, p[0] / p[2]);
        y0 = std::min(y0, p[1] / p[2]);
        y1 = std::max(y1, p[1] / p[2]);
      }
      const cv::Vec3d d = cam.R_cam_from_world.t() * cv::Vec3d(0.5 * (x0 + x1), 0.5 * (y0 + y1), 1.0);
      target = eye + cv::normalize(d) * cv::norm(L.look_at_m - eye);
    }
    calib.cameras.push_back(cam);
  }
  // One focal length for all: the largest that keeps every volume corner inside every image.
  double f = HUGE_VAL;
  for (const auto& cam : calib.cameras) {
    for (int c = 0; c < 8; ++c) {
      const cv::Vec3d p = cam.to_cam(corner(c));
      if (p[2] <= 0.05) throw std::invalid_argument("rig layout: a camera is inside the volume");
      const double fx = 0.5 * (L.width - 1) * (1 - 2 * L.margin) * p[2] / std::max(std::abs(p[0]), 1e-9);
      const double fy = 0.5 * (L.height - 1) * (1 - 2 * L.margin) * p[2] / std::max(std::abs(p[1]), 1e-9);
      f = std::min({f, fx, fy});
    }
  }
  for (std::size_t i = 0; i < calib.cameras.size(); ++i) {
    rig::Camera& cam = calib.cameras[i];
    cam.K(0, 0) = cam.K(1, 1) = f;
    if (L.distortion) {
      // Mild barrel distortion, slightly different per camera (as real lenses are).
      const double v = static_cast<double>(i % 3) - 1.0;
      cam.dist = {-0.10 + 0.015 * v, 0.03 - 0.005 * v, 0.0, 0.0, 0.0};
    }
  }
  calib.grid = rig::VoxelGrid::covering(L.volume_min_m, L.volume_max_m, L.voxel_m);
  return calib;
}

}  // namespace vc::sim
