// GRAB and FRAME (2.4): the byte layout of SPEC.md's tables, round trips, the edge's encoder straight
// from an RGB image (rgb8 copied, gray8 in fixed point), and every rejection: bad lengths, sizes,
// formats and cameras, by the decoder and by the encoders alike.
#include <gtest/gtest.h>

#include <cerrno>
#include <cstring>
#include <memory>
#include <vector>

#include "voxcap/crc32c.h"
#include "voxcap/proto.h"

namespace {

using Bytes = std::vector<uint8_t>;

uint16_t le16(const uint8_t* p) {
  return static_cast<uint16_t>(p[0] | p[1] << 8);
}
uint32_t le32(const uint8_t* p) {
  return p[0] | p[1] << 8 | p[2] << 16 | static_cast<uint32_t>(p[3]) << 24;
}

vc_header header(uint64_t seq = 0, uint64_t t = 0) {
  vc_header h{};
  h.node_id = 3;
  h.seq = seq;
  h.t_trigger_ns = t;
  return h;
}

struct Decoded {
  int rc = 0;
  size_t consumed = 0;
  std::unique_ptr<vc_msg> msg = std::make_unique<vc_msg>();
  vc_proto_diag diag{};
};

Decoded decode(const Bytes& b) {
  Decoded d;
  d.rc = vc_msg_decode(b.data(), b.size(), 0, d.msg.get(), &d.consumed, &d.diag);
  return d;
}

// A message whose payload was altered after encoding, resealed (CRCs valid, payload_len updated).
Bytes reframe(const Bytes& msg, const Bytes& payload) {
  vc_header h{};
  h.version_major = msg[4];
  h.version_minor = msg[5];
  h.type = le16(&msg[6]);
  h.node_id = le16(&msg[10]);
  Bytes b(VC_PROTO_HEADER_SIZE + payload.size());
  size_t len = 0;
  EXPECT_EQ(vc_frame_encode(b.data(), b.size(), &len, &h, payload.data(), payload.size()), 0);
  return b;
}

Bytes payload_of(const Bytes& msg) {
  return Bytes(msg.begin() + VC_PROTO_HEADER_SIZE, msg.end());
}

Bytes rgb_image(int w, int h, size_t stride) {
  Bytes img(stride * static_cast<size_t>(h), 0xEE);  // padding bytes must not reach the wire
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++)
      for (int c = 0; c < 3; c++)
        img[static_cast<size_t>(y) * stride + static_cast<size_t>(3 * x + c)] =
            static_cast<uint8_t>(x * 7 + y * 13 + c * 50);
  return img;
}

Bytes encode_grab(const vc_grab& g, uint64_t seq = 1000) {
  Bytes b(VC_PROTO_HEADER_SIZE + 64);
  size_t len = 0;
  vc_header h = header(seq);
  EXPECT_EQ(vc_encode_grab(b.data(), b.size(), &len, &h, &g), 0);
  b.resize(len);
  return b;
}

TEST(Grab, LayoutAsInSpecAndRoundTrip) {
  const vc_grab g{15, VC_FRAME_GRAY8, 0x3, 40};
  const Bytes b = encode_grab(g);
  ASSERT_EQ(b.size(), 40u + 12);
  EXPECT_EQ(b[5], 4);            // version 2.4
  EXPECT_EQ(le16(&b[6]), 13u);   // type GRAB
  EXPECT_EQ(le32(&b[12]), 12u);  // payload_len
  EXPECT_EQ(le16(&b[40]), 15u);  // every
  EXPECT_EQ(le16(&b[42]), 1u);   // format gray8
  EXPECT_EQ(le16(&b[44]), 3u);   // cameras
  EXPECT_EQ(le16(&b[46]), 0u);   // reserved
  EXPECT_EQ(le32(&b[48]), 40u);  // count
  Decoded d = decode(b);
  ASSERT_EQ(d.rc, 1) << d.diag.detail;
  EXPECT_EQ(d.msg->hdr.seq, 1000u);
  EXPECT_EQ(d.msg->u.grab.every, 15);
  EXPECT_EQ(d.msg->u.grab.format, VC_FRAME_GRAY8);
  EXPECT_EQ(d.msg->u.grab.cameras, 3);
  EXPECT_EQ(d.msg->u.grab.count, 40u);
}

