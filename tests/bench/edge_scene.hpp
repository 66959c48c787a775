// A small ray-cast scene for the edge benchmark: a textured room with floor shadows, a walking
// figure of ellipsoids (skin-coloured head and hands, shirt, dark trousers) and two calibrated
// 640x480 cameras with lens distortion. Frames are deterministic for a seed; the ray of every pixel
// is computed once per camera, on the first render (undistortion is not cheap; a scene used only
// for its cameras stays small).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "voxcap/edge/carver.h"
#include "voxcap/rig/camera.hpp"

namespace vc::bench {

struct Ellipsoid {
  cv::Vec3d center_world;
  cv::Matx33d unit_from_world;  // maps (p - center) to the unit sphere
  cv::Vec3b rgb;
};

class EdgeScene {
 public:
  EdgeScene(int width, int height, uint64_t seed);

  int width() const { return width_; }
  int height() const { return height_; }
  const vc::rig::Camera& camera(int c) const { return cams_[c]; }
  vc_camera camera_model(int c) const;
  // The capture volume [-1, 1] x [-1, 1] x [0, 2] m as an n^3 grid.
  static vc_voxel_grid grid(int n);

  // Renders camera `cam` at `frame` (frame < 0: the empty room, one noisy background frame `-frame`)
  // into rgb (interleaved RGB, stride 3*width).
  void render(int frame, int cam, std::vector<uint8_t>& rgb) const;

 private:
  std::vector<Ellipsoid> body(int frame) const;
  void prepare_rays(int cam) const;

  int width_, height_;
  uint64_t seed_;
  std::array<vc::rig::Camera, 2> cams_;
  mutable std::array<std::vector<cv::Vec3f>, 2> rays_world_;  // unit ray per pixel, lazily
};

}  // namespace vc::bench
