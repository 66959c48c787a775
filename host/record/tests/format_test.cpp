// records.vcr byte format: every record type round-trips bit-exactly, the layout is the one README.md
// documents, and the decoders reject every malformed body (short, long, bad counts, bad RLE).
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "session_fixture.hpp"
#include "voxcap/crc32c.h"
#include "voxcap/record/format.hpp"

namespace vc::record {
namespace {

using format::Header;
using format::RecordType;
using testing::make_features;
using testing::make_frame;
using testing::make_pose;
using testing::make_stats;
using testing::same_record;

uint32_t le32(const std::vector<uint8_t>& b, size_t off) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<uint32_t>(b[off + i]) << (8 * i);
  return v;
}
uint64_t le64(const std::vector<uint8_t>& b, size_t off) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<uint64_t>(b[off + i]) << (8 * i);
  return v;
}

// Decodes a whole encoded record the way the reader does; fails the test on any framing problem.
template <typename R>
R decode_whole(const std::vector<uint8_t>& bytes, RecordType want_type, uint64_t want_index) {
  Header h;
  std::string why;
  EXPECT_TRUE(format::decode_header(bytes.data(), &h, &why)) << why;
  EXPECT_EQ(h.type, want_type);
  EXPECT_EQ(h.index, want_index);
  EXPECT_EQ(bytes.size(), format::kHeaderBytes + h.body_bytes + format::kTrailerBytes);
  EXPECT_TRUE(format::check_crc(bytes));
  R out;
  EXPECT_TRUE(format::decode_body({bytes.data() + format::kHeaderBytes, h.body_bytes}, &out, &why)) << why;
  return out;
}

TEST(RecordFormat, FrameRoundTrips) {
  for (uint64_t seq : {0ull, 3ull, 10ull}) {
    const FrameRecord f = make_frame(seq);
    ASSERT_FALSE(f.rle.empty());
    std::vector<uint8_t> bytes;
    format::encode(f, 42 + seq, bytes);
    EXPECT_EQ(decode_whole<FrameRecord>(bytes, RecordType::Frame, 42 + seq), f);
  }
}

TEST(RecordFormat, FrameWithoutHullAndExtremeValuesRoundTrips) {
  FrameRecord f;
  f.seq = std::numeric_limits<uint64_t>::max();
  f.t_trigger_ns = std::numeric_limits<uint64_t>::max() - 1;
  f.t_merged_ns = 1;
  f.grid_id = 0xFFFFFFFF;
  f.voxel_count = 1ull << 40;  // not checked against anything without a hull
  f.occupied = 12345;
  f.degraded = true;
  f.nodes_missing = {0xFFFE, 0, 65535};
  std::vector<uint8_t> bytes;
  format::encode(f, 0xFFFFFFFFFFull, bytes);
  EXPECT_EQ(decode_whole<FrameRecord>(bytes, RecordType::Frame, 0xFFFFFFFFFFull), f);
}

TEST(RecordFormat, FeaturesRoundTripBitExactly) {
  FeatureRecord r = make_features(5, 3, 1);  // seq 5 holds a NaN (lost) feature
  r.features.push_back({65535, 65535, std::numeric_limits<float>::infinity(), -0.0f,
                        std::numeric_limits<float>::denorm_min()});
  std::vector<uint8_t> bytes;
  format::encode(r, 9, bytes);
  const FeatureRecord back = decode_whole<FeatureRecord>(bytes, RecordType::Features, 9);
  EXPECT_TRUE(std::isnan(back.features[4].u));
  EXPECT_TRUE(std::signbit(back.features.back().v));
  EXPECT_TRUE(same_record(back, r));

  FeatureRecord empty;
  format::encode(empty, 1, bytes);
  EXPECT_EQ(bytes.size(), format::kHeaderBytes + format::kFeaturesFixed + format::kTrailerBytes);
  EXPECT_EQ(decode_whole<FeatureRecord>(bytes, RecordType::Features, 1), empty);
}

