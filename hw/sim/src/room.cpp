// Procedural room textures: value noise and hashes only, so the room is identical everywhere and
// needs no image files.
#include "room.hpp"

#include <algorithm>
#include <cmath>

#include "voxcap/sim/scene.hpp"

namespace vc::sim::detail {
namespace {

struct Rect {
  double u0, u1, z0, z1;
  bool in(double u, double z) const { return u >= u0 && u < u1 && z >= z0 && z < z1; }
};

cv::Vec3d plaster(double u, double z, const cv::Vec3d& base, std::uint64_t salt) {
  return base *
         (0.96 + 0.05 * value_noise(u * 7, z * 7, salt) + 0.02 * value_noise(u * 40, z * 40, salt + 1));
}

// A framed rectangle: inside colour, a thin darker frame.
bool framed(const Rect& r, double u, double z, const cv::Vec3d& inside, double frame_m, cv::Vec3d* out) {
  if (!r.in(u, z)) return false;
  const bool edge = u < r.u0 + frame_m || u >= r.u1 - frame_m || z < r.z0 + frame_m || z >= r.z1 - frame_m;
  *out = edge ? cv::Vec3d(45, 42, 40) : inside;
  return true;
}

}  // namespace

std::uint64_t mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

double hash01(std::int64_t a, std::int64_t b, std::uint64_t salt) {
  const std::uint64_t h =
      mix64(static_cast<std::uint64_t>(a) * 0x100000001B3ull ^ mix64(static_cast<std::uint64_t>(b) ^ salt));
  return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0);
}

double value_noise(double x, double y, std::uint64_t salt) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy);
  double tx = x - fx, ty = y - fy;
  tx = tx * tx * (3 - 2 * tx);
  ty = ty * ty * (3 - 2 * ty);
  const double a = hash01(ix, iy, salt), b = hash01(ix + 1, iy, salt);
  const double c = hash01(ix, iy + 1, salt), d = hash01(ix + 1, iy + 1, salt);
  return (a * (1 - tx) + b * tx) * (1 - ty) + (c * (1 - tx) + d * tx) * ty;
}

bool Room::hit(const cv::Vec3d& o, const cv::Vec3d& d, double* t, int* face) const {
  if (std::abs(o[0]) > half_m || std::abs(o[1]) > half_m || o[2] < 0 || o[2] > height_m) return false;
  double best = HUGE_VAL;
  int f = -1;
  auto test = [&](double num, double den, int which) {
    if (std::abs(den) < 1e-15) return;
    const double tt = num / den;
    if (tt > 0 && tt < best) {
      best = tt;
      f = which;
    }
  };
  if (d[2] < 0) test(-o[2], d[2], kFloor);
  if (d[2] > 0) test(height_m - o[2], d[2], kCeiling);
  if (d[0] > 0) test(half_m - o[0], d[0], kWallPosX);
  if (d[0] < 0) test(-half_m - o[0], d[0], kWallNegX);
  if (d[1] > 0) test(half_m - o[1], d[1], kWallPosY);
  if (d[1] < 0) test(-half_m - o[1], d[1], kWallNegY);
  if (f < 0) return false;
  *t = best;
  *face = f;
  return true;
}

