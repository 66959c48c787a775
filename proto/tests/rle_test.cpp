// RLE properties against plain bitset operations: decode(encode(b)) == b, and(enc a, enc b) ==
// enc(a & b), popcount == bit count, encode == an independent bit-by-bit reference encoder; on random
// bitsets of many sizes and densities and on human-shaped hulls; plus every malformed-input rule.
#include <gtest/gtest.h>

#include <cerrno>
#include <random>
#include <vector>

#include "hull_shapes.hpp"
#include "voxcap/rle.h"

namespace {

using vc::proto::testing::Bitset;
namespace t = vc::proto::testing;

std::vector<uint8_t> encode(const Bitset& b) {
  std::vector<uint8_t> out(vc_rle_max_encoded_size(b.nbits));
  size_t len = 0;
  EXPECT_EQ(vc_rle_encode(b.bytes.data(), b.nbits, out.data(), out.size(), &len), 0);
  out.resize(len);
  return out;
}

Bitset decode(const std::vector<uint8_t>& rle, size_t nbits) {
  Bitset b(nbits);
  EXPECT_EQ(vc_rle_decode(rle.data(), rle.size(), b.bytes.data(), nbits), 0);
  return b;
}

std::vector<uint8_t> rle_and(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, size_t nbits) {
  std::vector<uint8_t> out(vc_rle_max_encoded_size(nbits));
  size_t len = 0;
  EXPECT_EQ(vc_rle_and(a.data(), a.size(), b.data(), b.size(), out.data(), out.size(), &len), 0);
  out.resize(len);
  return out;
}

// Every property on one pair of bitsets of equal size.
void check_properties(const Bitset& a, const Bitset& b) {
  SCOPED_TRACE(testing::Message() << "nbits=" << a.nbits << " count(a)=" << a.count());
  const auto ea = encode(a), eb = encode(b);
  EXPECT_EQ(ea, t::reference_rle(a));
  EXPECT_EQ(decode(ea, a.nbits), a);
  EXPECT_EQ(decode(eb, b.nbits), b);
  uint64_t occupied = 0, total = 0;
  ASSERT_EQ(vc_rle_popcount(ea.data(), ea.size(), &occupied, &total), 0);
  EXPECT_EQ(occupied, a.count());
  EXPECT_EQ(total, a.nbits);
  EXPECT_EQ(rle_and(ea, eb, a.nbits), encode(a & b));
  EXPECT_EQ(rle_and(eb, ea, a.nbits), encode(a & b));
  EXPECT_EQ(rle_and(ea, ea, a.nbits), ea);  // idempotent
}

TEST(Rle, RandomBitsetsOfManySizesAndDensities) {
  std::mt19937_64 rng(1234);
  const size_t sizes[] = {0,  1,   2,   7,   8,   9,   15,  16,   17,   63,       64,
                          65, 127, 128, 129, 255, 256, 257, 1000, 4099, 32768 + 5};
  const double densities[] = {0.0, 0.001, 0.02, 0.1, 0.5, 0.9, 0.98, 1.0};
  for (size_t n : sizes)
    for (double da : densities)
      for (double db : {0.0, 0.3, 0.97, 1.0})
        check_properties(t::random_bitset(n, da, rng), t::random_bitset(n, db, rng));
}

TEST(Rle, RandomRunStructuresIncludingMultiByteVarints) {
  std::mt19937_64 rng(99);
  for (double mean : {1.5, 5.0, 100.0, 300.0, 20000.0})
    for (size_t n : {size_t{1000}, size_t{65536 + 3}, size_t{200001}})
      check_properties(t::random_runs(n, mean, rng), t::random_runs(n, mean * 0.7, rng));
}

TEST(Rle, HumanShapedPartialHulls64And128) {
  for (int n : {64, 128}) {
    for (uint64_t seed : {1u, 2u}) {
      const Bitset body = t::human_hull(n, seed);
      ASSERT_GT(body.count(), 1000u);
      const Bitset from_x = t::extrude(body, n, 0), from_y = t::extrude(body, n, 1);
      check_properties(from_x, from_y);
      check_properties(body, from_x);
      // The AND of two partial hulls contains the body, as the host relies on.
      const Bitset merged = decode(rle_and(encode(from_x), encode(from_y), body.nbits), body.nbits);
      EXPECT_EQ(merged & body, body);
    }
  }
}

TEST(Rle, PaddingBitsPastNbitsAreIgnoredAndWrittenAsZero) {
  Bitset b(13);
  b.set(0);
  b.set(12);
  std::vector<uint8_t> dirty = b.bytes;
  dirty[1] |= 0xE0;  // bits 13..15: padding
  std::vector<uint8_t> out(16);
  size_t len = 0;
  ASSERT_EQ(vc_rle_encode(dirty.data(), 13, out.data(), out.size(), &len), 0);
  out.resize(len);
  EXPECT_EQ(out, encode(b));
  std::vector<uint8_t> back{0xFF, 0xFF};
  ASSERT_EQ(vc_rle_decode(out.data(), out.size(), back.data(), 13), 0);
  EXPECT_EQ(back, b.bytes);
}

TEST(Rle, CanonicalExamplesFromTheSpec) {
  // 10 voxels, occupied 3..5 (LSB first: byte0 = 0b00111000): runs 3 empty, 3 occupied, 4 empty.
  Bitset b(10);
  for (size_t i : {3, 4, 5}) b.set(i);
  EXPECT_EQ(encode(b), (std::vector<uint8_t>{0x03, 0x03, 0x04}));
  // Starting occupied: a leading empty run of 0.
  Bitset c(4);
  c.set(0);
  EXPECT_EQ(encode(c), (std::vector<uint8_t>{0x00, 0x01, 0x03}));
  // 300 empty voxels: one run, a two-byte varint (300 = 0b10'0101100 -> 0xAC 0x02).
  EXPECT_EQ(encode(Bitset(300)), (std::vector<uint8_t>{0xAC, 0x02}));
  EXPECT_TRUE(encode(Bitset(0)).empty());
}

TEST(Rle, WorstCaseSizeIsReachedByAlternatingBits) {
  for (size_t n : {1, 2, 9, 64, 1001}) {
    Bitset b(n);
    for (size_t i = 0; i < n; i += 2) b.set(i);
    EXPECT_EQ(encode(b).size(), vc_rle_max_encoded_size(n)) << n;
  }
  EXPECT_EQ(vc_rle_max_encoded_size(0), 0u);
  EXPECT_EQ(vc_rle_max_encoded_size(SIZE_MAX), SIZE_MAX);
}

TEST(Rle, EncodeReportsNeededSizeWhenOutputTooSmall) {
  std::mt19937_64 rng(5);
  const Bitset b = t::random_bitset(5000, 0.3, rng);
  const auto full = encode(b);
  std::vector<uint8_t> out(full.size());
  size_t len = 0;
  vc_rle_info info{};
  EXPECT_EQ(vc_rle_encode_info(b.bytes.data(), b.nbits, out.data(), full.size() - 1, &len, &info), -ENOSPC);
  EXPECT_EQ(len, full.size());
  EXPECT_EQ(info.occupied, b.count());
  EXPECT_EQ(vc_rle_encode(b.bytes.data(), b.nbits, nullptr, 0, &len), -ENOSPC);
  EXPECT_EQ(len, full.size());
  EXPECT_EQ(vc_rle_encode(b.bytes.data(), b.nbits, out.data(), full.size(), &len), 0);
  EXPECT_EQ(out, full);
  // AND reports the needed size the same way.
  size_t and_len = 0;
  EXPECT_EQ(vc_rle_and(full.data(), full.size(), full.data(), full.size(), out.data(), 3, &and_len), -ENOSPC);
  EXPECT_EQ(and_len, full.size());
}

TEST(Rle, InspectCountsRuns) {
  vc_rle_info info{};
  const std::vector<uint8_t> rle{0x00, 0x05, 0x02, 0x81, 0x01};  // 0 empty, 5 occ, 2 empty, 129 occ
  ASSERT_EQ(vc_rle_inspect(rle.data(), rle.size(), &info), 0);
  EXPECT_EQ(info.runs, 4u);
  EXPECT_EQ(info.total, 136u);
  EXPECT_EQ(info.occupied, 134u);
}

struct Malformed {
  const char* what;
  std::vector<uint8_t> rle;
  int err;
};

TEST(Rle, RejectsMalformedStreams) {
  const Malformed cases[] = {
      {"truncated varint", {0x05, 0x85}, -EBADMSG},
      {"overlong varint (redundant 0x00)", {0x85, 0x00, 0x05}, -EBADMSG},
      {"11-byte varint", {0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x01}, -EBADMSG},
      {"10th byte overflows 64 bits", {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x02}, -EBADMSG},
      {"zero run in the middle", {0x02, 0x00, 0x03}, -EBADMSG},
      {"lone zero run", {0x00}, -EBADMSG},
      {"trailing zero run", {0x02, 0x03, 0x00}, -EBADMSG},
      {"zero, zero", {0x00, 0x00, 0x03}, -EBADMSG},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.what);
    uint64_t occ = 0, total = 0;
    EXPECT_EQ(vc_rle_popcount(c.rle.data(), c.rle.size(), &occ, &total), c.err);
    std::vector<uint8_t> bits(8);
    EXPECT_EQ(vc_rle_decode(c.rle.data(), c.rle.size(), bits.data(), 5), c.err);
    const auto ok = encode(Bitset(5));
    std::vector<uint8_t> out(32);
    size_t len = 0;
    EXPECT_EQ(vc_rle_and(c.rle.data(), c.rle.size(), ok.data(), ok.size(), out.data(), out.size(), &len),
              c.err);
    EXPECT_EQ(vc_rle_and(ok.data(), ok.size(), c.rle.data(), c.rle.size(), out.data(), out.size(), &len),
              c.err);
  }
}

