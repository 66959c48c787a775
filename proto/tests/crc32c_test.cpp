// CRC32C: the standard check value, known vectors (RFC 3720 B.4), incremental use, and the
// accelerated path against the portable one on every length and alignment.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "voxcap/crc32c.h"

namespace {

TEST(Crc32c, CheckValue) {
  const char* s = "123456789";
  EXPECT_EQ(vc_crc32c(0, s, 9), 0xE3069283u);
  EXPECT_EQ(vc_crc32c_portable(0, s, 9), 0xE3069283u);
  EXPECT_EQ(vc_crc32c(0, nullptr, 0), 0u);
}

TEST(Crc32c, Rfc3720Vectors) {
  std::vector<uint8_t> zeros(32, 0x00), ones(32, 0xFF), inc(32), dec(32);
  for (int i = 0; i < 32; i++) {
    inc[i] = static_cast<uint8_t>(i);
    dec[i] = static_cast<uint8_t>(31 - i);
  }
  EXPECT_EQ(vc_crc32c(0, zeros.data(), 32), 0x8A9136AAu);
  EXPECT_EQ(vc_crc32c(0, ones.data(), 32), 0x62A8AB43u);
  EXPECT_EQ(vc_crc32c(0, inc.data(), 32), 0x46DD794Eu);
  EXPECT_EQ(vc_crc32c(0, dec.data(), 32), 0x113FDB5Cu);
}

TEST(Crc32c, IncrementalEqualsOneShot) {
  const std::string s = "The quick brown fox jumps over the lazy dog, then over the voxel grid.";
  const uint32_t whole = vc_crc32c(0, s.data(), s.size());
  for (size_t cut = 0; cut <= s.size(); cut++)
    EXPECT_EQ(vc_crc32c(vc_crc32c(0, s.data(), cut), s.data() + cut, s.size() - cut), whole) << cut;
}

TEST(Crc32c, AcceleratedMatchesPortableOnAllLengthsAndAlignments) {
  std::mt19937 rng(7);
  std::vector<uint8_t> buf(4096 + 16);
  for (auto& b : buf) b = static_cast<uint8_t>(rng());
  for (size_t off = 0; off < 8; off++)
    for (size_t len = 0; len < 300; len++)
      ASSERT_EQ(vc_crc32c(0, buf.data() + off, len), vc_crc32c_portable(0, buf.data() + off, len))
          << off << " " << len;
  EXPECT_EQ(vc_crc32c(0x12345678u, buf.data(), 4096), vc_crc32c_portable(0x12345678u, buf.data(), 4096));
  RecordProperty("impl", vc_crc32c_impl());
}

}  // namespace
