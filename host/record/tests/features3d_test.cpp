// FEATURES3D (format version 2; 3: the naming's trust in the state byte's bit 7): the host's triangulated
// features round-trip bit-exactly through the format and a session; bad bodies are rejected; version-1
// sessions (without them) and version-2 bodies (every name trusted) still read.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "session_fixture.hpp"
#include "voxcap/record/format.hpp"

namespace vc::record {
namespace {

using testing::read_bytes;
using testing::TempDir;
using testing::write_bytes;
using testing::write_rig_files;

Features3DRecord make_features3d(uint64_t seq) {
  Features3DRecord r;
  r.seq = seq;
  for (uint16_t id = 0; id < 5; ++id) {
    Features3DRecord::P p;
    p.id = id;
    p.state = static_cast<uint8_t>(id % 3);
    p.x = 0.125 * id - 0.3;
    p.y = id == 4 ? std::numeric_limits<double>::quiet_NaN() : -1.5e-3 * id;
    p.z = 1.75 - 0.4 * id;
    p.confidence = 0.2f * static_cast<float>(id);
    p.reproj_px = 0.75f + static_cast<float>(id);
    p.name_trusted = id != 3;  // the left foot's naming not trusted
    for (uint16_t v = 0; v < id + 1; ++v) p.views.push_back(static_cast<uint16_t>(7 - v));
    r.features.push_back(p);
  }
  return r;
}

bool bit_equal(const Features3DRecord& a, const Features3DRecord& b) {
  std::vector<uint8_t> ea, eb;
  format::encode(a, 0, ea);
  format::encode(b, 0, eb);
  return ea == eb;
}

TEST(RecordFeatures3D, RoundTripsBitExactlyWithTheDocumentedLayout) {
  const Features3DRecord r = make_features3d(42);
  std::vector<uint8_t> bytes;
  format::encode(r, 3, bytes);
  format::Header h;
  std::string why;
  ASSERT_TRUE(format::decode_header(bytes.data(), &h, &why)) << why;
  EXPECT_EQ(h.type, format::RecordType::Features3D);
  EXPECT_STREQ(format::to_string(h.type), "features3d");
  // 12 fixed + per feature 36 + 2 per view (1 + 2 + 3 + 4 + 5 views).
  EXPECT_EQ(h.body_bytes, 12u + 5 * 36 + 2 * 15);
  EXPECT_TRUE(format::check_crc(bytes));
  const std::span<const uint8_t> body(bytes.data() + format::kHeaderBytes, h.body_bytes);
  EXPECT_EQ(body[0], 42);      // u64 seq
  EXPECT_EQ(body[8], 5);       // u16 count
  EXPECT_EQ(body[12 + 2], 0);  // first feature's state
  EXPECT_EQ(body[12 + 3], 1);  // its n_views
  // The fourth feature (1 + 2 + 3 views before it): state 0 with bit 7, its naming not trusted.
  EXPECT_EQ(body[12 + 3 * 36 + 2 * 6 + 2], 0x80);
  Features3DRecord out;
  ASSERT_TRUE(format::decode_body(body, &out, &why)) << why;
  EXPECT_TRUE(bit_equal(r, out));
  EXPECT_EQ(out.features[2].views, (std::vector<uint16_t>{7, 6, 5}));
  EXPECT_TRUE(std::isnan(out.features[4].y));
  EXPECT_FALSE(out.features[3].name_trusted);
  EXPECT_TRUE(out.features[2].name_trusted);
}

TEST(RecordFeatures3D, AVersionTwoBodyReadsWithEveryNameTrusted) {
  // Version 2 wrote the state byte without bit 7: the same bytes read back with every name trusted.
  Features3DRecord r = make_features3d(7);
  for (Features3DRecord::P& p : r.features) p.name_trusted = true;
  std::vector<uint8_t> bytes;
  format::encode(r, 1, bytes);
  const std::span<const uint8_t> body(bytes.data() + format::kHeaderBytes,
                                      bytes.size() - format::kHeaderBytes - format::kTrailerBytes);
  for (size_t off = 12, i = 0; i < r.features.size(); off += 36 + 2 * r.features[i].views.size(), ++i)
    EXPECT_EQ(body[off + 2], r.features[i].state) << i;  // the version-2 layout, byte for byte
  Features3DRecord out;
  std::string why;
  ASSERT_TRUE(format::decode_body(body, &out, &why)) << why;
  for (const Features3DRecord::P& p : out.features) EXPECT_TRUE(p.name_trusted);
  EXPECT_TRUE(bit_equal(out, r));  // (a NaN coordinate: not operator==)
}

TEST(RecordFeatures3D, BadBodiesAreRejected) {
  std::vector<uint8_t> bytes;
  format::encode(make_features3d(1), 1, bytes);
  std::vector<uint8_t> body(bytes.begin() + format::kHeaderBytes, bytes.end() - format::kTrailerBytes);
  Features3DRecord out;
  std::string why;
  for (size_t n = 0; n < body.size(); ++n)
    EXPECT_FALSE(format::decode_body({body.data(), n}, &out, &why)) << "prefix of " << n << " bytes accepted";
  auto with = [&](size_t off, uint8_t v) {
    std::vector<uint8_t> b = body;
    b[off] = v;
    return format::decode_body(b, &out, &why);
  };
  EXPECT_FALSE(with(10, 1));         // reserved
  EXPECT_FALSE(with(12 + 2, 3));     // unknown state
  EXPECT_FALSE(with(12 + 2, 0x83));  // unknown state, its naming untrusted
  EXPECT_FALSE(with(12 + 3, 200));   // n_views past the body
  EXPECT_FALSE(with(8, 6));          // count past the body
  std::vector<uint8_t> longer = body;
  longer.push_back(0);
  EXPECT_FALSE(format::decode_body(longer, &out, &why));

  Features3DRecord bad = make_features3d(2);
  bad.features[0].state = 9;
  EXPECT_FALSE(format::check(bad, &why));
  std::vector<uint8_t> buf;
  EXPECT_THROW(format::encode(bad, 1, buf), std::invalid_argument);
  bad = make_features3d(2);
  bad.features[1].views.assign(300, 1);
  EXPECT_FALSE(format::check(bad, &why));
}

TEST(RecordFeatures3D, SessionRoundTripAndVersionOneSessionsStillRead) {
  TempDir tmp;
  const testing::RigFiles rig = write_rig_files(tmp.path());
  const auto dir = tmp.path() / "s";
  {
    Recorder rec = Recorder::create(dir, rig.rig_toml, rig.calibration_yaml, "{}");
    for (uint64_t seq = 1; seq <= 3; ++seq) {
      rec.append(testing::make_frame(seq));
      rec.append(make_features3d(seq));
    }
    rec.close();
  }
  {
    Reader reader = Reader::open(dir);
    EXPECT_EQ(reader.summary().format_version, format::kFormatVersion);
    EXPECT_EQ(reader.summary().features3d, 3u);
    EXPECT_EQ(reader.summary().frames, 3u);
    EXPECT_TRUE(reader.summary().closed_cleanly);
    Record r;
    int seen = 0;
    while (reader.next(r))
      if (const auto* f = std::get_if<Features3DRecord>(&r)) {
        ++seen;
        EXPECT_TRUE(bit_equal(*f, make_features3d(f->seq)));
      }
    EXPECT_EQ(seen, 3);
  }

  // A version-1 session (frames only): BEGIN rewritten with format_version 1, same length.
  const auto dir1 = tmp.path() / "v1";
  {
    Recorder rec = Recorder::create(dir1, rig.rig_toml, rig.calibration_yaml, "{}");
    rec.append(testing::make_frame(1));
    rec.close();
  }
  std::vector<uint8_t> vcr = read_bytes(dir1 / "records.vcr");
  format::Header h;
  std::string why;
  ASSERT_TRUE(format::decode_header(vcr.data(), &h, &why));
  format::BeginRecord begin;
  ASSERT_TRUE(format::decode_body({vcr.data() + format::kHeaderBytes, h.body_bytes}, &begin, &why)) << why;
  begin.format_version = 1;
  std::vector<uint8_t> b1;
  format::encode(begin, 0, b1);
  ASSERT_EQ(b1.size(), format::kHeaderBytes + h.body_bytes + format::kTrailerBytes);
  std::copy(b1.begin(), b1.end(), vcr.begin());
  write_bytes(dir1 / "records.vcr", vcr);
  Reader old = Reader::open(dir1);
  EXPECT_EQ(old.summary().format_version, 1u);
  EXPECT_EQ(old.summary().frames, 1u);
  EXPECT_EQ(old.summary().features3d, 0u);
  EXPECT_TRUE(old.summary().closed_cleanly);
}

}  // namespace
}  // namespace vc::record
