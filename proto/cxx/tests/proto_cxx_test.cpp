// vc_proto_cxx: every typed encoder reproduces the committed vector of its message byte for byte (the
// vectors are decoded with the C library, so the test does not depend on the structs' fields); encodes
// the C library rejects throw ProtoError with its code and vc_proto_strerror's text; messages larger than
// the wrapper's first buffer come out whole; the trigger datagram and RLE helpers.
#include "voxcap/proto.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using vc::proto::Bytes;
using vc::proto::ProtoError;

const fs::path kVectors = PROTO_VECTORS_DIR;

Bytes read_vector(const std::string& name) {
  std::ifstream f(kVectors / (name + ".bin"), std::ios::binary);
  EXPECT_TRUE(f) << "no vector " << name;
  return Bytes(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// The one message of a vector, decoded by the C library (views point into `bytes`).
vc_msg decode_one(const Bytes& bytes) {
  vc_msg msg{};
  size_t used = 0;
  EXPECT_EQ(vc_msg_decode(bytes.data(), bytes.size(), 0, &msg, &used, nullptr), 1);
  EXPECT_EQ(used, bytes.size());
  return msg;
}

// The typed overload for the message's type, as a caller holding that struct would call it.
Bytes encode_typed(const vc_msg& m) {
  switch (m.hdr.type) {
    case VC_MSG_HELLO:
      return vc::proto::encode(m.u.hello, m.hdr);
    case VC_MSG_CONFIG:
      return vc::proto::encode(m.u.config, m.hdr);
    case VC_MSG_BACKGROUND:
      return vc::proto::encode(m.u.background, m.hdr);
    case VC_MSG_START:
      return vc::proto::encode_start(m.hdr);
    case VC_MSG_STOP:
      return vc::proto::encode_stop(m.hdr);
    case VC_MSG_HULL:
      return vc::proto::encode(m.u.hull, m.hdr);
    case VC_MSG_FEATURES:
      return vc::proto::encode(m.u.features, m.hdr);
    case VC_MSG_STATS:
      return vc::proto::encode(m.u.stats, m.hdr);
    case VC_MSG_HEARTBEAT:
      return vc::proto::encode(m.u.heartbeat, m.hdr);
    case VC_MSG_ERROR:
      return vc::proto::encode(m.u.error, m.hdr);
    case VC_MSG_SILHOUETTE:
      return vc::proto::encode(m.u.silhouette, m.hdr);
    default:
      ADD_FAILURE() << "type " << m.hdr.type;
      return {};
  }
}

class EveryMessage : public ::testing::TestWithParam<const char*> {};

TEST_P(EveryMessage, EncodesItsVectorByteForByte) {
  const Bytes want = read_vector(GetParam());
  const vc_msg m = decode_one(want);
  EXPECT_EQ(encode_typed(m), want);
  EXPECT_EQ(vc::proto::encode(m), want);
}

INSTANTIATE_TEST_SUITE_P(ProtoCxx, EveryMessage,
                         ::testing::Values("hello", "config", "background", "start", "stop", "hull",
                                           "hull_empty", "features", "stats", "heartbeat", "error",
                                           "silhouette"));

TEST(ProtoCxx, HullFromBitsIsTheHullVector) {
  const Bytes want = read_vector("hull");
  const vc_msg m = decode_one(want);
  Bytes bits((m.u.hull.voxel_count + 7) / 8);
  ASSERT_EQ(vc_rle_decode(m.u.hull.rle, m.u.hull.rle_len, bits.data(), m.u.hull.voxel_count), 0);
  EXPECT_EQ(vc::proto::encode_hull_bits(bits, m.u.hull.voxel_count, m.u.hull.grid_id, m.hdr), want);
}

TEST(ProtoCxx, SilhouetteFromBitsIsTheSilhouetteVector) {
  const Bytes want = read_vector("silhouette");
  const vc_msg m = decode_one(want);
  const vc_silhouette& s = m.u.silhouette;
  const size_t n = size_t{s.width} * s.height;
  Bytes bits((n + 7) / 8);
  ASSERT_EQ(vc_rle_decode(s.rle, s.rle_len, bits.data(), n), 0);
  EXPECT_EQ(vc::proto::encode_silhouette_bits(bits, s.camera, s.scale, s.width, s.height, m.hdr), want);
  bits.pop_back();  // one byte short of width*height bits: refused, never read past
  EXPECT_THROW(vc::proto::encode_silhouette_bits(bits, s.camera, s.scale, s.width, s.height, m.hdr),
               vc::proto::ProtoError);
}

// A message larger than the wrapper's first buffer is encoded again at its size: whole and valid.
TEST(ProtoCxx, LargeHullComesOutWhole) {
  const size_t n = 64 * 64 * 64;
  Bytes bits(n / 8);
  for (size_t i = 0; i < bits.size(); i++) bits[i] = static_cast<uint8_t>(i * 37u + (i >> 5));
  vc_header hdr{};
  hdr.node_id = 2;
  hdr.seq = 99;
  const Bytes msg = vc::proto::encode_hull_bits(bits, n, 5, hdr);
  ASSERT_GT(msg.size(), 4096u);
  Bytes c(VC_PROTO_HEADER_SIZE + 24 + vc_rle_max_encoded_size(n));
  size_t len = 0;
  ASSERT_EQ(vc_encode_hull_bits(c.data(), c.size(), &len, &hdr, 5, bits.data(), n), 0);
  c.resize(len);
  EXPECT_EQ(msg, c);
  const vc_msg back = decode_one(msg);
  EXPECT_EQ(back.hdr.seq, 99u);
  EXPECT_EQ(back.u.hull.voxel_count, n);
}

TEST(ProtoCxx, ARejectedBodyThrowsTheEncodersCode) {
  vc_features f{};
  f.feature_count = VC_PROTO_MAX_FEATURES + 1;
  try {
    vc::proto::encode(f);
    FAIL() << "no exception";
  } catch (const ProtoError& e) {
    EXPECT_EQ(e.code(), VC_PROTO_ELIMIT);
    EXPECT_STREQ(e.name(), "VC_PROTO_ELIMIT");
    EXPECT_THAT(e.what(), HasSubstr("encoding FEATURES"));
    EXPECT_THAT(e.what(), HasSubstr(vc_proto_strerror(VC_PROTO_ELIMIT)));
  }
}

TEST(ProtoCxx, AnInconsistentHullThrows) {
  const Bytes v = read_vector("hull");
  vc_msg m = decode_one(v);
  m.u.hull.occupied_count += 1;  // no longer the RLE's popcount
  try {
    vc::proto::encode(m.u.hull, m.hdr);
    FAIL() << "no exception";
  } catch (const ProtoError& e) {
    EXPECT_LT(e.code(), 0);
    EXPECT_THAT(e.what(), HasSubstr("encoding HULL: "));
    EXPECT_THAT(e.what(), HasSubstr(vc_proto_strerror(e.code())));
  }
  EXPECT_THROW(vc::proto::encode(m), ProtoError);
}

TEST(ProtoCxx, AHelloForAnotherNodeThrows) {
  const Bytes v = read_vector("hello");
  vc_msg m = decode_one(v);
  vc_header hdr = m.hdr;
  hdr.node_id = static_cast<uint16_t>(m.u.hello.node_id + 1);
  EXPECT_THROW(vc::proto::encode(m.u.hello, hdr), ProtoError);
}

TEST(ProtoCxx, AnUnknownTypeThrowsEinval) {
  vc_msg m{};
  m.hdr.type = 77;
  try {
    vc::proto::encode(m);
    FAIL() << "no exception";
  } catch (const ProtoError& e) {
    EXPECT_EQ(e.code(), -EINVAL);
    EXPECT_THAT(e.what(), HasSubstr("encoding message type 77"));
  }
}

TEST(ProtoCxx, AShortBitsetThrowsInsteadOfReadingPastIt) {
  const Bytes bits(7);
  EXPECT_THROW(vc::proto::encode_hull_bits(bits, 64, 1), ProtoError);
  EXPECT_NO_THROW(vc::proto::encode_hull_bits(bits, 56, 1));
}

TEST(ProtoCxx, CheckPassesCodesOnAndThrowsNegativeOnes) {
  EXPECT_EQ(vc::proto::check(0, "x"), 0);
  EXPECT_EQ(vc::proto::check(1, "x"), 1);
  try {
    vc::proto::check(VC_PROTO_EMAGIC, "reading the stream");
    FAIL() << "no exception";
  } catch (const ProtoError& e) {
    EXPECT_STREQ(e.what(), "reading the stream: bad magic (VC_PROTO_EMAGIC)");
  }
}

TEST(ProtoCxx, TriggerDatagramRoundTripsAndMatchesItsVector) {
  const Bytes want = read_vector("trigger");
  ASSERT_EQ(want.size(), size_t{VC_TRIGGER_DGRAM_SIZE});
  const auto p = vc::proto::decode_trigger(want);
  ASSERT_TRUE(p);
  const auto d = vc::proto::encode_trigger(p->seq, p->t_ns);
  EXPECT_EQ(Bytes(d.begin(), d.end()), want);

  const auto q = vc::proto::decode_trigger(vc::proto::encode_trigger(7, 123456789));
  ASSERT_TRUE(q);
  EXPECT_EQ(q->seq, 7u);
  EXPECT_EQ(q->t_ns, 123456789u);
}

TEST(ProtoCxx, BytesThatAreNoDatagramGiveNothing) {
  const auto d = vc::proto::encode_trigger(1, 2);
  EXPECT_FALSE(vc::proto::decode_trigger(std::span<const uint8_t>(d.data(), d.size() - 1)));
  EXPECT_FALSE(vc::proto::decode_trigger({}));
  auto bad = d;
  bad[0] ^= 1;  // magic
  EXPECT_FALSE(vc::proto::decode_trigger(bad));
  EXPECT_FALSE(vc::proto::decode_trigger(read_vector("trigger_bad_version")));
}

TEST(ProtoCxx, RleInspectCountsOrThrows) {
  const Bytes v = read_vector("hull");
  const vc_msg m = decode_one(v);
  const vc_rle_info info = vc::proto::rle_inspect({m.u.hull.rle, m.u.hull.rle_len});
  EXPECT_EQ(info.total, m.u.hull.voxel_count);
  EXPECT_EQ(info.occupied, m.u.hull.occupied_count);
  EXPECT_EQ(info.runs, m.u.hull.run_count);

  const Bytes padded{0x80, 0x00, 0x05};  // a non-minimal varint
  try {
    vc::proto::rle_inspect(padded);
    FAIL() << "no exception";
  } catch (const ProtoError& e) {
    EXPECT_EQ(e.code(), -EBADMSG);
    EXPECT_THAT(e.what(), HasSubstr("inspecting RLE: malformed data"));
  }
}

}  // namespace