TEST(Grab, StopNeedsNoFormatOrCameras) {
  Decoded d = decode(encode_grab(vc_grab{0, 0, 0, 0}));
  ASSERT_EQ(d.rc, 1) << d.diag.detail;
  EXPECT_EQ(d.msg->u.grab.every, 0);
}

TEST(Grab, EncoderAndDecoderRefuseTheSameFields) {
  Bytes b(VC_PROTO_HEADER_SIZE + 64);
  size_t len = 0;
  vc_header h = header();
  const vc_grab bad[] = {
      {15, 0, 1, 0}, {15, 3, 1, 0}, {15, VC_FRAME_RGB8, 0, 0}, {15, VC_FRAME_RGB8, 0x100, 0}};
  for (const vc_grab& g : bad) {
    EXPECT_EQ(vc_encode_grab(b.data(), b.size(), &len, &h, &g), VC_PROTO_EFIELD)
        << g.format << " " << g.cameras;
    // The same fields by hand on the wire.
    Bytes p(12, 0);
    p[0] = static_cast<uint8_t>(g.every);
    p[2] = static_cast<uint8_t>(g.format);
    p[4] = static_cast<uint8_t>(g.cameras);
    p[5] = static_cast<uint8_t>(g.cameras >> 8);
    Decoded d = decode(reframe(encode_grab(vc_grab{1, 1, 1, 0}), p));
    EXPECT_EQ(d.rc, VC_PROTO_EFIELD) << d.diag.detail;
    EXPECT_EQ(d.consumed, 52u);  // not fatal: the message is skipped
  }
  Bytes p = payload_of(encode_grab(vc_grab{1, 1, 1, 0}));
  p[6] = 1;  // reserved
  EXPECT_EQ(decode(reframe(encode_grab(vc_grab{1, 1, 1, 0}), p)).rc, VC_PROTO_EFIELD);
  p = payload_of(encode_grab(vc_grab{1, 1, 1, 0}));
  p.pop_back();
  EXPECT_EQ(decode(reframe(encode_grab(vc_grab{1, 1, 1, 0}), p)).rc, VC_PROTO_ETRUNCATED);
  p = payload_of(encode_grab(vc_grab{1, 1, 1, 0}));
  p.push_back(0);
  EXPECT_EQ(decode(reframe(encode_grab(vc_grab{1, 1, 1, 0}), p)).rc, VC_PROTO_ETRAILING);
}

TEST(Frame, FromRgbCopiesRowsWithoutStride) {
  const int w = 7, h = 5;
  const size_t stride = 7 * 3 + 5;
  const Bytes img = rgb_image(w, h, stride);
  Bytes b(VC_PROTO_HEADER_SIZE + 12 + w * h * 3);
  size_t len = 0;
  vc_header hdr = header(1042, 99);
  ASSERT_EQ(vc_encode_frame_rgb(b.data(), b.size(), &len, &hdr, 1, VC_FRAME_RGB8, w, h, img.data(), stride),
            0);
  ASSERT_EQ(len, b.size());
  EXPECT_EQ(le16(&b[6]), 14u);  // type FRAME
  EXPECT_EQ(le16(&b[40]), 1u);  // camera
  EXPECT_EQ(le16(&b[42]), 2u);  // rgb8
  EXPECT_EQ(le16(&b[44]), 7u);
  EXPECT_EQ(le16(&b[46]), 5u);
  EXPECT_EQ(le32(&b[48]), 7u * 5 * 3);
  Decoded d = decode(b);
  ASSERT_EQ(d.rc, 1) << d.diag.detail;
  const vc_frame_msg& f = d.msg->u.frame;
  EXPECT_EQ(d.msg->hdr.seq, 1042u);
  EXPECT_EQ(d.msg->hdr.t_trigger_ns, 99u);
  ASSERT_EQ(f.pixels_len, 105u);
  for (int y = 0; y < h; y++)
    EXPECT_EQ(std::memcmp(f.pixels + y * w * 3, img.data() + static_cast<size_t>(y) * stride, w * 3), 0) << y;
}

