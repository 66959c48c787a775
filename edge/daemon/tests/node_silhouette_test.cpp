// CONFIG's carve rule and silhouettes on the node: the carver is built with the rule asked for (an
// unknown one is refused with a reason, the previous configuration kept), and every
// silhouette_every-th frame each camera's mask — the one the hull was carved with — goes out as a
// SILHOUETTE whose decoded bits are that mask, downscaled by silhouette_scale (any pixel of a block).
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "node.h"
#include "node_fixture.hpp"
#include "voxcap/rle.h"

namespace {

using vc_node_test::H;
using vc_node_test::image;
using vc_node_test::make_config;
using vc_node_test::NodeFixture;
using vc_node_test::W;

// The mask downscaled by the SPEC's rule, as bits (pixel x + sw*y).
std::vector<uint8_t> expected_bits(const uint8_t* mask, int s, int* sw, int* sh) {
  *sw = (W + s - 1) / s;
  *sh = (H + s - 1) / s;
  std::vector<uint8_t> bits((size_t(*sw) * *sh + 7) / 8, 0);
  for (int y = 0; y < H; y++)
    for (int x = 0; x < W; x++)
      if (mask[size_t(y) * W + x]) {
        const size_t b = size_t(x / s) + size_t(*sw) * size_t(y / s);
        bits[b / 8] = uint8_t(bits[b / 8] | 1u << (b % 8));
      }
  return bits;
}

void run_frames(uint8_t scale) {
  SCOPED_TRACE("scale " + std::to_string(scale));
  NodeFixture f(make_config(2, scale));
  const auto live0 = image(30, 61, 15, 56), live1 = image(20, 43, 10, 60);
  const uint8_t* rgb[2] = {live0.data(), live1.data()};
  const size_t stride[2] = {W * 3, W * 3};
  uint64_t silhouettes = 0;
  for (uint64_t seq = 100; seq < 104; seq++) {
    vc_node_output out;
    ASSERT_EQ(vc_node_process_frame(f.n, seq, 7000 + seq, rgb, stride, &out), 0);
    ASSERT_GE(out.count, 1);
    EXPECT_EQ(out.type[out.count - 1], VC_MSG_HULL);  // last: the host resolves a frame on it
    const int want = seq % 2 == 0 ? 2 : 0;            // silhouette_every 2: seq 100 and 102
    ASSERT_EQ(out.count, 1 + want) << "seq " << seq;
    for (int i = 0; i + 1 < out.count; i++) {
      EXPECT_EQ(out.type[i], VC_MSG_SILHOUETTE);
      vc_msg m;
      size_t used = 0;
      vc_proto_diag diag{};
      ASSERT_EQ(vc_msg_decode(out.msg[i], out.len[i], 0, &m, &used, &diag), 1) << diag.detail;
      EXPECT_EQ(used, out.len[i]);
      EXPECT_EQ(m.hdr.type, VC_MSG_SILHOUETTE);
      EXPECT_EQ(m.hdr.node_id, 4);
      EXPECT_EQ(m.hdr.seq, seq);
      EXPECT_EQ(m.hdr.t_trigger_ns, 7000 + seq);
      const vc_silhouette& s = m.u.silhouette;
      EXPECT_EQ(s.camera, i);
      EXPECT_EQ(s.scale, scale);
      int sw = 0, sh = 0;
      const uint8_t* mask = vc_node_mask(f.n, s.camera);
      ASSERT_NE(mask, nullptr);
      const auto want_bits = expected_bits(mask, scale, &sw, &sh);
      EXPECT_EQ(s.width, sw);
      EXPECT_EQ(s.height, sh);
      std::vector<uint8_t> got((size_t(sw) * sh + 7) / 8);
      ASSERT_EQ(vc_rle_decode(s.rle, s.rle_len, got.data(), size_t(sw) * sh), 0);
      EXPECT_EQ(got, want_bits);
      // The mask is the person's rectangle (camera 0: 31 x 41 pixels; camera 1: 23 x 50), give or take
      // the clean-up's corners: a real silhouette, not an empty or a full one.
      uint64_t fg = 0;
      for (size_t p = 0; p < size_t{W} * H; p++) fg += mask[p] != 0;
      EXPECT_NEAR(double(fg), s.camera == 0 ? 31.0 * 41 : 23.0 * 50, 8.0);
      if (scale == 1) EXPECT_EQ(s.foreground_count, fg);
      if (scale > 1) EXPECT_LT(s.foreground_count, fg);
      silhouettes++;
    }
  }
  vc_node_counters c;
  vc_node_get_counters(f.n, &c);
  EXPECT_EQ(c.silhouettes_encoded, silhouettes);
  EXPECT_EQ(silhouettes, 4u);
  EXPECT_EQ(c.silhouettes_over_limit, 0u);
  EXPECT_EQ(c.hulls_encoded, 4u);
}

TEST(NodeSilhouettes, EverySecondFrameEachCamerasMaskAtScale1) {
  run_frames(1);
}

TEST(NodeSilhouettes, EverySecondFrameEachCamerasMaskAtScale2) {
  run_frames(2);
}

TEST(NodeSilhouettes, NoneWhenEveryIsZero) {
  NodeFixture f(make_config(0, 0));
  const auto live = image(30, 61, 15, 56);
  const uint8_t* rgb[2] = {live.data(), live.data()};
  const size_t stride[2] = {W * 3, W * 3};
  for (uint64_t seq = 100; seq < 104; seq++) {
    vc_node_output out;
    ASSERT_EQ(vc_node_process_frame(f.n, seq, 0, rgb, stride, &out), 0);
    EXPECT_EQ(out.count, 1);
  }
  vc_node_counters c;
  vc_node_get_counters(f.n, &c);
  EXPECT_EQ(c.silhouettes_encoded, 0u);
}

TEST(NodeCarveRule, CentreIsTakenAnUnknownRuleIsRefusedWithAReason) {
  NodeFixture f(make_config(0, 0));  // configured with the centre rule, READY, running
  vc_config bad = make_config(0, 0);
  bad.carve_rule = 7;
  char why[200] = "", warn[200] = "";
  EXPECT_EQ(vc_node_configure(f.n, &bad, why, sizeof why, warn, sizeof warn), -EINVAL);
  EXPECT_STREQ(why, "CONFIG carve_rule 7: 0 centre, 1 footprint or 2 subpixel");
  EXPECT_EQ(vc_node_state(f.n), uint32_t{VC_STATE_RUNNING});  // the previous configuration goes on
  bad = make_config(3, 0);                                    // silhouettes without a scale
  EXPECT_EQ(vc_node_configure(f.n, &bad, why, sizeof why, warn, sizeof warn), -EINVAL);
  EXPECT_STREQ(why, "CONFIG silhouette_scale 0: 1..16");
  vc_config centre = make_config(0, 0);
  EXPECT_EQ(vc_node_configure(f.n, &centre, why, sizeof why, warn, sizeof warn), 0) << why;
  EXPECT_STREQ(why, "");
  // The footprint rule: taken once edge/core carves with it; until then refused with the carver's
  // own reason (ERROR `config` on the wire) and the node keeps what it had.
  vc_config foot = make_config(0, 0);
  foot.carve_rule = VC_CARVE_FOOTPRINT;
  const int rc = vc_node_configure(f.n, &foot, why, sizeof why, warn, sizeof warn);
  if (rc < 0) {
    EXPECT_NE(std::string(why).find("CONFIG: "), std::string::npos) << why;
    EXPECT_GT(std::strlen(why), std::strlen("CONFIG: ")) << why;
  } else {
    EXPECT_STREQ(why, "");
  }
  EXPECT_EQ(vc_node_state(f.n), uint32_t{VC_STATE_READY});
  vc_config sub = make_config(0, 0);  // and the subpixel rule (2.2)
  sub.carve_rule = VC_CARVE_SUBPIXEL;
  EXPECT_EQ(vc_node_configure(f.n, &sub, why, sizeof why, warn, sizeof warn), 0) << why;
  EXPECT_STREQ(why, "");
}

}  // namespace
