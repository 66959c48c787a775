// The node's state machine and frame path, on synthetic frames with known answers.
#include "node.h"

#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "voxcap/edge/carver.h"

namespace {

constexpr int W = 160, H = 120;

// A camera at `eye` looking at `target` (z up): rows of R are the camera's x (right), y (down), z.
vc_camera look_at(const double eye[3], const double target[3]) {
  vc_camera c{};
  c.width = W;
  c.height = H;
  double K[9] = {150, 0, W / 2.0, 0, 150, H / 2.0, 0, 0, 1};
  std::memcpy(c.K, K, sizeof(K));
  double f[3] = {target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]};
  double n = std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
  for (double& v : f) v /= n;
  double up[3] = {0, 0, 1};
  double r[3] = {f[1] * up[2] - f[2] * up[1], f[2] * up[0] - f[0] * up[2], f[0] * up[1] - f[1] * up[0]};
  n = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
  for (double& v : r) v /= n;
  double d[3] = {f[1] * r[2] - f[2] * r[1], f[2] * r[0] - f[0] * r[2], f[0] * r[1] - f[1] * r[0]};
  for (int i = 0; i < 3; i++) {
    c.R_cam_from_world[0 + i] = r[i];
    c.R_cam_from_world[3 + i] = d[i];
    c.R_cam_from_world[6 + i] = f[i];
  }
  for (int row = 0; row < 3; row++) {
    const double* Rr = &c.R_cam_from_world[row * 3];
    c.t_cam_from_world[row] = -(Rr[0] * eye[0] + Rr[1] * eye[1] + Rr[2] * eye[2]);
  }
  return c;
}

vc_config make_config() {
  vc_config cfg{};
  cfg.grid_id = 7;
  cfg.grid.nx = cfg.grid.ny = cfg.grid.nz = 16;
  cfg.grid.min_m[0] = -0.8;
  cfg.grid.min_m[1] = -0.8;
  cfg.grid.min_m[2] = 0.2;
  cfg.grid.voxel_m = 0.1;
  cfg.t_upper = 10;
  cfg.t_lower = 3;
  cfg.shadow_angle_deg = 6;
  cfg.background_frames = 4;
  cfg.camera_count = 2;
  double e0[3] = {0, -3, 1}, e1[3] = {-3, 0.3, 1.2}, tgt[3] = {0, 0, 1};
  cfg.cameras[0] = look_at(e0, tgt);
  cfg.cameras[1] = look_at(e1, tgt);
  return cfg;
}

std::vector<uint8_t> frame(uint8_t r, uint8_t g, uint8_t b, unsigned seed) {
  std::vector<uint8_t> f(W * H * 3);
  for (size_t i = 0; i < f.size(); i += 3) {
    unsigned n = (unsigned)(i * 2654435761u + seed * 40503u) >> 29;  // 0..7, deterministic noise
    f[i] = (uint8_t)(r + n % 3);
    f[i + 1] = (uint8_t)(g + n % 2);
    f[i + 2] = (uint8_t)(b + (n >> 1) % 3);
  }
  return f;
}

vc_node* make_node() {
  vc_node_camera cams[2] = {{W, H, VC_FOURCC('R', 'G', 'B', '3'), 60000},
                            {W, H, VC_FOURCC('R', 'G', 'B', '3'), 60000}};
  vc_node* n = nullptr;
  char why[128] = "";
  EXPECT_EQ(vc_node_new(3, cams, &n, why, sizeof why), 0) << why;
  return n;
}

void learn_background(vc_node* n) {
  ASSERT_EQ(vc_node_background_begin(n, 0), 0);
  EXPECT_EQ(vc_node_state(n), (uint32_t)VC_STATE_BACKGROUND);
  for (unsigned i = 0; i < 4; i++) {
    auto f = frame(100, 110, 120, i);
    const uint8_t* rgb[2] = {f.data(), f.data()};
    size_t stride[2] = {W * 3, W * 3};
    EXPECT_EQ(vc_node_background_add(n, rgb, stride), i == 3 ? 1 : 0);
  }
  EXPECT_EQ(vc_node_state(n), (uint32_t)VC_STATE_READY);
}