TEST(RecordFormat, PoseRoundTrips) {
  for (bool names : {true, false}) {
    PoseRecord p = make_pose(77, names);
    if (names) p.joint_names.push_back("épaule_gauche");  // UTF-8 is bytes
    p.values.push_back(std::numeric_limits<double>::quiet_NaN());
    std::vector<uint8_t> bytes;
    format::encode(p, 3, bytes);
    EXPECT_TRUE(same_record(decode_whole<PoseRecord>(bytes, RecordType::Pose, 3), p));
  }
  PoseRecord empty;
  std::vector<uint8_t> bytes;
  format::encode(empty, 1, bytes);
  EXPECT_EQ(decode_whole<PoseRecord>(bytes, RecordType::Pose, 1), empty);
}

TEST(RecordFormat, StatsRoundTrips) {
  const StatsRecord s = make_stats(123456789, kHostNodeId);
  std::vector<uint8_t> bytes;
  format::encode(s, 4, bytes);
  EXPECT_EQ(decode_whole<StatsRecord>(bytes, RecordType::Stats, 4), s);
}

TEST(RecordFormat, BeginAndEndRoundTrip) {
  format::BeginRecord b{format::kFormatVersion, -5, 99, "{\"x\": 1}\n"};
  std::vector<uint8_t> bytes;
  format::encode(b, 0, bytes);
  EXPECT_EQ(decode_whole<format::BeginRecord>(bytes, RecordType::Begin, 0), b);
  format::EndRecord e{1234, 1700000000000000000};
  format::encode(e, 1235, bytes);
  EXPECT_EQ(decode_whole<format::EndRecord>(bytes, RecordType::End, 1235), e);
}

// The byte layout documented in README.md (FORMAT), field by field.
TEST(RecordFormat, FrameLayoutIsTheDocumentedOne) {
  FrameRecord f = make_frame(3);  // degraded: present {0, 1}, missing {2}
  std::vector<uint8_t> b;
  format::encode(f, 0x0102030405060708ull, b);
  const size_t body = 56 + 2 * 3 + f.rle.size();
  ASSERT_EQ(b.size(), 24 + body + 4);
  EXPECT_EQ(std::string(b.begin(), b.begin() + 4), "VXRC");
  EXPECT_EQ(b[4], 2);  // type frame
  EXPECT_EQ(b[5], 0);
  EXPECT_EQ(b[6] | b[7], 0);
  EXPECT_EQ(le32(b, 8), body);
  EXPECT_EQ(b[12], 0x08);  // record index, little-endian
  EXPECT_EQ(b[19], 0x01);
  EXPECT_EQ(le32(b, 20), vc_crc32c(0, b.data(), 20));
  EXPECT_EQ(le64(b, 24 + 0), f.seq);
  EXPECT_EQ(le64(b, 24 + 8), f.t_trigger_ns);
  EXPECT_EQ(le64(b, 24 + 16), f.t_merged_ns);
  EXPECT_EQ(le64(b, 24 + 24), f.voxel_count);
  EXPECT_EQ(le64(b, 24 + 32), f.occupied);
  EXPECT_EQ(le32(b, 24 + 40), f.grid_id);
  EXPECT_EQ(b[24 + 44], 1);  // flags: degraded
  EXPECT_EQ(b[24 + 45], 0);
  EXPECT_EQ(b[24 + 46], 2);  // n_present
  EXPECT_EQ(b[24 + 48], 1);  // n_missing
  EXPECT_EQ(le32(b, 24 + 52), f.rle.size());
  EXPECT_EQ(b[24 + 56], 0);  // present[0] = 0
  EXPECT_EQ(b[24 + 58], 1);  // present[1] = 1
  EXPECT_EQ(b[24 + 60], 2);  // missing[0] = 2
  EXPECT_TRUE(std::equal(f.rle.begin(), f.rle.end(), b.begin() + 24 + 62));
  EXPECT_EQ(le32(b, b.size() - 4), vc_crc32c(0, b.data(), b.size() - 4));
}

