// Messages: byte layout against SPEC.md tables written out by hand, encode/decode round trips of
// every type, encoders refusing what decoders reject, the streaming decoder under every chunking,
// bounded memory, sticky fatal errors, and the limits.
#include <gtest/gtest.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <memory>
#include <random>
#include <vector>

#include "hull_shapes.hpp"
#include "voxcap/crc32c.h"
#include "voxcap/proto.h"
#include "voxcap/rle.h"

namespace {

using Bytes = std::vector<uint8_t>;

vc_header header(uint16_t node = 3, uint64_t seq = 0, uint64_t t = 0) {
  vc_header h{};
  h.node_id = node;
  h.seq = seq;
  h.t_trigger_ns = t;
  return h;
}

std::unique_ptr<vc_msg> new_msg(uint16_t type, uint16_t node = 3, uint64_t seq = 0, uint64_t t = 0) {
  auto m = std::make_unique<vc_msg>();
  std::memset(m.get(), 0, sizeof *m);
  m->hdr = header(node, seq, t);
  m->hdr.type = type;
  m->known = true;
  return m;
}

Bytes encode(const vc_msg& m) {
  Bytes b(VC_PROTO_HEADER_SIZE + (1 << 20));
  size_t len = 0;
  int rc = vc_msg_encode(b.data(), b.size(), &len, &m);
  EXPECT_EQ(rc, 0) << vc_proto_strerror(rc);
  b.resize(rc ? 0 : len);
  return b;
}

struct Decoded {
  int rc = 0;
  size_t consumed = 0;
  std::unique_ptr<vc_msg> msg = std::make_unique<vc_msg>();
  vc_proto_diag diag{};
};

Decoded decode(const Bytes& b, size_t max_payload = 0) {
  Decoded d;
  d.rc = vc_msg_decode(b.data(), b.size(), max_payload, d.msg.get(), &d.consumed, &d.diag);
  return d;
}

uint32_t le32(const uint8_t* p) {
  return p[0] | p[1] << 8 | p[2] << 16 | static_cast<uint32_t>(p[3]) << 24;
}

// ---- layout -----------------------------------------------------------------------------------------

TEST(Layout, HeartbeatByteByByteAsInSpec) {
  auto m = new_msg(VC_MSG_HEARTBEAT, 0x0203, 0x1112131415161718ull, 0x2122232425262728ull);
  m->hdr.flags = 0;
  m->u.heartbeat = {0x3132333435363738ull, VC_STATE_RUNNING};
  const Bytes b = encode(*m);
  Bytes expected = {'V',  'X',  'C',  'P',  2,    4,    9,    0,    0,    0,    0x03,
                    0x02, 12,   0,    0,    0,    0x18, 0x17, 0x16, 0x15, 0x14, 0x13,
                    0x12, 0x11, 0x28, 0x27, 0x26, 0x25, 0x24, 0x23, 0x22, 0x21};
  const Bytes payload = {0x38, 0x37, 0x36, 0x35, 0x34, 0x33, 0x32, 0x31, 5, 0, 0, 0};
  uint32_t pcrc = vc_crc32c(0, payload.data(), payload.size());
  for (int i = 0; i < 4; i++) expected.push_back(static_cast<uint8_t>(pcrc >> (8 * i)));
  uint32_t hcrc = vc_crc32c(0, expected.data(), 36);
  for (int i = 0; i < 4; i++) expected.push_back(static_cast<uint8_t>(hcrc >> (8 * i)));
  expected.insert(expected.end(), payload.begin(), payload.end());
  EXPECT_EQ(b, expected);
}

TEST(Layout, HullFixedPartAndRleFollowTheHeader) {
  const Bytes rle = {0x03, 0x03, 0x04};
  auto m = new_msg(VC_MSG_HULL, 1, 77, 99);
  m->u.hull = {0x01020304, 3, 10, 3, rle.data(), 0};
  const Bytes b = encode(*m);
  ASSERT_EQ(b.size(), 40u + 24 + 3);
  EXPECT_EQ(le32(&b[12]), 27u);          // payload_len
  EXPECT_EQ(le32(&b[40]), 0x01020304u);  // grid_id
  EXPECT_EQ(le32(&b[44]), 3u);           // rle_len
  EXPECT_EQ(le32(&b[48]), 10u);          // voxel_count (low half)
  EXPECT_EQ(le32(&b[56]), 3u);           // occupied_count (low half)
  EXPECT_EQ(Bytes(b.begin() + 64, b.end()), rle);
}

TEST(Layout, SilhouetteFixedPartAndRleFollowTheHeader) {
  const Bytes rle = {0x03, 0x03, 0x06};  // 4x3 pixels, pixels 3..5 foreground
  auto m = new_msg(VC_MSG_SILHOUETTE, 1, 77, 99);
  m->u.silhouette = {1, 2, 4, 3, 3, 3, rle.data(), 0};
  const Bytes b = encode(*m);
  ASSERT_EQ(b.size(), 40u + 16 + 3);
  EXPECT_EQ(b[6], 11);           // type
  EXPECT_EQ(le32(&b[12]), 19u);  // payload_len
  EXPECT_EQ(b[40], 1);           // camera
  EXPECT_EQ(b[42], 2);           // scale
  EXPECT_EQ(b[44], 4);           // width
  EXPECT_EQ(b[46], 3);           // height
  EXPECT_EQ(le32(&b[48]), 3u);   // rle_len
  EXPECT_EQ(le32(&b[52]), 3u);   // foreground_count
  EXPECT_EQ(Bytes(b.begin() + 56, b.end()), rle);
}

TEST(Layout, ConfigCarveRuleAndSilhouettesWhereReservedWas) {
  auto m = new_msg(VC_MSG_CONFIG);
  vc_config& c = m->u.config;
  c.grid.nx = c.grid.ny = c.grid.nz = 2, c.grid.voxel_m = 0.1, c.t_upper = 4, c.t_lower = 2;
  c.background_frames = 2, c.camera_count = 1, c.cameras[0].width = 8, c.cameras[0].height = 6;
  c.carve_rule = VC_CARVE_FOOTPRINT, c.silhouette_every = 3, c.silhouette_scale = 16;
  const Bytes b = encode(*m);
  EXPECT_EQ(b[40 + 64], 1);  // carve_rule u16
  EXPECT_EQ(b[40 + 65], 0);
  EXPECT_EQ(b[40 + 66], 3);   // silhouette_every
  EXPECT_EQ(b[40 + 67], 16);  // silhouette_scale
  // A 2.0 CONFIG (reserved 0) is a 2.1 CONFIG with the centre rule and no silhouettes.
  c.carve_rule = VC_CARVE_CENTRE, c.silhouette_every = 0, c.silhouette_scale = 0;
  const Bytes old = encode(*m);
  EXPECT_EQ(le32(&old[40 + 64]), 0u);
  Decoded d = decode(old);
  ASSERT_EQ(d.rc, 1) << d.diag.detail;
  EXPECT_EQ(d.msg->u.config.carve_rule, VC_CARVE_CENTRE);
  EXPECT_EQ(d.msg->u.config.silhouette_every, 0);
}

TEST(Layout, EmptyPayloadHasZeroCrc) {
  auto m = new_msg(VC_MSG_START);
  const Bytes b = encode(*m);
  ASSERT_EQ(b.size(), 40u);
  EXPECT_EQ(le32(&b[32]), 0u);
}

// ---- round trips ----------------------------------------------------------------------------------

std::unique_ptr<vc_msg> sample(uint16_t type, const Bytes& rle, const std::string& text) {
  auto m = new_msg(type, 5, 1000, 2000);
  switch (type) {
    case VC_MSG_HELLO:
      m->u.hello = {5, 1, 2, 3, VC_CAP_HULL | VC_CAP_GPIO_TRIGGER, 2, 0, {}};
      m->u.hello.cameras[0] = {1456, 1088, VC_FOURCC('G', 'R', 'E', 'Y'), 60000};
      m->u.hello.cameras[1] = {1456, 1088, VC_FOURCC('G', 'R', 'E', 'Y'), 59940};
      break;
    case VC_MSG_CONFIG: {
      vc_config& c = m->u.config;
      c.grid_id = 9, c.grid.nx = 64, c.grid.ny = 48, c.grid.nz = 100;
      c.grid.min_m[0] = -0.64, c.grid.min_m[1] = -0.48, c.grid.min_m[2] = 0, c.grid.voxel_m = 0.02;
      c.t_upper = 4, c.t_lower = 2, c.shadow_angle_deg = 5, c.cleanup_radius_px = 3;
      c.background_frames = 25, c.feature_role = VC_ROLE_NONE, c.camera_count = 1;
      c.cameras[0].width = 320, c.cameras[0].height = 240;
      for (int i = 0; i < 9; i++) c.cameras[0].K[i] = c.cameras[0].R_cam_from_world[i] = i * 0.5 - 1;
      for (int i = 0; i < 5; i++) c.cameras[0].dist[i] = -0.01 * i;
      for (int i = 0; i < 3; i++) c.cameras[0].t_cam_from_world[i] = 1.0 / (i + 3);
      break;
    }
    case VC_MSG_BACKGROUND:
      m->u.background.frame_count = 0;
      break;
    case VC_MSG_HULL: {
      uint64_t occ = 0, total = 0;
      EXPECT_EQ(vc_rle_popcount(rle.data(), rle.size(), &occ, &total), 0);
      m->u.hull = {3, static_cast<uint32_t>(rle.size()), total, occ, rle.data(), 0};
      break;
    }
    case VC_MSG_FEATURES:
      m->u.features.camera = 1;
      m->u.features.feature_count = 2;
      m->u.features.features[0] = {VC_FEATURE_RIGHT_FOOT, VC_FEATURE_PREDICTED, -3.5f, 1e4f, 0.25f};
      m->u.features.features[1] = {VC_FEATURE_HEAD, VC_FEATURE_TRACKING, 100.125f, 50.0f, 1.0f};
      break;
    case VC_MSG_STATS:
      m->u.stats.frames = 30;
      m->u.stats.stage_count = 2;
      m->u.stats.stages[0] = {VC_STAGE_CARVE, 100, 200};
      m->u.stats.stages[1] = {1000, 5, 5};  // unknown stage ids are allowed (open set)
      m->u.stats.counter_count = 1;
      m->u.stats.counters[0] = {VC_COUNTER_SEND_QUEUE_DROPS, UINT64_MAX};
      break;
    case VC_MSG_HEARTBEAT:
      m->u.heartbeat = {UINT64_MAX, VC_STATE_HOST};
      break;
    case VC_MSG_ERROR:
      m->u.error = {VC_ERR_CAMERA, VC_SEVERITY_FATAL, 0, static_cast<uint16_t>(text.size()), text.data()};
      break;
    case VC_MSG_SILHOUETTE: {
      uint64_t occ = 0, total = 0;
      EXPECT_EQ(vc_rle_popcount(rle.data(), rle.size(), &occ, &total), 0);
      // Any width x height of `total` pixels: the RLE is a bitset of that many bits.
      uint16_t w = 1;
      for (uint16_t f = 2; f <= 1024 && uint64_t{f} * f <= total; f++)
        if (total % f == 0) w = f;
      m->u.silhouette = {7,
                         1,
                         w,
                         static_cast<uint16_t>(total / w),
                         static_cast<uint32_t>(rle.size()),
                         static_cast<uint32_t>(occ),
                         rle.data(),
                         0};
      break;
    }
    default:
      break;
  }
  return m;
}

TEST(RoundTrip, EveryTypeDecodesToWhatWasEncoded) {
  std::mt19937_64 rng(3);
  const auto body = vc::proto::testing::human_hull(32, 4);
  Bytes rle(vc_rle_max_encoded_size(body.nbits));
  size_t rle_len = 0;
  ASSERT_EQ(vc_rle_encode(body.bytes.data(), body.nbits, rle.data(), rle.size(), &rle_len), 0);
  rle.resize(rle_len);
  const std::string text = "camera 1 stopped delivering frames: \xc3\xa9t\xc3\xa9";
  for (uint16_t type = VC_MSG_HELLO; type <= VC_MSG_SILHOUETTE; type++) {
    SCOPED_TRACE(vc_msg_type_name(type));
    auto m = sample(type, rle, text);
    const Bytes b = encode(*m);
    Decoded d = decode(b);
    ASSERT_EQ(d.rc, 1) << d.diag.detail;
    EXPECT_EQ(d.consumed, b.size());
    const vc_msg& r = *d.msg;
    EXPECT_TRUE(r.known);
    EXPECT_EQ(r.ignored_bytes, 0u);
    EXPECT_EQ(r.hdr.type, type);
    EXPECT_EQ(r.hdr.version_major, VC_PROTO_VERSION_MAJOR);
    EXPECT_EQ(r.hdr.version_minor, VC_PROTO_VERSION_MINOR);
    EXPECT_EQ(r.hdr.node_id, 5);
    EXPECT_EQ(r.hdr.seq, 1000u);
    EXPECT_EQ(r.hdr.t_trigger_ns, 2000u);
    EXPECT_EQ(r.hdr.payload_len, b.size() - 40);
    EXPECT_EQ(r.payload, b.data() + 40);
    // Re-encoding the decoded message gives the same bytes: every field survived.
    EXPECT_EQ(encode(r), b);
    switch (type) {
      case VC_MSG_HELLO:
        EXPECT_EQ(r.u.hello.cameras[1].max_fps_milli, 59940u);
        EXPECT_EQ(r.u.hello.camera_record_size, 12);
        break;
      case VC_MSG_CONFIG:
        EXPECT_EQ(r.u.config.cameras[0].t_cam_from_world[0], 1.0 / 3);
        EXPECT_EQ(r.u.config.grid.min_m[0], -0.64);
        EXPECT_EQ(r.u.config.camera_record_size, 216);
        break;
      case VC_MSG_HULL:
        EXPECT_EQ(r.u.hull.occupied_count, body.count());
        EXPECT_EQ(r.u.hull.voxel_count, body.nbits);
        EXPECT_EQ(Bytes(r.u.hull.rle, r.u.hull.rle + r.u.hull.rle_len), rle);
        EXPECT_GT(r.u.hull.run_count, 10u);
        break;
      case VC_MSG_FEATURES:
        EXPECT_EQ(r.u.features.features[0].v, 1e4f);
        break;
      case VC_MSG_STATS:
        EXPECT_EQ(r.u.stats.counters[0].value, UINT64_MAX);
        break;
      case VC_MSG_ERROR:
        EXPECT_EQ(std::string(r.u.error.text, r.u.error.text_len), text);
        break;
      case VC_MSG_SILHOUETTE:
        EXPECT_EQ(r.u.silhouette.camera, 7);
        EXPECT_EQ(uint64_t{r.u.silhouette.width} * r.u.silhouette.height, body.nbits);
        EXPECT_EQ(r.u.silhouette.foreground_count, body.count());
        EXPECT_EQ(Bytes(r.u.silhouette.rle, r.u.silhouette.rle + r.u.silhouette.rle_len), rle);
        EXPECT_GT(r.u.silhouette.run_count, 10u);
        break;
      default:
        break;
    }
  }
}

TEST(RoundTrip, SilhouetteFromBitsMatchesSilhouetteFromRle) {
  // A 37x23 mask (odd sizes: rows do not start on byte boundaries) of a disc and a stripe.
  const uint16_t w = 37, h = 23;
  Bytes bits((w * h + 7) / 8, 0);
  uint32_t fg = 0;
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++)
      if ((x - 18) * (x - 18) + (y - 11) * (y - 11) <= 64 || y == 2) {
        bits[(x + w * y) / 8] = static_cast<uint8_t>(bits[(x + w * y) / 8] | 1u << ((x + w * y) % 8));
        fg++;
      }
  Bytes rle(vc_rle_max_encoded_size(w * h));
  size_t rle_len = 0;
  ASSERT_EQ(vc_rle_encode(bits.data(), w * h, rle.data(), rle.size(), &rle_len), 0);
  auto m = new_msg(VC_MSG_SILHOUETTE, 2, 3, 4);
  m->u.silhouette = {1, 4, w, h, static_cast<uint32_t>(rle_len), fg, rle.data(), 0};
  const Bytes via_rle = encode(*m);
  Bytes via_bits(via_rle.size() + 100);
  size_t len = 0;
  vc_header hd = header(2, 3, 4);
  ASSERT_EQ(vc_encode_silhouette_bits(via_bits.data(), via_bits.size(), &len, &hd, 1, 4, w, h, bits.data()),
            0);
  via_bits.resize(len);
  EXPECT_EQ(via_bits, via_rle);
  Decoded d = decode(via_bits);
  ASSERT_EQ(d.rc, 1) << d.diag.detail;
  Bytes back((w * h + 7) / 8, 0xFF);
  ASSERT_EQ(vc_rle_decode(d.msg->u.silhouette.rle, d.msg->u.silhouette.rle_len, back.data(), w * h), 0);
  EXPECT_EQ(back, bits);
  // Too small a buffer: -ENOSPC and the size needed; fields out of range: the decoder's codes.
  Bytes small(60);
  EXPECT_EQ(vc_encode_silhouette_bits(small.data(), small.size(), &len, &hd, 1, 4, w, h, bits.data()),
            -ENOSPC);
  EXPECT_EQ(len, via_rle.size());
  EXPECT_EQ(vc_encode_silhouette_bits(via_bits.data(), via_bits.size(), &len, &hd, 8, 4, w, h, bits.data()),
            VC_PROTO_EFIELD);
  EXPECT_EQ(vc_encode_silhouette_bits(via_bits.data(), via_bits.size(), &len, &hd, 1, 17, w, h, bits.data()),
            VC_PROTO_EFIELD);
  EXPECT_EQ(vc_encode_silhouette_bits(via_bits.data(), via_bits.size(), &len, &hd, 1, 1, 0, h, bits.data()),
            VC_PROTO_EFIELD);
  EXPECT_EQ(
      vc_encode_silhouette_bits(via_bits.data(), via_bits.size(), &len, &hd, 1, 1, 16385, 1, bits.data()),
      VC_PROTO_ELIMIT);
  EXPECT_EQ(vc_encode_silhouette_bits(via_bits.data(), via_bits.size(), &len, &hd, 1, 1, w, h, nullptr),
            -EINVAL);
}