TEST(Rle, TotalsThatOverflow64BitsAreMalformed) {
  // Two runs of 2^63: a valid varint each, but the total does not fit in 64 bits.
  const std::vector<uint8_t> rle{0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x01,
                                 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x01};
  EXPECT_EQ(vc_rle_popcount(rle.data(), rle.size(), nullptr, nullptr), -EBADMSG);
  std::vector<uint8_t> out(64);
  size_t len = 0;
  EXPECT_EQ(vc_rle_and(rle.data(), rle.size(), rle.data(), rle.size(), out.data(), out.size(), &len),
            -EBADMSG);
}

TEST(Rle, RunsNotSummingToNbitsAreInvalid) {
  const std::vector<uint8_t> rle{0x03, 0x03, 0x04};  // 10 bits
  std::vector<uint8_t> bits(4);
  EXPECT_EQ(vc_rle_decode(rle.data(), rle.size(), bits.data(), 9), -EINVAL);
  EXPECT_EQ(vc_rle_decode(rle.data(), rle.size(), bits.data(), 11), -EINVAL);
  EXPECT_EQ(vc_rle_decode(rle.data(), rle.size(), bits.data(), 10), 0);
  const std::vector<uint8_t> shorter{0x03, 0x03, 0x03};  // 9 bits
  std::vector<uint8_t> out(16);
  size_t len = 0;
  EXPECT_EQ(vc_rle_and(rle.data(), rle.size(), shorter.data(), shorter.size(), out.data(), out.size(), &len),
            -EINVAL);
  EXPECT_EQ(vc_rle_and(nullptr, 0, rle.data(), rle.size(), out.data(), out.size(), &len), -EINVAL);
}