TEST(RecordFormat, FeaturesPoseStatsLayout) {
  FeatureRecord fr;
  fr.seq = 9;
  fr.node_id = 0x0201;
  fr.camera = 1;
  fr.features = {{7, 2, 1.5f, -2.0f, 0.25f}};
  std::vector<uint8_t> b;
  format::encode(fr, 1, b);
  ASSERT_EQ(b.size(), 24 + 16 + 16 + 4u);
  EXPECT_EQ(b[4], 3);
  EXPECT_EQ(le64(b, 24), 9u);
  EXPECT_EQ(b[32], 0x01);
  EXPECT_EQ(b[33], 0x02);
  EXPECT_EQ(b[34], 1);
  EXPECT_EQ(le32(b, 36), 1u);
  EXPECT_EQ(b[40], 7);
  EXPECT_EQ(b[42], 2);
  EXPECT_EQ(le32(b, 44), 0x3FC00000u);  // 1.5f
  EXPECT_EQ(le32(b, 48), 0xC0000000u);  // -2.0f
  EXPECT_EQ(le32(b, 52), 0x3E800000u);  // 0.25f

  PoseRecord p;
  p.seq = 4;
  p.layout = "xyz";
  p.joint_names = {"a", "bc"};
  p.values = {1.0};
  format::encode(p, 2, b);
  ASSERT_EQ(b.size(), 24 + 16 + 3 + (2 + 1) + (2 + 2) + 8 + 4u);
  EXPECT_EQ(b[4], 4);
  EXPECT_EQ(le32(b, 32), 1u);  // n_values
  EXPECT_EQ(b[36], 2);         // n_names
  EXPECT_EQ(b[38], 3);         // layout_len
  EXPECT_EQ(std::string(b.begin() + 40, b.begin() + 43), "xyz");
  EXPECT_EQ(b[43], 1);
  EXPECT_EQ(b[45], 'a');
  EXPECT_EQ(b[46], 2);
  EXPECT_EQ(std::string(b.begin() + 48, b.begin() + 50), "bc");
  EXPECT_EQ(le64(b, 50), 0x3FF0000000000000ull);  // 1.0

  StatsRecord s{5, 0xFFFF, "{}"};
  format::encode(s, 3, b);
  ASSERT_EQ(b.size(), 24 + 16 + 2 + 4u);
  EXPECT_EQ(b[4], 5);
  EXPECT_EQ(le64(b, 24), 5u);
  EXPECT_EQ(b[32], 0xFF);
  EXPECT_EQ(b[33], 0xFF);
  EXPECT_EQ(le32(b, 36), 2u);
  EXPECT_EQ(b[40], '{');
}

TEST(RecordFormat, CheckRejectsRecordsTheReaderWouldNot) {
  std::string why;
  FrameRecord f = make_frame(1);
  f.occupied += 1;
  EXPECT_FALSE(format::check(f, &why));
  EXPECT_THAT(why, ::testing::HasSubstr("hull RLE holds"));
  f = make_frame(1);
  f.voxel_count *= 2;
  EXPECT_FALSE(format::check(f, &why));
  f = make_frame(1);
  f.rle.push_back(0x80);  // an unterminated varint
  EXPECT_FALSE(format::check(f, &why));
  EXPECT_THAT(why, ::testing::HasSubstr("malformed"));
  f = make_frame(1, 0);
  f.occupied = f.voxel_count + 1;
  EXPECT_FALSE(format::check(f, &why));
  f = make_frame(1);
  f.nodes_present.assign(70000, 1);
  EXPECT_FALSE(format::check(f, &why));

  StatsRecord s{1, 0, "{\"fps\": 60"};
  EXPECT_FALSE(format::check(s, &why));
  EXPECT_THAT(why, ::testing::HasSubstr("not valid JSON"));
  s.json = "";
  EXPECT_FALSE(format::check(s, &why));

  PoseRecord p;
  p.layout.assign(70000, 'x');
  EXPECT_FALSE(format::check(p, &why));
  p.layout.clear();
  p.joint_names = {std::string(70000, 'j')};
  EXPECT_FALSE(format::check(p, &why));

  std::vector<uint8_t> out;
  EXPECT_THROW(format::encode(s, 1, out), std::invalid_argument);
}

// Every proper prefix and every one-byte extension of a valid body is rejected.
template <typename R>
void expect_exact_body(const R& r) {
  std::vector<uint8_t> bytes;
  format::encode(r, 1, bytes);
  std::vector<uint8_t> body(bytes.begin() + format::kHeaderBytes, bytes.end() - format::kTrailerBytes);
  R out;
  std::string why;
  ASSERT_TRUE(format::decode_body(body, &out, &why)) << why;
  for (size_t n = 0; n < body.size(); ++n)
    EXPECT_FALSE(format::decode_body({body.data(), n}, &out, &why)) << "prefix of " << n << " bytes accepted";
  body.push_back(0);
  EXPECT_FALSE(format::decode_body(body, &out, &why)) << "extra byte accepted";
}

