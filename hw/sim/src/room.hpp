// The static room around the capture volume, one of the presets (room_presets() in scene.hpp):
// "default", a box with a wooden plank floor, painted walls with panels, a door, posters, a
// checkerboard and shelves (several in colours close to the clothes presets, to break weak
// background subtraction); "camouflage", a beige tiled floor close to the skin presets and walls
// painted close to the shirt presets. Lit by the scene's point light.
#pragma once

#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

namespace vc::sim::detail {

enum RoomFace : int { kFloor = 0, kCeiling, kWallPosX, kWallNegX, kWallPosY, kWallNegY };
enum RoomStyle : int { kRoomDefault = 0, kRoomCamouflage };
// The style of a room preset's name; -1 when unknown.
int room_style(const std::string& name);

struct Room {
  double half_m = 4.5;
  double height_m = 3.0;
  cv::Vec3d light_m{1.2, 0.9, 2.9};
  int style = kRoomDefault;

  // The ray o + t d from inside the room: exit distance and face. False if o is outside.
  bool hit(const cv::Vec3d& o, const cv::Vec3d& d, double* t, int* face) const;
  // Lit colour (RGB, 0..255 scale, may exceed 255 slightly) of a surface point.
  cv::Vec3d shade(int face, const cv::Vec3d& p) const;
  cv::Vec3d albedo(int face, const cv::Vec3d& p) const;
};

// Deterministic hash noise helpers (also used for the noise tables).
std::uint64_t mix64(std::uint64_t x);
double hash01(std::int64_t a, std::int64_t b, std::uint64_t salt);
double value_noise(double x, double y, std::uint64_t salt);

}  // namespace vc::sim::detail