TEST(Node, NewRefusesImpossibleCamerasAndSaysWhy) {
  vc_node_camera cams[2] = {{W, H, 0, 0}, {0, H, 0, 0}};
  vc_node* n = reinterpret_cast<vc_node*>(0x1);
  char why[128] = "stale";
  EXPECT_EQ(vc_node_new(3, cams, &n, why, sizeof why), -EINVAL);
  EXPECT_EQ(n, nullptr);
  EXPECT_STREQ(why, "node: camera 1 is 0x120 (1..16384 each)");
  cams[1].width = W;
  ASSERT_EQ(vc_node_new(3, cams, &n, why, sizeof why), 0);
  EXPECT_STREQ(why, "");
  vc_node_free(n);
  vc_node_free(nullptr);
}

TEST(Node, HelloDescribesTheCameras) {
  vc_node* n = make_node();
  uint8_t buf[512];
  size_t len = 0;
  ASSERT_EQ(vc_node_hello(n, VC_CAP_HULL | VC_CAP_UDP_TRIGGER, buf, sizeof(buf), &len), 0);
  vc_msg m;
  size_t used = 0;
  ASSERT_EQ(vc_msg_decode(buf, len, 0, &m, &used, nullptr), 1);
  EXPECT_EQ(m.hdr.type, VC_MSG_HELLO);
  EXPECT_EQ(m.u.hello.node_id, 3);
  ASSERT_EQ(m.u.hello.camera_count, 2);
  EXPECT_EQ(m.u.hello.cameras[1].width, W);
  EXPECT_EQ(m.u.hello.capabilities, VC_CAP_HULL | VC_CAP_UDP_TRIGGER);
  vc_node_free(n);
}

TEST(Node, RejectsConfigThatDisagreesWithTheCameras) {
  vc_node* n = make_node();
  vc_config cfg = make_config();
  cfg.cameras[1].width = 320;
  char why[256], warn[256];
  EXPECT_EQ(vc_node_configure(n, &cfg, why, sizeof(why), warn, sizeof(warn)), -EINVAL);
  EXPECT_NE(std::strstr(why, "320x120"), nullptr) << why;
  EXPECT_EQ(vc_node_state(n), (uint32_t)VC_STATE_IDLE);
  cfg = make_config();
  cfg.camera_count = 1;
  EXPECT_EQ(vc_node_configure(n, &cfg, why, sizeof(why), warn, sizeof(warn)), -EINVAL);
  vc_node_free(n);
}

TEST(Node, CommandsOutOfOrderAreRefused) {
  vc_node* n = make_node();
  EXPECT_EQ(vc_node_background_begin(n, 4), -EAGAIN);
  EXPECT_EQ(vc_node_start(n, 0), -EAGAIN);
  vc_config cfg = make_config();
  char why[256], warn[256];
  ASSERT_EQ(vc_node_configure(n, &cfg, why, sizeof(why), warn, sizeof(warn)), 0) << why;
  EXPECT_EQ(vc_node_start(n, 0), -EAGAIN);  // no background yet
  auto f = frame(100, 110, 120, 0);
  const uint8_t* rgb[2] = {f.data(), f.data()};
  size_t stride[2] = {W * 3, W * 3};
  const uint8_t* msg;
  size_t len;
  EXPECT_EQ(vc_node_process(n, 1, 0, rgb, stride, &msg, &len), -EAGAIN);
  vc_node_free(n);
}