TEST(RoundTrip, HullFromBitsMatchesHullFromRle) {
  const auto body = vc::proto::testing::human_hull(64, 11);
  Bytes rle(vc_rle_max_encoded_size(body.nbits));
  size_t rle_len = 0;
  ASSERT_EQ(vc_rle_encode(body.bytes.data(), body.nbits, rle.data(), rle.size(), &rle_len), 0);
  auto m = new_msg(VC_MSG_HULL, 2, 3, 4);
  m->u.hull = {12, static_cast<uint32_t>(rle_len), body.nbits, body.count(), rle.data(), 0};
  const Bytes via_rle = encode(*m);
  Bytes via_bits(via_rle.size() + 100);
  size_t len = 0;
  vc_header h = header(2, 3, 4);
  ASSERT_EQ(
      vc_encode_hull_bits(via_bits.data(), via_bits.size(), &len, &h, 12, body.bytes.data(), body.nbits), 0);
  via_bits.resize(len);
  EXPECT_EQ(via_bits, via_rle);
  // Too small a buffer: -ENOSPC and the size needed.
  Bytes small(100);
  EXPECT_EQ(vc_encode_hull_bits(small.data(), small.size(), &len, &h, 12, body.bytes.data(), body.nbits),
            -ENOSPC);
  EXPECT_EQ(len, via_rle.size());
  EXPECT_EQ(vc_encode_hull_bits(nullptr, 0, &len, &h, 12, body.bytes.data(), body.nbits), -ENOSPC);
  EXPECT_EQ(len, via_rle.size());
}