namespace {

// Walls: u runs along the wall (left to right seen from the room's centre), z up; salt per wall.
double wall_u(int face, const cv::Vec3d& p, std::uint64_t* salt) {
  switch (face) {
    case kWallPosY:
      *salt = 31;
      return p[0];
    case kWallNegY:
      *salt = 32;
      return -p[0];
    case kWallPosX:
      *salt = 33;
      return -p[1];
    default:
      *salt = 34;
      return p[1];
  }
}

// The camouflage room. The floor: beige ceramic tiles (0.4 m, 4 mm grout), each tile's tone drawn
// around the light skin presets, with a stone-like mottle from 10 cm down to ~1 cm. The walls, below
// 2 m: paint close to a shirt preset per wall (+y blue ~ default, -y red ~ pale, +x green ~ olive,
// -x ochre ~ brown), with a plaster texture (a few per cent, from 15 cm down to ~7 mm); above it
// off-white. Flat (no texture, as printed or enamelled surfaces are): the posters (skin tones), the
// door (~ trousers), the whiteboard and a light grey panel (~ the dark preset's shirt), each in a thin
// dark frame; the skirting board is flat white.
cv::Vec3d camouflage_albedo(int face, const cv::Vec3d& p) {
  if (face == kFloor) {
    const double tile = 0.4, grout = 0.004;
    const double gx = std::floor(p[0] / tile), gy = std::floor(p[1] / tile);
    const double xl = p[0] - gx * tile, yl = p[1] - gy * tile;
    if (xl < grout || yl < grout) return {170, 160, 148};
    const auto ix = static_cast<std::int64_t>(gx), iy = static_cast<std::int64_t>(gy);
    const double tone = 0.90 + 0.18 * hash01(ix, iy, 51);
    const double warm = hash01(ix, iy, 52) - 0.5;
    const cv::Vec3d base(214 * (1 + 0.05 * warm), 166, 130 * (1 - 0.06 * warm));
    const double mottle = 1 + 0.08 * (value_noise(p[0] * 10, p[1] * 10, 53) - 0.5) +
                          0.07 * (value_noise(p[0] * 35, p[1] * 35, 54) - 0.5) +
                          0.05 * (value_noise(p[0] * 100, p[1] * 100, 55) - 0.5);
    return base * (tone * mottle);
  }
  if (face == kCeiling) return cv::Vec3d(188, 188, 186) * (0.98 + 0.04 * value_noise(p[0] * 3, p[1] * 3, 21));
  std::uint64_t salt = 30;
  const double u = wall_u(face, p, &salt), z = p[2];
  if (z < 0.10) return {222, 220, 212};  // skirting board, flat white
  cv::Vec3d c;
  cv::Vec3d paint(204, 202, 194);
  switch (face) {
    case kWallPosY:  // behind the performer as the front cameras see it
      if (framed({0.9, 1.8, 0.10, 2.05}, u, z, cv::Vec3d(60, 60, 66), 0.04, &c)) return c;  // door ~ trousers
      if (framed({-2.6, -1.8, 1.0, 1.8}, u, z, cv::Vec3d(220, 170, 136), 0.02, &c))
        return c;             // skin-toned poster
      paint = {42, 80, 164};  // blue ~ shirt
      break;
    case kWallNegY:
      if (framed({-1.2, 0.6, 0.9, 1.9}, u, z, cv::Vec3d(236, 236, 232), 0.04, &c)) return c;  // whiteboard
      if (framed({1.2, 2.0, 0.7, 1.7}, u, z, cv::Vec3d(150, 100, 70), 0.02, &c))
        return c;             // brown-skin poster
      paint = {170, 44, 44};  // red ~ shirt
      break;
    case kWallPosX:
      if (framed({0.9, 1.7, 0.8, 1.8}, u, z, cv::Vec3d(196, 150, 108), 0.02, &c))
        return c;             // olive-skin poster
      paint = {50, 118, 62};  // green ~ shirt
      break;
    default:
      if (framed({-2.0, 0.0, 0.3, 2.0}, u, z, cv::Vec3d(200, 200, 196), 0.03, &c)) return c;  // grey panel
      paint = {214, 148, 44};                                                                 // ochre ~ shirt
      break;
  }
  if (z >= 2.0) paint = {204, 202, 194};
  return paint *
         (0.95 + 0.06 * value_noise(u * 7, z * 7, salt) + 0.04 * value_noise(u * 45, z * 45, salt + 1) +
          0.02 * value_noise(u * 140, z * 140, salt + 2));
}

}  // namespace

int room_style(const std::string& name) {
  if (name == "default") return kRoomDefault;
  if (name == "camouflage") return kRoomCamouflage;
  return -1;
}