TEST(Frame, GrayIsFixedPointLuma) {
  const int w = 4, h = 3;
  const Bytes img = rgb_image(w, h, w * 3);
  Bytes b(VC_PROTO_HEADER_SIZE + 12 + w * h);
  size_t len = 0;
  vc_header hdr = header(5);
  ASSERT_EQ(vc_encode_frame_rgb(b.data(), b.size(), &len, &hdr, 0, VC_FRAME_GRAY8, w, h, img.data(), w * 3),
            0);
  Decoded d = decode(b);
  ASSERT_EQ(d.rc, 1) << d.diag.detail;
  ASSERT_EQ(d.msg->u.frame.pixels_len, 12u);
  for (int i = 0; i < w * h; i++) {
    const double y = 0.299 * img[3 * i] + 0.587 * img[3 * i + 1] + 0.114 * img[3 * i + 2];
    EXPECT_NEAR(d.msg->u.frame.pixels[i], y, 1.0) << i;
  }
  // Too small a buffer: -ENOSPC with the size needed, as every encoder.
  len = 0;
  EXPECT_EQ(vc_encode_frame_rgb(b.data(), 30, &len, &hdr, 0, VC_FRAME_GRAY8, w, h, img.data(), w * 3),
            -ENOSPC);
  EXPECT_EQ(len, b.size());
}

TEST(Frame, RejectsBadLengthsSizesFormatsAndCameras) {
  const Bytes img = rgb_image(6, 4, 18);
  vc_frame_msg f{1, VC_FRAME_RGB8, 6, 4, 72, img.data()};
  Bytes good(VC_PROTO_HEADER_SIZE + 12 + 72);
  size_t len = 0;
  vc_header hdr = header(7);
  ASSERT_EQ(vc_encode_frame(good.data(), good.size(), &len, &hdr, &f), 0);
  ASSERT_EQ(decode(good).rc, 1);
  const Bytes p = payload_of(good);
  auto patched = [&](auto patch) {
    Bytes q = p;
    patch(q);
    return decode(reframe(good, q));
  };
  auto st16 = [](Bytes& q, size_t at, uint16_t v) {
    q[at] = static_cast<uint8_t>(v);
    q[at + 1] = static_cast<uint8_t>(v >> 8);
  };
  // pixels_len must be width x height x channels exactly, whatever the payload holds.
  EXPECT_EQ(patched([](Bytes& q) { q[8] = 71; }).rc, VC_PROTO_EINCONSISTENT);
  EXPECT_EQ(patched([](Bytes& q) { q[8] = 73, q.push_back(0); }).rc, VC_PROTO_EINCONSISTENT);
  EXPECT_EQ(patched([&](Bytes& q) { st16(q, 2, VC_FRAME_GRAY8); }).rc, VC_PROTO_EINCONSISTENT);
  // Fewer bytes than announced, more than announced, or not even the fixed part.
  EXPECT_EQ(patched([](Bytes& q) { q.pop_back(); }).rc, VC_PROTO_ETRUNCATED);
  EXPECT_EQ(patched([](Bytes& q) { q.push_back(1); }).rc, VC_PROTO_ETRAILING);
  EXPECT_EQ(patched([](Bytes& q) { q.resize(10); }).rc, VC_PROTO_ETRUNCATED);
  // pixels_len huge (a u32 the payload cannot hold): refused from the sizes, never read.
  EXPECT_EQ(patched([](Bytes& q) { q[8] = q[9] = q[10] = q[11] = 0xFF; }).rc, VC_PROTO_EINCONSISTENT);
  EXPECT_EQ(patched([&](Bytes& q) { st16(q, 0, 8); }).rc, VC_PROTO_EFIELD);
  EXPECT_EQ(patched([&](Bytes& q) { st16(q, 2, 0); }).rc, VC_PROTO_EFIELD);
  EXPECT_EQ(patched([&](Bytes& q) { st16(q, 2, 3); }).rc, VC_PROTO_EFIELD);
  EXPECT_EQ(patched([&](Bytes& q) { st16(q, 4, 0); }).rc, VC_PROTO_EFIELD);
  EXPECT_EQ(patched([&](Bytes& q) { st16(q, 6, 16385); }).rc, VC_PROTO_ELIMIT);
  // A 16384 x 16384 rgb8 image does not fit a payload: ELIMIT, not an overflow.
  EXPECT_EQ(patched([&](Bytes& q) { st16(q, 4, 16384), st16(q, 6, 16384); }).rc, VC_PROTO_ELIMIT);

  // The encoders refuse the same.
  Bytes b(VC_PROTO_HEADER_SIZE + 200);
  vc_frame_msg bad = f;
  bad.pixels_len = 71;
  EXPECT_EQ(vc_encode_frame(b.data(), b.size(), &len, &hdr, &bad), VC_PROTO_EINCONSISTENT);
  bad = f;
  bad.camera = 8;
  EXPECT_EQ(vc_encode_frame(b.data(), b.size(), &len, &hdr, &bad), VC_PROTO_EFIELD);
  EXPECT_EQ(vc_encode_frame_rgb(b.data(), b.size(), &len, &hdr, 0, 9, 6, 4, img.data(), 18), VC_PROTO_EFIELD);
  EXPECT_EQ(vc_encode_frame_rgb(b.data(), b.size(), &len, &hdr, 0, 1, 6, 4, img.data(), 17), -EINVAL);
  EXPECT_EQ(vc_encode_frame_rgb(b.data(), b.size(), &len, &hdr, 0, 2, 2048, 2048, img.data(), 6144),
            VC_PROTO_ELIMIT);  // 12 MiB of rgb8
}