TEST(RoundTrip, EncodersReportNeededSize) {
  auto m = sample(VC_MSG_CONFIG, {}, "");
  size_t len = 0;
  Bytes b(10);
  EXPECT_EQ(vc_msg_encode(b.data(), b.size(), &len, m.get()), -ENOSPC);
  EXPECT_EQ(len, 40u + 78 + 216);
  EXPECT_EQ(vc_msg_encode(nullptr, 0, &len, m.get()), -ENOSPC);
  EXPECT_EQ(vc_msg_encode(b.data(), b.size(), nullptr, m.get()), -EINVAL);
}

// ---- encoders refuse what the decoder rejects ------------------------------------------------------

TEST(Encoders, RefuseInvalidBodiesWithTheDecodersCode) {
  const Bytes rle = {0x03, 0x03, 0x04};
  auto expect_refused = [](const vc_msg& m, int code) {
    Bytes b(4096);
    size_t len = 0;
    EXPECT_EQ(vc_msg_encode(b.data(), b.size(), &len, &m), code) << vc_msg_type_name(m.hdr.type);
  };
  auto hello = sample(VC_MSG_HELLO, rle, "");
  hello->u.hello.node_id = 6;
  expect_refused(*hello, VC_PROTO_EINCONSISTENT);
  hello = sample(VC_MSG_HELLO, rle, "");
  hello->u.hello.camera_count = 9;
  expect_refused(*hello, VC_PROTO_ELIMIT);
  auto config = sample(VC_MSG_CONFIG, rle, "");
  config->u.config.grid.voxel_m = -0.02;
  expect_refused(*config, VC_PROTO_EFIELD);
  config = sample(VC_MSG_CONFIG, rle, "");
  config->u.config.grid.nx = config->u.config.grid.ny = config->u.config.grid.nz = 1024;
  expect_refused(*config, VC_PROTO_ELIMIT);
  config = sample(VC_MSG_CONFIG, rle, "");
  config->u.config.cameras[0].K[0] = NAN;
  expect_refused(*config, VC_PROTO_EFIELD);
  config = sample(VC_MSG_CONFIG, rle, "");
  config->u.config.t_lower = 5;  // above t_upper
  expect_refused(*config, VC_PROTO_EFIELD);
  config = sample(VC_MSG_CONFIG, rle, "");
  config->u.config.feature_role = 2;
  expect_refused(*config, VC_PROTO_EFIELD);
  config = sample(VC_MSG_CONFIG, rle, "");
  config->u.config.cleanup_radius_px = VC_CLEANUP_RADIUS_MAX_PX + 1;  // more than the edge runs
  expect_refused(*config, VC_PROTO_EFIELD);
  config = sample(VC_MSG_CONFIG, rle, "");
  config->u.config.carve_rule = 3;  // 2.0's nonzero `reserved`, now an unknown carve rule (2 is subpixel)
  expect_refused(*config, VC_PROTO_EFIELD);
  config = sample(VC_MSG_CONFIG, rle, "");
  config->u.config.silhouette_every = 2;  // silhouettes need a scale of at least 1
  config->u.config.silhouette_scale = 0;
  expect_refused(*config, VC_PROTO_EFIELD);
  config->u.config.silhouette_scale = VC_PROTO_MAX_SILHOUETTE_SCALE + 1;
  expect_refused(*config, VC_PROTO_EFIELD);
  config->u.config.silhouette_every = 0;  // a scale over 16 is refused even when unused
  expect_refused(*config, VC_PROTO_EFIELD);
  auto sil = sample(VC_MSG_SILHOUETTE, rle, "");
  sil->u.silhouette.foreground_count++;
  expect_refused(*sil, VC_PROTO_EINCONSISTENT);
  sil = sample(VC_MSG_SILHOUETTE, rle, "");
  sil->u.silhouette.height++;
  expect_refused(*sil, VC_PROTO_EINCONSISTENT);
  sil = sample(VC_MSG_SILHOUETTE, rle, "");
  sil->u.silhouette.camera = VC_PROTO_MAX_CAMERAS;
  expect_refused(*sil, VC_PROTO_EFIELD);
  sil = sample(VC_MSG_SILHOUETTE, rle, "");
  sil->u.silhouette.width = VC_PROTO_MAX_SILHOUETTE_SIDE + 1;
  expect_refused(*sil, VC_PROTO_ELIMIT);
  sil = sample(VC_MSG_SILHOUETTE, rle, "");
  const Bytes zero_run = {0x03, 0x00, 0x07};
  sil->u.silhouette.rle = zero_run.data();
  expect_refused(*sil, VC_PROTO_ERLE);
  auto hull = sample(VC_MSG_HULL, rle, "");
  hull->u.hull.occupied_count++;
  expect_refused(*hull, VC_PROTO_EINCONSISTENT);
  hull = sample(VC_MSG_HULL, rle, "");
  const Bytes bad_rle = {0x83, 0x00, 0x03, 0x04};
  hull->u.hull.rle = bad_rle.data();
  hull->u.hull.rle_len = 4;
  expect_refused(*hull, VC_PROTO_ERLE);
  auto features = sample(VC_MSG_FEATURES, rle, "");
  features->u.features.features[1].confidence = 1.5f;
  expect_refused(*features, VC_PROTO_EFIELD);
  features = sample(VC_MSG_FEATURES, rle, "");
  features->u.features.features[1].feature_id = VC_FEATURE_RIGHT_FOOT;
  expect_refused(*features, VC_PROTO_EINCONSISTENT);
  auto stats = sample(VC_MSG_STATS, rle, "");
  stats->u.stats.stages[0].mean_ns = 300;  // > max_ns
  expect_refused(*stats, VC_PROTO_EINCONSISTENT);
  auto hb = sample(VC_MSG_HEARTBEAT, rle, "");
  hb->u.heartbeat.state = VC_STATE_COUNT;
  expect_refused(*hb, VC_PROTO_EFIELD);
  const std::string with_nul("a\0b", 3);
  auto err = sample(VC_MSG_ERROR, rle, with_nul);
  expect_refused(*err, VC_PROTO_EFIELD);
  for (const char* bad :
       {"\xc0\xaf", "\xed\xa0\x80", "\xf4\x90\x80\x80", "\xe2\x82"}) {  // overlong, surrogate, >U+10FFFF, cut
    const std::string t(bad);
    auto e = sample(VC_MSG_ERROR, rle, t);
    expect_refused(*e, VC_PROTO_EFIELD);
  }
  auto unknown = new_msg(77);
  expect_refused(*unknown, -EINVAL);
}