TEST(Rle, DecodeNeverWritesPastTheBitset) {
  // Runs summing past nbits must be rejected before touching bytes beyond ceil(nbits/8).
  const std::vector<uint8_t> rle{0x00, 0xC8, 0x01};  // 200 occupied bits
  std::vector<uint8_t> guard(64, 0xAB);
  EXPECT_EQ(vc_rle_decode(rle.data(), rle.size(), guard.data(), 12), -EINVAL);
  for (size_t i = 2; i < guard.size(); i++) ASSERT_EQ(guard[i], 0xAB) << i;
}

TEST(Rle, NullArguments) {
  size_t len = 0;
  uint8_t byte = 0;
  EXPECT_EQ(vc_rle_encode(nullptr, 8, &byte, 1, &len), -EINVAL);
  EXPECT_EQ(vc_rle_encode(&byte, 8, &byte, 1, nullptr), -EINVAL);
  EXPECT_EQ(vc_rle_encode(nullptr, 0, nullptr, 0, &len), 0);
  EXPECT_EQ(len, 0u);
  EXPECT_EQ(vc_rle_decode(nullptr, 1, &byte, 8), -EINVAL);
  EXPECT_EQ(vc_rle_decode(nullptr, 0, nullptr, 0), 0);
  EXPECT_EQ(vc_rle_inspect(&byte, 1, nullptr), -EINVAL);
}

}  // namespace
