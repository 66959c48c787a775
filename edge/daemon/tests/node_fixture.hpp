// The node on two small synthetic cameras, shared by the node's SILHOUETTE and GRAB tests: a CONFIG
// over an 8^3 grid seen by two cameras 3 m away, images of a grey-blue background with a red rectangle,
// and a node configured, its background learnt and running.
#pragma once

#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "node.h"

namespace vc_node_test {

constexpr int W = 90, H = 70;  // not multiples of the scales tried: the last blocks are clipped

inline vc_config make_config(uint8_t every, uint8_t scale) {
  vc_config cfg{};
  cfg.grid_id = 5;
  cfg.grid.nx = cfg.grid.ny = cfg.grid.nz = 8;
  cfg.grid.min_m[0] = -0.4;
  cfg.grid.min_m[1] = -0.4;
  cfg.grid.min_m[2] = 0.6;
  cfg.grid.voxel_m = 0.1;
  cfg.t_upper = 10;
  cfg.t_lower = 3;
  cfg.shadow_angle_deg = 6;
  cfg.cleanup_radius_px = 1;
  cfg.background_frames = 3;
  cfg.carve_rule = VC_CARVE_CENTRE;
  cfg.silhouette_every = every;
  cfg.silhouette_scale = scale;
  cfg.camera_count = 2;
  for (int c = 0; c < 2; c++) {  // two cameras 3 m away along -y and -x, looking at (0, 0, 1)
    vc_camera& k = cfg.cameras[c];
    k.width = W;
    k.height = H;
    const double K[9] = {80, 0, W / 2.0, 0, 80, H / 2.0, 0, 0, 1};
    std::memcpy(k.K, K, sizeof K);
    const double R0[9] = {1, 0, 0, 0, 0, -1, 0, 1, 0}, R1[9] = {0, -1, 0, 0, 0, -1, 1, 0, 0};
    std::memcpy(k.R_cam_from_world, c ? R1 : R0, sizeof R0);
    k.t_cam_from_world[0] = 0;
    k.t_cam_from_world[1] = 1;
    k.t_cam_from_world[2] = 3;
  }
  return cfg;
}

// Background grey-blue; a red rectangle [x0, x1) x [y0, y1) in the live frames.
inline std::vector<uint8_t> image(int x0, int x1, int y0, int y1) {
  std::vector<uint8_t> f(size_t{W} * H * 3);
  for (int y = 0; y < H; y++)
    for (int x = 0; x < W; x++) {
      uint8_t* p = &f[(size_t(y) * W + x) * 3];
      const bool in = x >= x0 && x < x1 && y >= y0 && y < y1;
      const unsigned noise = (unsigned(x * 7 + y * 13) % 3);
      p[0] = uint8_t(in ? 230 : 100 + noise);
      p[1] = uint8_t(in ? 20 : 110 + noise);
      p[2] = uint8_t(in ? 30 : 120 + noise);
    }
  return f;
}

struct NodeFixture {
  vc_node* n = nullptr;
  std::vector<uint8_t> bg = image(0, 0, 0, 0);
  explicit NodeFixture(const vc_config& cfg) {
    vc_node_camera cams[2] = {{W, H, VC_FOURCC('R', 'G', 'B', '3'), 60000},
                              {W, H, VC_FOURCC('R', 'G', 'B', '3'), 60000}};
    char why[160] = "";
    EXPECT_EQ(vc_node_new(4, cams, &n, why, sizeof why), 0) << why;
    char warn[160] = "";
    EXPECT_EQ(vc_node_configure(n, &cfg, why, sizeof why, warn, sizeof warn), 0) << why;
    EXPECT_EQ(vc_node_background_begin(n, 0), 0);
    const uint8_t* rgb[2] = {bg.data(), bg.data()};
    const size_t stride[2] = {W * 3, W * 3};
    for (int i = 0; i < 3; i++) vc_node_background_add(n, rgb, stride);
    EXPECT_EQ(vc_node_state(n), uint32_t{VC_STATE_READY});
    EXPECT_EQ(vc_node_start(n, 100), 0);
  }
  ~NodeFixture() { vc_node_free(n); }
};

}  // namespace vc_node_test