TEST(Encoders, HullBitsOverTheRunLimitIsRefused) {
  // Alternating bits: one run per voxel, more than VC_PROTO_MAX_RLE_RUNS.
  const size_t nbits = VC_PROTO_MAX_RLE_RUNS + 16;
  Bytes bits(nbits / 8, 0x55);
  Bytes out(40 + 24 + vc_rle_max_encoded_size(nbits));
  size_t len = 0;
  vc_header h = header();
  EXPECT_EQ(vc_encode_hull_bits(out.data(), out.size(), &len, &h, 1, bits.data(), nbits), VC_PROTO_ELIMIT);
}

// ---- decoding one buffer --------------------------------------------------------------------------

TEST(Decode, PrefixesNeedMoreBytesAndNeverReadPastThem) {
  auto m = sample(VC_MSG_STATS, {}, "");
  const Bytes b = encode(*m);
  for (size_t n = 0; n < b.size(); n++) {
    // An exact-size heap copy: ASan catches any read past n.
    std::unique_ptr<uint8_t[]> prefix(new uint8_t[n ? n : 1]);
    std::memcpy(prefix.get(), b.data(), n);
    auto out = std::make_unique<vc_msg>();
    size_t consumed = 99;
    EXPECT_EQ(vc_msg_decode(prefix.get(), n, 0, out.get(), &consumed, nullptr), 0) << n;
    EXPECT_EQ(consumed, 0u);
  }
}

