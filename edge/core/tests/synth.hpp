// Small synthetic scenes for the edge/core unit tests: textured, noisy RGB backgrounds with coloured
// blobs (foreground) and darkened regions (shadows) whose truth is known per pixel, and random rigs
// of two calibrated cameras with distortion around a voxel grid.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "voxcap/edge/carver.h"

namespace vc::edge_test {

enum class Truth : uint8_t { kBackground = 0, kShadow = 1, kForeground = 2 };

struct Blob {
  double cx, cy, rx, ry;  // ellipse, pixels
  uint8_t r, g, b;        // foreground colour, or unused for shadows
  double gain;            // shadow: background multiplied by this
};

struct Scene {
  int width = 320, height = 240;
  double noise_sigma = 2.0;
  std::vector<Blob> people;   // foreground ellipses
  std::vector<Blob> shadows;  // shadow ellipses (drawn below the people)

  // Noise-free background colour of pixel (x, y): smooth gradients plus a texture, like a room.
  void background(int x, int y, double rgb[3]) const {
    double tx = std::sin(x * 0.21) * std::cos(y * 0.13);
    double checker = ((x / 16 + y / 16) % 2) ? 18.0 : 0.0;
    rgb[0] = 90.0 + 60.0 * x / width + 15.0 * tx + checker;
    rgb[1] = 110.0 + 40.0 * y / height - 10.0 * tx + checker * 0.5;
    rgb[2] = 70.0 + 30.0 * (x + y) / (width + height) + 8.0 * tx;
  }

  static bool inside(const Blob& b, int x, int y) {
    double dx = (x - b.cx) / b.rx, dy = (y - b.cy) / b.ry;
    return dx * dx + dy * dy <= 1.0;
  }

  // Renders a frame (interleaved RGB, stride 3*width) and its per-pixel truth.
  void render(std::mt19937& rng, std::vector<uint8_t>& rgb, std::vector<Truth>* truth) const {
    std::normal_distribution<double> noise(0.0, noise_sigma);
    rgb.resize(static_cast<size_t>(width) * height * 3);
    if (truth) truth->assign(static_cast<size_t>(width) * height, Truth::kBackground);
    for (int y = 0; y < height; y++)
      for (int x = 0; x < width; x++) {
        double c[3];
        background(x, y, c);
        Truth t = Truth::kBackground;
        for (const Blob& s : shadows)
          if (inside(s, x, y)) {
            for (double& v : c) v *= s.gain;
            t = Truth::kShadow;
            break;
          }
        for (const Blob& p : people)
          if (inside(p, x, y)) {
            // Shading across the blob, so the foreground is not flat.
            double shade = 0.8 + 0.2 * std::cos((x - p.cx) / p.rx);
            c[0] = p.r * shade;
            c[1] = p.g * shade;
            c[2] = p.b * shade;
            t = Truth::kForeground;
            break;
          }
        size_t i = (static_cast<size_t>(y) * width + x) * 3;
        for (int k = 0; k < 3; k++) {
          double v = std::round(c[k] + noise(rng));
          rgb[i + k] = static_cast<uint8_t>(v < 0 ? 0 : v > 255 ? 255 : v);
        }
        if (truth) (*truth)[static_cast<size_t>(y) * width + x] = t;
      }
  }
};

// A camera at `eye` looking at `target` (z up), OpenCV convention (x right, y down, z forward).
inline vc_camera look_at(const double eye[3], const double target[3], int w, int h, double f,
                         const double dist[5]) {
  vc_camera c{};
  c.width = static_cast<uint32_t>(w);
  c.height = static_cast<uint32_t>(h);
  double z[3] = {target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]};
  double n = std::sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2]);
  for (double& v : z) v /= n;
  const double up[3] = {0, 0, 1};
  // x = z × up (points right when looking along z with z up), y = z × x (points down).
  double x[3] = {z[1] * up[2] - z[2] * up[1], z[2] * up[0] - z[0] * up[2], z[0] * up[1] - z[1] * up[0]};
  n = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
  for (double& v : x) v /= n;
  double y[3] = {z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]};
  for (int k = 0; k < 3; k++) {
    c.R_cam_from_world[0 + k] = x[k];
    c.R_cam_from_world[3 + k] = y[k];
    c.R_cam_from_world[6 + k] = z[k];
  }
  for (int r = 0; r < 3; r++) {
    const double* R = &c.R_cam_from_world[3 * r];
    c.t_cam_from_world[r] = -(R[0] * eye[0] + R[1] * eye[1] + R[2] * eye[2]);
  }
  c.K[0] = f;
  c.K[2] = w / 2.0 - 0.37;  // off-centre principal point: no symmetric rounding ties
  c.K[4] = f * 1.01;
  c.K[5] = h / 2.0 + 0.23;
  c.K[8] = 1.0;
  for (int k = 0; k < 5; k++) c.dist[k] = dist[k];
  return c;
}

}  // namespace vc::edge_test
