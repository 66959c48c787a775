// Ray-cast benchmark scene (see edge_scene.hpp). Rendering: per pixel, the precomputed world ray of
// the (distorted) camera hits the room box or the nearest body ellipsoid; floor points whose ray to
// the light hits the body are darkened (a cast shadow); Gaussian-like sensor noise is added from a
// counter-based hash so that every frame is reproducible.
#include "edge_scene.hpp"

#include <algorithm>
#include <cmath>

#include "voxcap/rig/c_models.hpp"

namespace vc::bench {
namespace {

constexpr double kRoom = 4.5;  // half-size of the room box (m), cameras stand inside it
const cv::Vec3d kLight = cv::normalize(cv::Vec3d(0.35, 0.25, 1.0));

uint64_t splitmix(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Sum of four uniforms (Irwin-Hall), scaled to standard deviation `sigma`.
double noise(uint64_t key, double sigma) {
  uint64_t h = splitmix(key);
  double s = 0;
  for (int i = 0; i < 4; i++) s += static_cast<double>((h >> (16 * i)) & 0xFFFF) / 65535.0;
  return (s - 2.0) * sigma * std::sqrt(3.0);
}

Ellipsoid limb(const cv::Vec3d& a, const cv::Vec3d& b, double r, cv::Vec3b rgb) {
  cv::Vec3d u = b - a;
  double len = cv::norm(u);
  u /= len;
  cv::Vec3d helper = std::fabs(u[2]) < 0.9 ? cv::Vec3d(0, 0, 1) : cv::Vec3d(1, 0, 0);
  cv::Vec3d v = cv::normalize(u.cross(helper)), w = u.cross(v);
  double half = len / 2 + 0.5 * r;
  cv::Matx33d rows(u[0] / half, u[1] / half, u[2] / half, v[0] / r, v[1] / r, v[2] / r, w[0] / r, w[1] / r,
                   w[2] / r);
  return {(a + b) * 0.5, rows, rgb};
}

Ellipsoid blob(const cv::Vec3d& c, double rx, double ry, double rz, cv::Vec3b rgb) {
  return {c, cv::Matx33d(1 / rx, 0, 0, 0, 1 / ry, 0, 0, 0, 1 / rz), rgb};
}

// Nearest t > 0 where origin + t*dir enters the ellipsoid, or -1.
double hit(const Ellipsoid& e, const cv::Vec3d& origin, const cv::Vec3d& dir) {
  cv::Vec3d o = e.unit_from_world * (origin - e.center_world), d = e.unit_from_world * dir;
  double a = d.dot(d), b = 2 * o.dot(d), c = o.dot(o) - 1;
  double disc = b * b - 4 * a * c;
  if (disc < 0) return -1;
  double t = (-b - std::sqrt(disc)) / (2 * a);
  return t > 1e-9 ? t : -1;
}

}  // namespace

EdgeScene::EdgeScene(int width, int height, uint64_t seed) : width_(width), height_(height), seed_(seed) {
  const double angles_deg[2] = {25.0, -30.0};
  const double f = 0.82 * width;
  for (int c = 0; c < 2; c++) {
    double a = angles_deg[c] * M_PI / 180.0;
    cv::Vec3d eye(3.6 * std::cos(a), 3.6 * std::sin(a), 1.7);
    cams_[c] =
        vc::rig::Camera::look_at(c == 0 ? "cam0" : "cam1", width, height, f, eye, cv::Vec3d(0, 0, 1.0));
    cams_[c].K(0, 2) += 3.3;
    cams_[c].K(1, 2) -= 2.1;
    cams_[c].dist = cv::Vec<double, 5>(-0.12, 0.035, 0.0006, -0.0004, 0.0);
  }
}

void EdgeScene::prepare_rays(int c) const {
  auto& rays = rays_world_[c];
  if (!rays.empty()) return;
  rays.resize(static_cast<size_t>(width_) * height_);
  for (int y = 0; y < height_; y++)
    for (int x = 0; x < width_; x++) {
      cv::Vec3d d = cams_[c].ray_world(cv::Point2d(x, y));
      rays[static_cast<size_t>(y) * width_ + x] =
          cv::Vec3f(static_cast<float>(d[0]), static_cast<float>(d[1]), static_cast<float>(d[2]));
    }
}

vc_camera EdgeScene::camera_model(int c) const {
  return vc::rig::to_c_camera(cams_[c]);
}

vc_voxel_grid EdgeScene::grid(int n) {
  vc_voxel_grid g{};
  g.min_m[0] = -1.0;
  g.min_m[1] = -1.0;
  g.min_m[2] = 0.0;
  g.voxel_m = 2.0 / n;
  g.nx = g.ny = g.nz = static_cast<uint32_t>(n);
  return g;
}

std::vector<Ellipsoid> EdgeScene::body(int frame) const {
  const cv::Vec3b skin(222, 172, 140), shirt(45, 95, 165), trousers(72, 62, 58);
  const double s = std::sin(0.25 * frame);
  const cv::Vec3d root(-0.25 + 0.2 * std::sin(0.05 * frame), 0.1 * std::cos(0.07 * frame), 0);
  std::vector<Ellipsoid> parts;
  parts.push_back(blob(root + cv::Vec3d(0, 0, 1.22), 0.12, 0.19, 0.28, shirt));     // chest
  parts.push_back(blob(root + cv::Vec3d(0, 0, 0.95), 0.11, 0.17, 0.13, trousers));  // pelvis
  parts.push_back(blob(root + cv::Vec3d(0, 0, 1.62), 0.095, 0.085, 0.12, skin));    // head
  for (int side = -1; side <= 1; side += 2) {
    double phi = 0.5 * s * side;
    cv::Vec3d shoulder = root + cv::Vec3d(0, 0.21 * side, 1.43);
    cv::Vec3d elbow = shoulder + 0.28 * cv::Vec3d(std::sin(phi), 0.05 * side, -std::cos(phi));
    cv::Vec3d hand = elbow + 0.25 * cv::Vec3d(std::sin(phi + 0.4), 0.0, -std::cos(phi + 0.4));
    parts.push_back(limb(shoulder, elbow, 0.05, shirt));
    parts.push_back(limb(elbow, hand, 0.04, skin));
    parts.push_back(blob(hand + 0.05 * cv::normalize(hand - elbow), 0.05, 0.035, 0.06, skin));
    double psi = -0.4 * s * side;
    cv::Vec3d hip = root + cv::Vec3d(0, 0.1 * side, 0.9);
    cv::Vec3d knee = hip + 0.43 * cv::Vec3d(std::sin(psi), 0, -std::cos(psi));
    cv::Vec3d ankle = knee + 0.4 * cv::Vec3d(std::sin(psi - 0.25), 0, -std::cos(psi - 0.25));
    ankle[2] = std::max(ankle[2], 0.08);
    parts.push_back(limb(hip, knee, 0.075, trousers));
    parts.push_back(limb(knee, ankle, 0.055, trousers));
    parts.push_back(limb(ankle, ankle + cv::Vec3d(0.17, 0, -0.04), 0.04, skin));  // bare foot
  }
  return parts;
}

void EdgeScene::render(int frame, int cam, std::vector<uint8_t>& rgb) const {
  rgb.resize(static_cast<size_t>(width_) * height_ * 3);
  const std::vector<Ellipsoid> parts = frame >= 0 ? body(frame) : std::vector<Ellipsoid>{};
  // Bounding sphere of the body for a cheap rejection per ray.
  cv::Vec3d bc(0, 0, 0);
  double br = 0;
  if (!parts.empty()) {
    for (const auto& e : parts) bc += e.center_world;
    bc *= 1.0 / parts.size();
    for (const auto& e : parts) {
      double r = 1.0 / std::min({cv::norm(e.unit_from_world.row(0)), cv::norm(e.unit_from_world.row(1)),
                                 cv::norm(e.unit_from_world.row(2))});
      br = std::max(br, cv::norm(e.center_world - bc) + r);
    }
  }
  auto sphere_hit = [&](const cv::Vec3d& o, const cv::Vec3d& d) {
    cv::Vec3d oc = o - bc;
    double b = oc.dot(d), c = oc.dot(oc) - br * br;
    return b * b - c >= 0 && (b < 0 || c < 0);
  };
  prepare_rays(cam);
  const cv::Vec3d eye = cams_[cam].center_world();
  const auto& rays = rays_world_[cam];
  const uint64_t key0 =
      splitmix(seed_ ^ (static_cast<uint64_t>(frame + 1000000) << 20) ^ static_cast<uint64_t>(cam));
  for (int y = 0; y < height_; y++)
    for (int x = 0; x < width_; x++) {
      const size_t i = static_cast<size_t>(y) * width_ + x;
      const cv::Vec3d d(rays[i][0], rays[i][1], rays[i][2]);
      // Room: exit point of the box [-R, R]^2 x [0, 3].
      double t_room = 1e9;
      int axis = 0;
      for (int k = 0; k < 3; k++) {
        if (std::fabs(d[k]) < 1e-12) continue;
        double lo = k == 2 ? 0.0 : -kRoom, hi = k == 2 ? 3.0 : kRoom;
        double t = ((d[k] > 0 ? hi : lo) - eye[k]) / d[k];
        if (t < t_room) {
          t_room = t;
          axis = k;
        }
      }
      cv::Vec3d p = eye + t_room * d;
      double c[3];
      if (axis == 2 && d[2] < 0) {  // floor: checker of 0.5 m with a fine texture
        bool dark = (static_cast<int>(std::floor(p[0] * 2)) + static_cast<int>(std::floor(p[1] * 2))) & 1;
        double tex = 6 * std::sin(p[0] * 23) * std::sin(p[1] * 19);
        c[0] = (dark ? 118 : 152) + tex;
        c[1] = (dark ? 114 : 146) + tex;
        c[2] = (dark ? 104 : 132) + tex;
        if (!parts.empty() && sphere_hit(p, kLight)) {
          for (const auto& e : parts)
            if (hit(e, p, kLight) > 0) {
              for (double& v : c) v *= 0.55;
              break;
            }
        }
      } else {  // walls and ceiling: warm paint with soft vertical bands
        double band = 10 * std::sin((p[0] + p[1]) * 3.1) + 8 * std::cos(p[2] * 2.3);
        c[0] = 188 + band;
        c[1] = 176 + band * 0.8;
        c[2] = 150 + band * 0.5;
      }
      if (!parts.empty() && sphere_hit(eye, d)) {
        double best = t_room;
        const Ellipsoid* hit_e = nullptr;
        for (const auto& e : parts) {
          double t = hit(e, eye, d);
          if (t > 0 && t < best) {
            best = t;
            hit_e = &e;
          }
        }
        if (hit_e != nullptr) {
          cv::Vec3d q = hit_e->unit_from_world * (eye + best * d - hit_e->center_world);
          cv::Vec3d n = cv::normalize(hit_e->unit_from_world.t() * q);
          double shade = 0.55 + 0.45 * std::max(0.0, n.dot(kLight));
          for (int k = 0; k < 3; k++) c[k] = hit_e->rgb[k] * shade;
        }
      }
      for (int k = 0; k < 3; k++) {
        double v = std::round(c[k] + noise(key0 + i * 3 + static_cast<uint64_t>(k), 2.0));
        rgb[3 * i + static_cast<size_t>(k)] = static_cast<uint8_t>(std::clamp(v, 0.0, 255.0));
      }
    }
}

}  // namespace vc::bench