TEST(Decode, MagicIsCheckedOnTheFirstByte) {
  const Bytes b = {'X'};
  Decoded d = decode(b);
  EXPECT_EQ(d.rc, VC_PROTO_EMAGIC);
  EXPECT_EQ(d.consumed, 0u);
  EXPECT_TRUE(vc_proto_error_is_fatal(d.rc));
  EXPECT_NE(std::string(d.diag.detail).find("byte 0"), std::string::npos) << d.diag.detail;
}

TEST(Decode, NewerMinorAppendedBytesAreIgnoredSameMinorRejected) {
  auto m = sample(VC_MSG_FEATURES, {}, "");
  Bytes b = encode(*m);
  b.insert(b.end(), {9, 9});
  auto reseal = [](Bytes& x, uint8_t minor) {
    x[5] = minor;
    uint32_t plen = static_cast<uint32_t>(x.size() - 40);
    std::memcpy(&x[12], &plen, 4);
    uint32_t pc = vc_crc32c(0, x.data() + 40, plen);
    std::memcpy(&x[32], &pc, 4);
    uint32_t hc = vc_crc32c(0, x.data(), 36);
    std::memcpy(&x[36], &hc, 4);
  };
  reseal(b, VC_PROTO_VERSION_MINOR);
  Decoded same = decode(b);
  EXPECT_EQ(same.rc, VC_PROTO_ETRAILING);
  EXPECT_EQ(same.consumed, b.size());  // non-fatal: the message is consumed
  EXPECT_FALSE(vc_proto_error_is_fatal(same.rc));
  reseal(b, VC_PROTO_VERSION_MINOR + 1);
  Decoded newer = decode(b);
  ASSERT_EQ(newer.rc, 1) << newer.diag.detail;
  EXPECT_EQ(newer.msg->ignored_bytes, 2u);
  EXPECT_EQ(newer.msg->u.features.feature_count, 2);
}

