// One calibrated camera of the rig: OpenCV's pinhole model with distortion (k1 k2 p1 p2 k3) and
// world-to-camera extrinsics, x_cam = R_cam_from_world * x_world + t_cam_from_world.
//
// project() is the exact formula of cv::projectPoints (it ignores the skew entry K(0,1), so valid()
// rejects a non-zero skew rather than let the two disagree). undistort() inverts the distortion by
// Newton iteration to ~1e-12 in normalized coordinates, so ray_world() and project() are consistent
// to far below a pixel. Pixel (u, v) = (0, 0) is the centre of the top-left pixel (OpenCV's convention).
#pragma once

#include <string>

#include <opencv2/core.hpp>

namespace vc::rig {

struct Camera {
  std::string name;
  int width = 0;  // pixels, 1..kMaxImageSide
  int height = 0;
  static constexpr int kMaxImageSide = 16384;  // what any sensor has; the edge's limit too
  cv::Matx33d K = cv::Matx33d::eye();
  cv::Vec<double, 5> dist{0, 0, 0, 0, 0};  // k1 k2 p1 p2 k3 (OpenCV order)
  cv::Matx33d R_cam_from_world = cv::Matx33d::eye();
  cv::Vec3d t_cam_from_world{0, 0, 0};

  // x_cam = R * x_world + t.
  cv::Vec3d to_cam(const cv::Vec3d& p_world) const;
  // The full OpenCV model incl. distortion; identical to cv::projectPoints (a point with z_cam == 0
  // is divided by 1, as OpenCV does; points behind the camera project to meaningless pixels — check
  // to_cam(p)[2] > 0 first).
  cv::Point2d project(const cv::Vec3d& p_world) const;
  // Normalized, undistorted image coordinates (x/z, y/z) -> distorted normalized coordinates.
  cv::Vec2d distort(const cv::Vec2d& xy_undistorted) const;
  // Pixel -> undistorted normalized coordinates (x/z, y/z of every point seen at that pixel).
  cv::Vec2d undistort(const cv::Point2d& px) const;
  // Unit direction (world frame) of the viewing ray through a pixel.
  cv::Vec3d ray_world(const cv::Point2d& px) const;
  // Camera centre in world coordinates, -R^T t.
  cv::Vec3d center_world() const;
  // K [R | t] (no distortion).
  cv::Matx34d projection_matrix() const;
  bool has_distortion() const;
  // Inside the image rectangle [-0.5, width-0.5) x [-0.5, height-0.5).
  bool in_image(const cv::Point2d& px) const;

  bool valid(std::string* why) const;

  // A distortion-free camera at eye_world looking at target_world, image x axis to the right of
  // the view and image y axis towards -up_world, principal point at the image centre.
  static Camera look_at(std::string name, int width, int height, double focal_px, const cv::Vec3d& eye_world,
                        const cv::Vec3d& target_world, const cv::Vec3d& up_world = cv::Vec3d(0, 0, 1));
};

}  // namespace vc::rig
