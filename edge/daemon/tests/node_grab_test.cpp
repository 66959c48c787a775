// GRAB on the node (protocol 2.4): only a running node takes it; the frames it selects (every N-th
// seq from the first, `count` of them) give one FRAME per asked camera whose pixels are the frame the
// node processed, before subtraction (rgb8 as it is, gray8 as luma), without stride; STOP, START and
// CONFIG end it; a camera the node does not have is refused with a reason.
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "node.h"
#include "node_fixture.hpp"

namespace {

using vc_node_test::H;
using vc_node_test::image;
using vc_node_test::make_config;
using vc_node_test::NodeFixture;
using vc_node_test::W;

vc_msg decode(const uint8_t* b, size_t len) {
  vc_msg m{};
  size_t used = 0;
  vc_proto_diag diag{};
  EXPECT_EQ(vc_msg_decode(b, len, 0, &m, &used, &diag), 1) << diag.detail;
  return m;
}

TEST(NodeGrab, OnlyARunningNodeTakesIt) {
  vc_node_camera cams[2] = {{W, H, VC_FOURCC('R', 'G', 'B', '3'), 60000},
                            {W, H, VC_FOURCC('R', 'G', 'B', '3'), 60000}};
  vc_node* n = nullptr;
  char why[160] = "";
  ASSERT_EQ(vc_node_new(4, cams, &n, why, sizeof why), 0) << why;
  const vc_grab g{2, VC_FRAME_RGB8, 3, 0};
  EXPECT_EQ(vc_node_grab(n, &g, 0, why, sizeof why), -EAGAIN);
  EXPECT_NE(std::string(why).find("not running"), std::string::npos) << why;
  EXPECT_FALSE(vc_node_grabbing(n));
  vc_node_free(n);
}

TEST(NodeGrab, SelectedFramesCarryTheProcessedImages) {
  NodeFixture f(make_config(0, 0));
  char why[160] = "";
  const vc_grab g{4, VC_FRAME_RGB8, 0x3, 2};  // seq 104 and 108, then it stops
  ASSERT_EQ(vc_node_grab(f.n, &g, 101, why, sizeof why), 0) << why;
  EXPECT_TRUE(vc_node_grabbing(f.n));
  int grabbed = 0;
  for (uint64_t seq = 100; seq < 116; seq++) {
    // camera 0 and 1 see different frames, with a stride wider than a row
    const size_t stride = W * 3 + 6;
    std::vector<uint8_t> img[2];
    for (int c = 0; c < 2; c++) {
      std::vector<uint8_t> tight = image(10 + int(seq % 7) + 5 * c, 40, 20, 50);
      img[c].assign(stride * H, 0xAB);
      for (int y = 0; y < H; y++) std::memcpy(&img[c][y * stride], &tight[size_t(y) * W * 3], W * 3);
    }
    const uint8_t* rgb[2] = {img[0].data(), img[1].data()};
    const size_t strides[2] = {stride, stride};
    vc_node_output out;
    ASSERT_EQ(vc_node_process_frame(f.n, seq, seq * 10, rgb, strides, &out), 0);
    const int k = vc_node_frames(f.n, seq, seq * 10, rgb, strides, &out);
    const bool want = (seq == 104 || seq == 108);
    ASSERT_EQ(k, want ? 2 : 0) << seq;
    for (int i = 0; i < k; i++) {
      EXPECT_EQ(out.type[i], VC_MSG_FRAME);
      vc_msg m = decode(out.msg[i], out.len[i]);
      ASSERT_EQ(m.hdr.type, VC_MSG_FRAME);
      EXPECT_EQ(m.hdr.seq, seq);
      EXPECT_EQ(m.hdr.t_trigger_ns, seq * 10);
      EXPECT_EQ(m.hdr.node_id, 4);
      const vc_frame_msg& fr = m.u.frame;
      ASSERT_EQ(fr.camera, i);
      ASSERT_EQ(fr.width, W);
      ASSERT_EQ(fr.height, H);
      for (int y = 0; y < H; y++)
        ASSERT_EQ(std::memcmp(fr.pixels + size_t(y) * W * 3, &img[i][y * stride], W * 3), 0) << y;
    }
    grabbed += k ? 1 : 0;
  }
  EXPECT_EQ(grabbed, 2);
  EXPECT_FALSE(vc_node_grabbing(f.n));  // count reached
  vc_node_counters nc;
  vc_node_get_counters(f.n, &nc);
  EXPECT_EQ(nc.frames_encoded, 4u);
}

TEST(NodeGrab, GrayOneCameraAndWhatEndsIt) {
  NodeFixture f(make_config(0, 0));
  char why[160] = "";
  const vc_grab g{1, VC_FRAME_GRAY8, 0x2, 0};
  ASSERT_EQ(vc_node_grab(f.n, &g, 0, why, sizeof why), 0) << why;
  std::vector<uint8_t> img = image(10, 40, 20, 50);
  const uint8_t* rgb[2] = {img.data(), img.data()};
  const size_t stride[2] = {W * 3, W * 3};
  vc_node_output out;
  ASSERT_EQ(vc_node_process_frame(f.n, 100, 1, rgb, stride, &out), 0);
  ASSERT_EQ(vc_node_frames(f.n, 100, 1, rgb, stride, &out), 1);
  vc_msg m = decode(out.msg[0], out.len[0]);
  EXPECT_EQ(m.u.frame.camera, 1);
  EXPECT_EQ(m.u.frame.format, VC_FRAME_GRAY8);
  ASSERT_EQ(m.u.frame.pixels_len, uint32_t(W * H));
  for (int i = 0; i < W * H; i += 97) {
    const double y = 0.299 * img[3 * i] + 0.587 * img[3 * i + 1] + 0.114 * img[3 * i + 2];
    EXPECT_NEAR(m.u.frame.pixels[i], y, 1.0);
  }
  // A camera the node does not have: refused with a reason, the cameras it has are grabbed.
  const vc_grab g4{1, VC_FRAME_GRAY8, 0x5, 0};
  EXPECT_EQ(vc_node_grab(f.n, &g4, 0, why, sizeof why), -ENODEV);
  EXPECT_NE(std::string(why).find("the node has 2"), std::string::npos) << why;
  EXPECT_TRUE(vc_node_grabbing(f.n));
  const vc_grab none{1, VC_FRAME_GRAY8, 0x4, 0};
  EXPECT_EQ(vc_node_grab(f.n, &none, 0, why, sizeof why), -ENODEV);
  // STOP ends it, and a later START does not bring it back.
  vc_node_stop(f.n);
  EXPECT_FALSE(vc_node_grabbing(f.n));
  ASSERT_EQ(vc_node_start(f.n, 0), 0);
  ASSERT_EQ(vc_node_process_frame(f.n, 101, 1, rgb, stride, &out), 0);
  EXPECT_EQ(vc_node_frames(f.n, 101, 1, rgb, stride, &out), 0);
  // every 0 stops.
  ASSERT_EQ(vc_node_grab(f.n, &g, 0, why, sizeof why), 0);
  const vc_grab stop{0, 0, 0, 0};
  ASSERT_EQ(vc_node_grab(f.n, &stop, 0, why, sizeof why), 0);
  EXPECT_FALSE(vc_node_grabbing(f.n));
}

}  // namespace