TEST(Decode, HullWithMoreRunsThanTheLimitIsRejected) {
  // 2^22 + 2 single-voxel runs: about 4 MiB of RLE, under the payload limit, over the run limit.
  const uint64_t runs = VC_PROTO_MAX_RLE_RUNS + 2;
  Bytes msg(40 + 24 + runs);
  uint8_t* rle = msg.data() + 64;
  rle[0] = 0;
  std::memset(rle + 1, 1, runs - 1);
  vc_header h = header();
  h.version_major = VC_PROTO_VERSION_MAJOR;
  h.type = VC_MSG_HULL;
  Bytes payload(24 + runs);
  uint32_t v32 = 1;
  std::memcpy(&payload[0], &v32, 4);
  v32 = static_cast<uint32_t>(runs);
  std::memcpy(&payload[4], &v32, 4);
  uint64_t total = runs - 1, occ = (runs - 1) / 2 + ((runs - 1) % 2);
  std::memcpy(&payload[8], &total, 8);
  std::memcpy(&payload[16], &occ, 8);
  std::memcpy(&payload[24], rle, runs);
  size_t len = 0;
  ASSERT_EQ(vc_frame_encode(msg.data(), msg.size(), &len, &h, payload.data(), payload.size()), 0);
  Decoded d = decode(msg);
  EXPECT_EQ(d.rc, VC_PROTO_ELIMIT) << d.diag.detail;
}

// ---- streaming decoder -----------------------------------------------------------------------------

struct DecoderDeleter {
  void operator()(vc_decoder* d) const { vc_decoder_free(d); }
};
using DecoderPtr = std::unique_ptr<vc_decoder, DecoderDeleter>;

// A new decoder (null, with the reason reported, when vc_decoder_new fails).
DecoderPtr new_decoder(size_t max_payload) {
  vc_decoder* d = nullptr;
  char why[128];
  EXPECT_EQ(vc_decoder_new(max_payload, &d, why, sizeof why), 0) << why;
  return DecoderPtr(d);
}

// Feeds `stream` in chunks from `chunk_size`, returns the types of messages yielded (negative codes
// for errors) and the final code of finish.
std::vector<int> run_stream(const Bytes& stream, size_t max_payload,
                            const std::function<size_t()>& chunk_size) {
  DecoderPtr dec = new_decoder(max_payload);
  EXPECT_TRUE(dec);
  std::vector<int> seen;
  auto msg = std::make_unique<vc_msg>();
  size_t pos = 0;
  while (pos < stream.size()) {
    size_t n = std::min(chunk_size(), stream.size() - pos), used = 0;
    int rc = vc_decoder_feed(dec.get(), stream.data() + pos, n, &used);
    if (rc < 0) {
      EXPECT_TRUE(vc_proto_error_is_fatal(rc));
      return seen;
    }
    pos += used;
    while ((rc = vc_decoder_next(dec.get(), msg.get())) != 0) {
      seen.push_back(rc > 0 ? msg->hdr.type : rc);
      if (rc < 0 && vc_proto_error_is_fatal(rc)) return seen;
    }
  }
  int rc = vc_decoder_finish(dec.get());
  if (rc) seen.push_back(rc);
  return seen;
}

TEST(Decoder, SameMessagesWhateverTheChunking) {
  const auto body = vc::proto::testing::human_hull(64, 5);
  Bytes stream;
  std::vector<int> expected;
  std::mt19937_64 rng(8);
  const std::string text = "x";
  for (int i = 0; i < 40; i++) {
    Bytes rle(vc_rle_max_encoded_size(body.nbits));
    size_t rle_len = 0;
    ASSERT_EQ(vc_rle_encode(body.bytes.data(), body.nbits, rle.data(), rle.size(), &rle_len), 0);
    rle.resize(rle_len);
    auto m = sample(static_cast<uint16_t>(VC_MSG_HELLO + rng() % 10), rle, text);
    Bytes b = encode(*m);
    stream.insert(stream.end(), b.begin(), b.end());
    expected.push_back(m->hdr.type);
  }
  EXPECT_EQ(run_stream(stream, 0, [] { return size_t{1}; }), expected);
  EXPECT_EQ(run_stream(stream, 0, [] { return size_t{7}; }), expected);
  EXPECT_EQ(run_stream(stream, 0, [&] { return stream.size(); }), expected);
  EXPECT_EQ(run_stream(stream, 0, [&] { return size_t{1} + rng() % 5000; }), expected);
  // A small decoder limit still holds every message here (largest payload < 64 KiB).
  EXPECT_EQ(run_stream(stream, 65536, [&] { return size_t{1} + rng() % 100000; }), expected);
}

