// The default virtual rig: N cameras in a convergent ring around the capture volume, two of them
// close together in front (at -y, where the performer faces in the initialization pose), the
// others evenly spread over the rest of the circle; focal length chosen so that the volume fills
// the image. Camera 0 and 1 are the front pair.
#pragma once

#include <string>

#include "voxcap/rig/calibration.hpp"

namespace vc::sim {

struct RigLayout {
  int cameras = 6;
  int width = 640, height = 480;
  double radius_m = 3.8;          // horizontal distance of every camera from the volume axis
  double height_m = 2.3;          // camera height above the floor
  double front_spacing_m = 0.8;   // distance between the two front cameras
  cv::Vec3d volume_min_m{-1.25, -1.25, 0.0};
  cv::Vec3d volume_max_m{1.25, 1.25, 2.2};
  cv::Vec3d look_at_m{0, 0, 0.95};
  double margin = 0.02;           // image fraction kept free around the projected volume
  double voxel_m = 0.02;          // the calibration's voxel grid over the volume
  bool distortion = false;        // mild barrel distortion (k1 ~ -0.1, k2 ~ 0.03), per camera
  bool valid(std::string* why) const;
};

// Throws std::invalid_argument when the layout is invalid.
rig::Calibration default_rig(const RigLayout& layout);

}  // namespace vc::sim