TEST(Node, FullForegroundOccupiesExactlyTheVoxelsBothCamerasSee) {
  vc_node* n = make_node();
  vc_config cfg = make_config();
  char why[256], warn[256];
  ASSERT_EQ(vc_node_configure(n, &cfg, why, sizeof(why), warn, sizeof(warn)), 0) << why;
  learn_background(n);
  ASSERT_EQ(vc_node_start(n, 100), 0);

  auto bg = frame(100, 110, 120, 9);
  auto fg = frame(230, 30, 30, 9);
  const uint8_t* rgb_bg[2] = {bg.data(), bg.data()};
  const uint8_t* rgb_fg[2] = {fg.data(), fg.data()};
  size_t stride[2] = {W * 3, W * 3};
  const uint8_t* msg = nullptr;
  size_t len = 0;
  EXPECT_EQ(vc_node_process(n, 99, 0, rgb_fg, stride, &msg, &len), 1);  // before START's first seq

  // Empty scene: an empty hull.
  ASSERT_EQ(vc_node_process(n, 100, 5000, rgb_bg, stride, &msg, &len), 0);
  vc_msg m;
  size_t used;
  ASSERT_EQ(vc_msg_decode(msg, len, 0, &m, &used, nullptr), 1);
  EXPECT_EQ(m.hdr.type, VC_MSG_HULL);
  EXPECT_EQ(m.hdr.seq, 100u);
  EXPECT_EQ(m.hdr.t_trigger_ns, 5000u);
  EXPECT_EQ(m.u.hull.grid_id, 7u);
  EXPECT_EQ(m.u.hull.voxel_count, 16u * 16 * 16);
  EXPECT_EQ(m.u.hull.occupied_count, 0u);

  // Everything foreground: exactly the voxels whose centres both cameras see.
  ASSERT_EQ(vc_node_process(n, 101, 6000, rgb_fg, stride, &msg, &len), 0);
  ASSERT_EQ(vc_msg_decode(msg, len, 0, &m, &used, nullptr), 1);
  uint64_t seen = 0;
  const vc_camera* cm = cfg.cameras;  // CONFIG's cameras are the carver's
  for (int k = 0; k < 16; k++)
    for (int j = 0; j < 16; j++)
      for (int i = 0; i < 16; i++) {
        double p[3] = {cfg.grid.min_m[0] + (i + 0.5) * 0.1, cfg.grid.min_m[1] + (j + 0.5) * 0.1,
                       cfg.grid.min_m[2] + (k + 0.5) * 0.1};
        int u, v;
        if (vc_camera_project(&cm[0], p, &u, &v) && vc_camera_project(&cm[1], p, &u, &v)) seen++;
      }
  EXPECT_GT(seen, 0u);
  EXPECT_EQ(m.u.hull.occupied_count, seen);
  ASSERT_NE(vc_node_mask(n, 0), nullptr);
  EXPECT_EQ(vc_node_mask(n, 0)[W * H / 2 + W / 2], 255);

  vc_node_counters nc;
  vc_node_get_counters(n, &nc);
  EXPECT_EQ(nc.hulls_encoded, 2u);
  vc_stage_time st[8];
  uint32_t frames = 0;
  int k = vc_node_take_stage_times(n, st, 8, &frames);
  EXPECT_EQ(k, 4);
  EXPECT_EQ(frames, 2u);
  EXPECT_EQ(st[0].stage_id, (uint32_t)VC_STAGE_SUBTRACT);
  EXPECT_GE(st[0].max_ns, st[0].mean_ns);
  vc_node_free(n);
}

TEST(Node, NewConfigKeepsTheLearntBackground) {
  vc_node* n = make_node();
  vc_config cfg = make_config();
  char why[256], warn[256];
  ASSERT_EQ(vc_node_configure(n, &cfg, why, sizeof(why), warn, sizeof(warn)), 0);
  learn_background(n);
  ASSERT_EQ(vc_node_start(n, 0), 0);
  cfg.grid.voxel_m = 0.05;
  cfg.grid.nx = cfg.grid.ny = cfg.grid.nz = 32;
  ASSERT_EQ(vc_node_configure(n, &cfg, why, sizeof(why), warn, sizeof(warn)), 0);
  EXPECT_EQ(vc_node_state(n), (uint32_t)VC_STATE_READY);
  EXPECT_EQ(vc_node_start(n, 0), 0);
  vc_node_stop(n);
  EXPECT_EQ(vc_node_state(n), (uint32_t)VC_STATE_READY);
  vc_node_free(n);
}