TEST(RecordFormat, DecodersRejectShortAndLongBodies) {
  expect_exact_body(make_frame(3));
  expect_exact_body(make_features(4, 0, 1));
  expect_exact_body(make_pose(5, true));
  expect_exact_body(make_stats(6, 2));
  expect_exact_body(format::BeginRecord{format::kFormatVersion, 1, 2, "{}"});
  expect_exact_body(format::EndRecord{3, 4});
}

TEST(RecordFormat, DecodersRejectBadFieldsEvenWithAGoodCrc) {
  std::vector<uint8_t> bytes;
  format::encode(make_frame(1), 1, bytes);
  std::vector<uint8_t> body(bytes.begin() + format::kHeaderBytes, bytes.end() - format::kTrailerBytes);
  FrameRecord f;
  std::string why;
  auto with = [&](size_t off, uint8_t v) {
    std::vector<uint8_t> b = body;
    b[off] = v;
    return format::decode_body(b, &f, &why);
  };
  EXPECT_FALSE(with(44, 2));     // unknown flag
  EXPECT_FALSE(with(45, 1));     // reserved
  EXPECT_FALSE(with(50, 1));     // reserved
  EXPECT_FALSE(with(46, 200));   // n_present past the body
  EXPECT_FALSE(with(32, 0xFF));  // occupied no longer matches the RLE

  format::BeginRecord begin{format::kFormatVersion + 1, 0, 0, ""};
  format::encode(begin, 0, bytes);
  format::BeginRecord b;
  EXPECT_FALSE(format::decode_body({bytes.data() + 24, bytes.size() - 28}, &b, &why));
  EXPECT_THAT(why, ::testing::HasSubstr("format version"));
}

TEST(RecordFormat, HeaderRejections) {
  std::vector<uint8_t> bytes;
  format::encode(make_stats(1, 1), 5, bytes);
  Header h;
  std::string why;
  ASSERT_TRUE(format::decode_header(bytes.data(), &h, &why));

  auto reseal = [](std::vector<uint8_t> b) {  // recompute the header CRC after an edit
    const uint32_t crc = vc_crc32c(0, b.data(), 20);
    for (int i = 0; i < 4; ++i) b[20 + i] = static_cast<uint8_t>(crc >> (8 * i));
    return b;
  };
  std::vector<uint8_t> b = bytes;
  b[0] = 'W';
  EXPECT_FALSE(format::decode_header(b.data(), &h, &why));
  EXPECT_THAT(why, ::testing::HasSubstr("magic"));
  b = bytes;
  b[9] ^= 1;  // body length
  EXPECT_FALSE(format::decode_header(b.data(), &h, &why));
  EXPECT_THAT(why, ::testing::HasSubstr("header CRC"));
  b = bytes;
  b[4] = 9;
  EXPECT_FALSE(format::decode_header(reseal(b).data(), &h, &why));
  EXPECT_THAT(why, ::testing::HasSubstr("unknown record type 9"));
  b = bytes;
  b[4] = 0;
  EXPECT_FALSE(format::decode_header(reseal(b).data(), &h, &why));
  b = bytes;
  b[6] = 1;
  EXPECT_FALSE(format::decode_header(reseal(b).data(), &h, &why));
  b = bytes;
  b[11] = 0x7F;  // 2 GiB body
  EXPECT_FALSE(format::decode_header(reseal(b).data(), &h, &why));
  EXPECT_THAT(why, ::testing::HasSubstr("over the limit"));

  b = bytes;
  b[30] ^= 0x10;  // body byte: header fine, record CRC not
  EXPECT_TRUE(format::decode_header(b.data(), &h, &why));
  EXPECT_FALSE(format::check_crc(b));
  b = bytes;
  b.back() ^= 0x80;  // the CRC itself
  EXPECT_FALSE(format::check_crc(b));
}

TEST(RecordFormat, EncodeReusesTheBufferCapacity) {
  std::vector<uint8_t> buf;
  format::encode(make_frame(1), 1, buf);
  const size_t big = buf.capacity();
  const uint8_t* data = buf.data();
  format::encode(make_stats(1, 1), 2, buf);
  format::encode(make_frame(1), 3, buf);
  EXPECT_EQ(buf.capacity(), big);
  EXPECT_EQ(buf.data(), data);
}

}  // namespace
}  // namespace vc::record