TEST(Decoder, FatalErrorsAreStickyNonFatalOnesSkipOneMessage) {
  auto hb = sample(VC_MSG_HEARTBEAT, {}, "");
  Bytes good = encode(*hb);
  Bytes bad_state = good;
  bad_state[48] = 99;  // state
  uint32_t pc = vc_crc32c(0, bad_state.data() + 40, 12);
  std::memcpy(&bad_state[32], &pc, 4);
  uint32_t hc = vc_crc32c(0, bad_state.data(), 36);
  std::memcpy(&bad_state[36], &hc, 4);
  Bytes stream = good;
  stream.insert(stream.end(), bad_state.begin(), bad_state.end());
  stream.insert(stream.end(), good.begin(), good.end());
  stream.push_back('!');
  stream.insert(stream.end(), good.begin(), good.end());
  DecoderPtr dec = new_decoder(0);
  size_t used = 0;
  ASSERT_EQ(vc_decoder_feed(dec.get(), stream.data(), stream.size(), &used), 0);
  EXPECT_EQ(used, stream.size());
  auto msg = std::make_unique<vc_msg>();
  EXPECT_EQ(vc_decoder_next(dec.get(), msg.get()), 1);
  EXPECT_EQ(vc_decoder_next(dec.get(), msg.get()), VC_PROTO_EFIELD);
  EXPECT_EQ(vc_decoder_diag(dec.get())->offset, good.size());
  EXPECT_EQ(msg->hdr.type, VC_MSG_HEARTBEAT);  // the rejected message's header is available
  EXPECT_EQ(vc_decoder_next(dec.get(), msg.get()), 1);
  EXPECT_EQ(vc_decoder_next(dec.get(), msg.get()), VC_PROTO_EMAGIC);
  EXPECT_EQ(vc_decoder_diag(dec.get())->offset, 3 * good.size());
  EXPECT_EQ(vc_decoder_next(dec.get(), msg.get()), VC_PROTO_EMAGIC);
  EXPECT_EQ(vc_decoder_feed(dec.get(), good.data(), good.size(), &used), VC_PROTO_EMAGIC);
  EXPECT_EQ(used, 0u);
  EXPECT_EQ(vc_decoder_finish(dec.get()), VC_PROTO_EMAGIC);
}

TEST(Decoder, FinishInsideAMessageIsEof) {
  auto hb = sample(VC_MSG_HEARTBEAT, {}, "");
  Bytes b = encode(*hb);
  DecoderPtr dec = new_decoder(0);
  size_t used = 0;
  ASSERT_EQ(vc_decoder_feed(dec.get(), b.data(), b.size() - 1, &used), 0);
  auto msg = std::make_unique<vc_msg>();
  EXPECT_EQ(vc_decoder_next(dec.get(), msg.get()), 0);
  EXPECT_EQ(vc_decoder_pending(dec.get()), b.size() - 1);
  EXPECT_EQ(vc_decoder_finish(dec.get()), VC_PROTO_EEOF);
  EXPECT_EQ(vc_decoder_diag(dec.get())->code, VC_PROTO_EEOF);
  DecoderPtr clean = new_decoder(0);
  ASSERT_EQ(vc_decoder_feed(clean.get(), b.data(), b.size(), &used), 0);
  EXPECT_EQ(vc_decoder_next(clean.get(), msg.get()), 1);
  EXPECT_EQ(vc_decoder_next(clean.get(), msg.get()), 0);
  EXPECT_EQ(vc_decoder_finish(clean.get()), 0);
  EXPECT_EQ(vc_decoder_offset(clean.get()), b.size());
}

TEST(Decoder, MemoryIsBoundedAndFeedAlwaysProgresses) {
  // max_payload 100: the buffer never holds more than 140 bytes; feeding a 10 KB stream of valid
  // messages in one call takes what fits, the caller drains, feeds the rest.
  auto hb = sample(VC_MSG_HEARTBEAT, {}, "");
  const Bytes one = encode(*hb);
  Bytes stream;
  for (int i = 0; i < 200; i++) stream.insert(stream.end(), one.begin(), one.end());
  DecoderPtr dec = new_decoder(100);
  auto msg = std::make_unique<vc_msg>();
  size_t pos = 0, messages = 0;
  while (pos < stream.size()) {
    size_t used = 0;
    ASSERT_EQ(vc_decoder_feed(dec.get(), stream.data() + pos, stream.size() - pos, &used), 0);
    EXPECT_LE(vc_decoder_pending(dec.get()), 140u);
    pos += used;
    int rc;
    while ((rc = vc_decoder_next(dec.get(), msg.get())) == 1) messages++;
    ASSERT_EQ(rc, 0);
  }
  EXPECT_EQ(messages, 200u);
  // A payload over the limit is refused from the header alone.
  auto config = sample(VC_MSG_CONFIG, {}, "");
  const Bytes big = encode(*config);  // 294-byte payload
  DecoderPtr small = new_decoder(100);
  size_t used = 0;
  ASSERT_EQ(vc_decoder_feed(small.get(), big.data(), 40, &used), 0);
  EXPECT_EQ(vc_decoder_next(small.get(), msg.get()), VC_PROTO_EOVERSIZE);
}