TEST(Frame, ANewerMinorMayAppendFields) {
  const Bytes img = rgb_image(2, 2, 6);
  vc_frame_msg f{0, VC_FRAME_RGB8, 2, 2, 12, img.data()};
  Bytes b(VC_PROTO_HEADER_SIZE + 24);
  size_t len = 0;
  vc_header hdr = header(7);
  ASSERT_EQ(vc_encode_frame(b.data(), b.size(), &len, &hdr, &f), 0);
  Bytes p = payload_of(b);
  p.insert(p.end(), {1, 2, 3});
  vc_header h{};
  h.version_major = VC_PROTO_VERSION_MAJOR;
  h.version_minor = VC_PROTO_VERSION_MINOR + 1;
  h.type = VC_MSG_FRAME;
  Bytes n(VC_PROTO_HEADER_SIZE + p.size());
  ASSERT_EQ(vc_frame_encode(n.data(), n.size(), &len, &h, p.data(), p.size()), 0);
  Decoded d = decode(n);
  ASSERT_EQ(d.rc, 1) << d.diag.detail;
  EXPECT_EQ(d.msg->ignored_bytes, 3u);
  EXPECT_EQ(std::memcmp(d.msg->u.frame.pixels, img.data(), 12), 0);
}

TEST(Frame, NamesAndChannels) {
  EXPECT_STREQ(vc_frame_format_name(VC_FRAME_GRAY8), "gray8");
  EXPECT_STREQ(vc_frame_format_name(VC_FRAME_RGB8), "rgb8");
  EXPECT_EQ(vc_frame_format_name(0), nullptr);
  EXPECT_EQ(vc_frame_format_channels(VC_FRAME_RGB8), 3u);
  EXPECT_EQ(vc_frame_format_channels(7), 0u);
  EXPECT_STREQ(vc_counter_name(VC_COUNTER_FRAMES_SENT), "frames_sent");
  EXPECT_STREQ(vc_counter_name(VC_COUNTER_FRAMES_DROPPED), "frames_dropped");
}

}  // namespace