TEST(Node, WarnsWhenPartOfTheGridIsUnseen) {
  vc_node* n = make_node();
  vc_config cfg = make_config();
  cfg.grid.nx = 60;  // 6 m wide: far beyond both views
  char why[256], warn[256];
  ASSERT_EQ(vc_node_configure(n, &cfg, why, sizeof(why), warn, sizeof(warn)), 0);
  EXPECT_NE(std::strstr(warn, "not seen"), nullptr) << warn;
  vc_node_free(n);
}

}  // namespace

namespace {

TEST(Node, KeptBackgroundIsRestoredAfterARestart) {
  char dir[] = "/tmp/voxcap-node-XXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  vc_config cfg = make_config();
  char why[256], warn[256];
  {
    vc_node* n = make_node();
    ASSERT_EQ(vc_node_configure(n, &cfg, why, sizeof(why), warn, sizeof(warn)), 0);
    EXPECT_EQ(vc_node_save_background(n, dir), -EAGAIN);  // nothing learnt yet
    learn_background(n);
    ASSERT_EQ(vc_node_save_background(n, dir), 0);
    vc_node_free(n);
  }
  vc_node* n = make_node();  // "restarted"
  ASSERT_EQ(vc_node_load_background(n, dir, why, sizeof(why)), 0) << why;
  EXPECT_EQ(vc_node_state(n), (uint32_t)VC_STATE_IDLE);
  ASSERT_EQ(vc_node_configure(n, &cfg, why, sizeof(why), warn, sizeof(warn)), 0);
  EXPECT_EQ(vc_node_state(n), (uint32_t)VC_STATE_READY);  // no BACKGROUND needed
  ASSERT_EQ(vc_node_start(n, 0), 0);
  auto fg = frame(230, 30, 30, 1);
  const uint8_t* rgb[2] = {fg.data(), fg.data()};
  size_t stride[2] = {W * 3, W * 3};
  const uint8_t* msg;
  size_t len;
  ASSERT_EQ(vc_node_process(n, 1, 0, rgb, stride, &msg, &len), 0);
  EXPECT_EQ(vc_node_mask(n, 0)[0], 255);  // the restored model classifies
  vc_node_free(n);

  // A camera of another size does not take it; a flipped byte is caught.
  vc_node_camera small[2] = {{W / 2, H, 0, 0}, {W / 2, H, 0, 0}};
  vc_node* other = nullptr;
  ASSERT_EQ(vc_node_new(3, small, &other, nullptr, 0), 0);
  EXPECT_EQ(vc_node_load_background(other, dir, why, sizeof(why)), -EINVAL);
  EXPECT_NE(std::strstr(why, "learnt at 160x120"), nullptr) << why;
  vc_node_free(other);
  std::string path = std::string(dir) + "/background-cam1.vcbg";
  FILE* f = std::fopen(path.c_str(), "r+b");
  ASSERT_NE(f, nullptr);
  std::fseek(f, 1000, SEEK_SET);
  std::fputc(0x5A, f);
  std::fclose(f);
  vc_node* again = make_node();
  EXPECT_EQ(vc_node_load_background(again, dir, why, sizeof(why)), -EINVAL);
  EXPECT_NE(std::strstr(why, "checksum"), nullptr) << why;
  vc_node_free(again);
  char empty[] = "/tmp/voxcap-node-none-XXXXXX";
  ASSERT_NE(mkdtemp(empty), nullptr);
  vc_node* fresh = make_node();
  EXPECT_EQ(vc_node_load_background(fresh, empty, why, sizeof(why)), -ENOENT);
  vc_node_free(fresh);
  std::remove((std::string(dir) + "/background-cam0.vcbg").c_str());
  std::remove(path.c_str());
  rmdir(dir);
  rmdir(empty);
}

}  // namespace