cv::Vec3d Room::albedo(int face, const cv::Vec3d& p) const {
  if (style == kRoomCamouflage) return camouflage_albedo(face, p);
  const cv::Vec3d paint(204, 202, 194);
  if (face == kFloor) {
    // Oak planks along x: 0.2 m wide, 1.6 m long, rows staggered; grain and dark seams.
    const double w = 0.2, len = 1.6;
    const double row = std::floor(p[1] / w);
    const double yl = p[1] - row * w;
    const double shift = hash01(static_cast<std::int64_t>(row), 0, 11) * len;
    const double col = std::floor((p[0] + shift) / len);
    const double xl = p[0] + shift - col * len;
    const auto ir = static_cast<std::int64_t>(row), ic = static_cast<std::int64_t>(col);
    const double tone = 0.80 + 0.32 * hash01(ir, ic, 12);
    const double warm = hash01(ir, ic, 15) - 0.5;
    const cv::Vec3d base(160 * (1 + 0.08 * warm), 114, 74 * (1 - 0.1 * warm));
    const double grain =
        1 + 0.07 * std::sin(2 * M_PI * (yl * 28 + 2.5 * value_noise(p[0] * 1.3, row * 7.3, 13))) +
        0.08 * (value_noise(p[0] * 6, p[1] * 45, 14) - 0.5);
    const bool seam = yl < 0.004 || yl > w - 0.004 || xl < 0.005;
    return base * (tone * grain * (seam ? 0.5 : 1.0));
  }
  if (face == kCeiling) return cv::Vec3d(188, 188, 186) * (0.98 + 0.04 * value_noise(p[0] * 3, p[1] * 3, 21));
  // Walls: u runs along the wall (left to right seen from the room's centre), z up.
  double u = 0;
  std::uint64_t salt = 30;
  switch (face) {
    case kWallPosY:
      u = p[0];
      salt = 31;
      break;
    case kWallNegY:
      u = -p[0];
      salt = 32;
      break;
    case kWallPosX:
      u = -p[1];
      salt = 33;
      break;
    default:
      u = p[1];
      salt = 34;
      break;
  }
  const double z = p[2];
  if (z < 0.10) return cv::Vec3d(72, 64, 56);  // skirting board
  cv::Vec3d c;
  switch (face) {
    case kWallPosY:  // behind the performer as the front cameras see it
      if (framed({-1.7, -0.25, 0.55, 2.05}, u, z, cv::Vec3d(40, 80, 165), 0.03, &c))
        return c;                                                                     // blue ~ shirt
      if (framed({0.75, 1.75, 0.10, 2.05}, u, z, cv::Vec3d(60, 60, 66), 0.05, &c)) {  // door ~ trousers
        if (std::hypot(u - 1.62, z - 1.0) < 0.035) return {190, 175, 120};            // handle
        return c;
      }
      if (framed({2.2, 3.0, 1.0, 1.8}, u, z, cv::Vec3d(218, 170, 138), 0.02, &c))
        return c;  // skin-toned poster
      if (framed({-3.4, -2.4, 0.9, 1.5}, u, z, cv::Vec3d(175, 45, 42), 0.02, &c)) return c;  // red ~ shirt
      break;
    case kWallNegY:
      if (framed({-1.2, 0.6, 0.9, 2.0}, u, z, cv::Vec3d(236, 236, 232), 0.04, &c)) return c;  // whiteboard
      if (framed({1.2, 2.0, 0.6, 1.7}, u, z, cv::Vec3d(196, 150, 108), 0.02, &c))
        return c;  // olive-skin poster
      break;
    case kWallPosX: {
      if (Rect{-0.4, 0.32, 1.0, 1.48}.in(u, z)) {  // checkerboard, 8 cm squares
        const int a = static_cast<int>(std::floor((u + 0.4) / 0.08)),
                  b = static_cast<int>(std::floor((z - 1.0) / 0.08));
        return ((a + b) & 1) ? cv::Vec3d(25, 25, 25) : cv::Vec3d(235, 235, 235);
      }
      if (framed({0.9, 2.3, 0.5, 1.9}, u, z, cv::Vec3d(50, 118, 64), 0.03, &c)) return c;    // green ~ shirt
      if (framed({-2.6, -1.2, 0.3, 1.2}, u, z, cv::Vec3d(56, 70, 118), 0.03, &c)) return c;  // jeans blue
      break;
    }
    default: {
      if (Rect{-2.2, 0.0, 0.1, 1.9}.in(u, z)) {  // shelves with books of random colours
        const double shelf = std::fmod(z - 0.1, 0.45);
        if (shelf < 0.03) return {110, 80, 55};
        const auto book = static_cast<std::int64_t>(std::floor((u + 2.2) / 0.045));
        const auto level = static_cast<std::int64_t>(std::floor((z - 0.1) / 0.45));
        const double top = 0.3 + 0.12 * hash01(book, level, 41);
        if (shelf > top) return {60, 48, 40};
        const double h = hash01(book, level, 42) * 6.0;  // hue sextant
        const double v = 90 + 110 * hash01(book, level, 43);
        const double f = h - std::floor(h);
        const cv::Vec3d hues[6] = {{1, f, 0.2},     {1 - f, 1, 0.2}, {0.2, 1, f},
                                   {0.2, 1 - f, 1}, {f, 0.2, 1},     {1, 0.2, 1 - f}};
        return hues[static_cast<int>(h) % 6] * v;
      }
      if (framed({0.8, 2.0, 0.6, 1.8}, u, z, cv::Vec3d(218, 148, 42), 0.03, &c)) return c;  // orange ~ shirt
      break;
    }
  }
  return plaster(u, z, paint, salt);
}

cv::Vec3d Room::shade(int face, const cv::Vec3d& p) const {
  static const cv::Vec3d normals[6] = {{0, 0, 1}, {0, 0, -1}, {-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}};
  const cv::Vec3d l = cv::normalize(light_m - p);
  const double ndl = std::max(0.0, normals[face].dot(l));
  return albedo(face, p) * (0.55 + 0.5 * ndl);
}

}  // namespace vc::sim::detail

namespace vc::sim {

const std::vector<RoomPreset>& room_presets() {
  static const std::vector<RoomPreset> presets = {
      {"default",
       "wooden plank floor, off-white plaster walls with posters, a door, a checkerboard, shelves"},
      {"camouflage",
       "beige tiled floor close to the skin presets, walls painted close to the shirt presets (blue, red, "
       "green, ochre) with plaster texture; flat posters, door, whiteboard, grey panel"},
  };
  return presets;
}

}  // namespace vc::sim