// The host's pre-HELLO cap (SPEC.md "Limits"): a stranger's first message declaring 8 MiB is refused
// from its header, before anything is buffered; after the HELLO the full maximum applies again.
TEST(Decoder, MaxPayloadCanBeRaisedAfterHello) {
  auto hello = sample(VC_MSG_HELLO, {}, "");
  auto config = sample(VC_MSG_CONFIG, {}, "");
  const Bytes h = encode(*hello), c = encode(*config);
  ASSERT_LE(h.size() - VC_PROTO_HEADER_SIZE, size_t{VC_PROTO_MAX_HELLO_PAYLOAD});
  Bytes stream = h;
  stream.insert(stream.end(), c.begin(), c.end());
  DecoderPtr dec = new_decoder(200);  // below CONFIG's payload
  auto msg = std::make_unique<vc_msg>();
  size_t used = 0;
  ASSERT_EQ(vc_decoder_feed(dec.get(), stream.data(), stream.size(), &used), 0);
  ASSERT_EQ(vc_decoder_next(dec.get(), msg.get()), 1);
  EXPECT_EQ(msg->hdr.type, VC_MSG_HELLO);
  ASSERT_EQ(vc_decoder_set_max_payload(dec.get(), 0), 0);
  size_t pos = used;
  while (pos < stream.size()) {
    ASSERT_EQ(vc_decoder_feed(dec.get(), stream.data() + pos, stream.size() - pos, &used), 0);
    pos += used;
  }
  ASSERT_EQ(vc_decoder_next(dec.get(), msg.get()), 1);
  EXPECT_EQ(msg->hdr.type, VC_MSG_CONFIG);
  // An 8 MiB header as the first thing a stranger sends: oversize after its 40 bytes.
  Bytes huge = c;
  const uint32_t plen = VC_PROTO_MAX_PAYLOAD;
  std::memcpy(&huge[12], &plen, 4);
  const uint32_t hc = vc_crc32c(0, huge.data(), 36);
  std::memcpy(&huge[36], &hc, 4);
  DecoderPtr first = new_decoder(VC_PROTO_MAX_HELLO_PAYLOAD);
  ASSERT_EQ(vc_decoder_feed(first.get(), huge.data(), VC_PROTO_HEADER_SIZE, &used), 0);
  EXPECT_EQ(vc_decoder_next(first.get(), msg.get()), VC_PROTO_EOVERSIZE);
  EXPECT_EQ(vc_decoder_set_max_payload(first.get(), VC_PROTO_MAX_PAYLOAD + 1), -EINVAL);
  EXPECT_EQ(vc_decoder_set_max_payload(nullptr, 0), -EINVAL);
}

TEST(Decoder, RejectsBadArguments) {
  char why[128] = "unset";
  vc_decoder* failed = reinterpret_cast<vc_decoder*>(why);  // must come back NULL
  EXPECT_EQ(vc_decoder_new(VC_PROTO_MAX_PAYLOAD + 1, &failed, why, sizeof why), -EINVAL);
  EXPECT_EQ(failed, nullptr);
  EXPECT_STREQ(why, "decoder: max_payload 8388609 is above the protocol's 8388608 bytes");
  EXPECT_EQ(vc_decoder_new(0, nullptr, why, sizeof why), -EINVAL);  // nowhere to put it
  char tiny[9];
  EXPECT_EQ(vc_decoder_new(VC_PROTO_MAX_PAYLOAD + 1, &failed, tiny, sizeof tiny), -EINVAL);
  EXPECT_STREQ(tiny, "decoder:");  // truncated and terminated, like the edge's vc_why
  EXPECT_EQ(vc_decoder_new(VC_PROTO_MAX_PAYLOAD, &failed, why, sizeof why), 0);
  EXPECT_STREQ(why, "");
  vc_decoder_free(failed);
  vc_decoder_free(nullptr);
  DecoderPtr dec = new_decoder(0);
  size_t used = 0;
  EXPECT_EQ(vc_decoder_feed(dec.get(), nullptr, 3, &used), -EINVAL);
  EXPECT_EQ(vc_decoder_feed(dec.get(), nullptr, 0, &used), 0);
  EXPECT_EQ(vc_decoder_next(dec.get(), nullptr), -EINVAL);
}

TEST(Names, EveryCodeAndTypeHasOne) {
  for (int code = VC_PROTO_EORDER; code <= VC_PROTO_EMAGIC; code++) {
    EXPECT_STRNE(vc_proto_strerror(code), "unknown error") << code;
    EXPECT_STRNE(vc_proto_error_name(code), "UNKNOWN") << code;
  }
  for (uint16_t t = VC_MSG_HELLO; t <= VC_MSG_FRAME; t++) EXPECT_NE(vc_msg_type_name(t), nullptr);
  EXPECT_EQ(vc_msg_type_name(0), nullptr);
  EXPECT_STREQ(vc_msg_type_name(11), "SILHOUETTE");
  EXPECT_STREQ(vc_msg_type_name(12), "AUTH");   // 2.3
  EXPECT_STREQ(vc_msg_type_name(13), "GRAB");   // 2.4
  EXPECT_STREQ(vc_msg_type_name(14), "FRAME");  // 2.4
  EXPECT_EQ(vc_msg_type_name(15), nullptr);
  EXPECT_STREQ(vc_counter_name(VC_COUNTER_SILHOUETTES_SENT), "silhouettes_sent");
  EXPECT_STREQ(vc_counter_name(VC_COUNTER_SILHOUETTES_DROPPED), "silhouettes_dropped");
  EXPECT_STREQ(vc_feature_name(VC_FEATURE_RIGHT_FOOT), "right_foot");
  EXPECT_STREQ(vc_counter_name(VC_COUNTER_PULSES_WITHOUT_FRAME), "pulses_without_frame");
}

}  // namespace
