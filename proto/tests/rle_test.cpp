// RLE properties against plain bitset operations: decode(encode(b)) == b, and(enc a, enc b) ==
// enc(a & b), popcount == bit count, encode == an independent bit-by-bit reference encoder; on random
// bitsets of many sizes and densities and on human-shaped hulls; plus every malformed-input rule.
// vc_rle_and_n against the chain of vc_rle_and and the bitset AND, errors and ENOSPC included.
#include <gtest/gtest.h>

#include <cerrno>
#include <iterator>
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

// Non-canonical or broken RLE byte strings, with the error every reader must give.
std::vector<Malformed> malformed_streams() {
  return {
      {"truncated varint", {0x05, 0x85}, -EBADMSG},
      {"overlong varint (redundant 0x00)", {0x85, 0x00, 0x05}, -EBADMSG},
      {"11-byte varint", {0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x01}, -EBADMSG},
      {"10th byte overflows 64 bits", {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x02}, -EBADMSG},
      {"zero run in the middle", {0x02, 0x00, 0x03}, -EBADMSG},
      {"lone zero run", {0x00}, -EBADMSG},
      {"trailing zero run", {0x02, 0x03, 0x00}, -EBADMSG},
      {"zero, zero", {0x00, 0x00, 0x03}, -EBADMSG},
  };
}

TEST(Rle, RejectsMalformedStreams) {
  const std::vector<Malformed> cases = malformed_streams();
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

// ---- vc_rle_and_n --------------------------------------------------------------------------------

using Stream = std::vector<uint8_t>;

struct AndResult {
  int rc = 0;
  size_t len = 0;
  Stream out;  // the first min(len, cap) bytes on success
  bool operator==(const AndResult&) const = default;
};

AndResult and_n(const std::vector<Stream>& in, size_t cap) {
  std::vector<const uint8_t*> ptrs;
  std::vector<size_t> lens;
  for (const auto& s : in) {
    ptrs.push_back(s.data());
    lens.push_back(s.size());
  }
  AndResult r;
  r.out.assign(cap, 0);
  r.rc = vc_rle_and_n(ptrs.data(), lens.data(), in.size(), r.out.data(), cap, &r.len);
  r.out.resize(r.rc == 0 ? r.len : 0);
  return r;
}

// What the host did before vc_rle_and_n: vc_rle_and over the running result, ample room in between,
// `cap` for the last step.
AndResult and_chain(const std::vector<Stream>& in, size_t cap) {
  AndResult r;
  Stream acc = in.at(0);
  if (in.size() == 1) {
    r.len = acc.size();
    r.rc = acc.size() <= cap ? 0 : -ENOSPC;
    if (r.rc == 0) r.out = acc;
    return r;
  }
  for (size_t i = 1; i < in.size(); i++) {
    const size_t room = i + 1 == in.size() ? cap : 4 * (acc.size() + in[i].size()) + 64;
    Stream next(room);
    r.rc = vc_rle_and(acc.data(), acc.size(), in[i].data(), in[i].size(), next.data(), room, &r.len);
    if (r.rc) return r;
    next.resize(r.len);
    acc = std::move(next);
  }
  r.out = acc;
  return r;
}

// n-way AND against the pairwise chain and against the bitset AND, plus the ENOSPC boundary.
void check_and_n(const std::vector<Bitset>& bits) {
  SCOPED_TRACE(testing::Message() << "n=" << bits.size() << " nbits=" << bits[0].nbits);
  std::vector<Stream> in;
  Bitset all = bits[0];
  for (const auto& b : bits) {
    in.push_back(encode(b));
    all = all & b;
  }
  const size_t roomy = vc_rle_max_encoded_size(all.nbits) + 16;
  const AndResult got = and_n(in, roomy);
  ASSERT_EQ(got.rc, 0);
  EXPECT_EQ(got.out, encode(all));
  EXPECT_EQ(got, and_chain(in, roomy));
  // Exactly the needed size fits; one byte less reports the needed size.
  EXPECT_EQ(and_n(in, got.len), got);
  if (got.len > 0) {
    const AndResult tight = and_n(in, got.len - 1);
    EXPECT_EQ(tight.rc, -ENOSPC);
    EXPECT_EQ(tight.len, got.len);
    EXPECT_EQ(tight, and_chain(in, got.len - 1));
  }
}

TEST(RleAndN, RandomBitsetsAgreeWithPairwiseChainAndBitsetAnd) {
  std::mt19937_64 rng(4321);
  const size_t sizes[] = {0, 1, 2, 7, 63, 64, 65, 129, 1000, 4099};
  const double densities[] = {0.0, 0.02, 0.5, 0.9, 0.98, 1.0};
  for (size_t nstreams = 1; nstreams <= 8; nstreams++)
    for (size_t nbits : sizes)
      for (int rep = 0; rep < 6; rep++) {
        std::vector<Bitset> bits;
        for (size_t k = 0; k < nstreams; k++)
          bits.push_back(t::random_bitset(nbits, densities[(rep + k) % std::size(densities)], rng));
        check_and_n(bits);
      }
}

TEST(RleAndN, RandomRunStructuresIncludingMultiByteVarints) {
  std::mt19937_64 rng(77);
  for (size_t nstreams = 1; nstreams <= 8; nstreams++)
    for (double mean : {1.5, 40.0, 300.0, 20000.0})
      for (size_t nbits : {size_t{1000}, size_t{200001}}) {
        std::vector<Bitset> bits;
        for (size_t k = 0; k < nstreams; k++)
          bits.push_back(t::random_runs(nbits, mean * (1.0 + 0.3 * k), rng));
        check_and_n(bits);
      }
}

TEST(RleAndN, StructuredInputs) {
  std::mt19937_64 rng(8);
  for (size_t nbits : {size_t{1}, size_t{9}, size_t{64}, size_t{1001}}) {
    Bitset empty(nbits), full(nbits), even(nbits), odd(nbits);
    for (size_t i = 0; i < nbits; i++) {
      full.set(i);
      (i % 2 ? odd : even).set(i);
    }
    for (size_t nstreams = 1; nstreams <= 8; nstreams++) {
      check_and_n(std::vector<Bitset>(nstreams, full));
      check_and_n(std::vector<Bitset>(nstreams, empty));
      check_and_n(std::vector<Bitset>(nstreams, even));  // worst case size, starting occupied
      check_and_n(std::vector<Bitset>(nstreams, odd));
      // One stream differs, at every position: it alone decides the result.
      for (size_t k = 0; k < nstreams; k++) {
        for (const Bitset* other : {&empty, &even, &odd}) {
          std::vector<Bitset> bits(nstreams, full);
          bits[k] = *other;
          check_and_n(bits);
        }
        std::vector<Bitset> bits(nstreams, t::random_bitset(nbits, 0.7, rng));
        bits[k] = full;
        check_and_n(bits);
      }
      // Disjoint even/odd: empty result after all-worst-case inputs.
      std::vector<Bitset> alt;
      for (size_t k = 0; k < nstreams; k++) alt.push_back(k % 2 ? odd : even);
      check_and_n(alt);
    }
  }
  // Nested intervals, shifted intervals, a run ending exactly at the last bit.
  for (size_t nstreams = 2; nstreams <= 8; nstreams++) {
    std::vector<Bitset> nested, shifted;
    for (size_t k = 0; k < nstreams; k++) {
      Bitset a(500), b(500);
      for (size_t i = 10 * k; i < 500 - 10 * k; i++) a.set(i);
      for (size_t i = 7 * k; i < 500; i++)
        if ((i / 50) % 2 == 0) b.set(i);
      nested.push_back(a);
      shifted.push_back(b);
    }
    check_and_n(nested);
    check_and_n(shifted);
  }
}

TEST(RleAndN, HumanShapedPartialHulls) {
  for (int n : {64, 128}) {
    const Bitset body = t::human_hull(n, 3);
    const Bitset x = t::extrude(body, n, 0), y = t::extrude(body, n, 1), z = t::extrude(body, n, 2);
    const std::vector<Bitset> views{x, y, z, x, y, z, x, y};
    for (size_t k = 1; k <= views.size(); k++) check_and_n({views.begin(), views.begin() + k});
    check_and_n({body, x, y, z});
  }
}

TEST(RleAndN, ManyStreamsUpToTheLimit) {
  std::mt19937_64 rng(64);
  std::vector<Bitset> bits;
  for (size_t k = 0; k < VC_RLE_AND_MAX_STREAMS; k++) bits.push_back(t::random_bitset(3000, 0.995, rng));
  check_and_n(bits);
  std::vector<Stream> in(VC_RLE_AND_MAX_STREAMS + 1, encode(bits[0]));
  EXPECT_EQ(and_n(in, 8000).rc, -EINVAL);
}

TEST(RleAndN, ArgumentErrors) {
  const Stream a{0x03, 0x03, 0x04};
  const uint8_t* ptrs[2] = {a.data(), a.data()};
  const size_t lens[2] = {a.size(), a.size()};
  Stream out(16);
  size_t len = 0;
  EXPECT_EQ(vc_rle_and_n(ptrs, lens, 2, out.data(), out.size(), &len), 0);
  EXPECT_EQ(len, a.size());
  EXPECT_EQ(vc_rle_and_n(ptrs, lens, 0, out.data(), out.size(), &len), -EINVAL);
  EXPECT_EQ(vc_rle_and_n(nullptr, lens, 2, out.data(), out.size(), &len), -EINVAL);
  EXPECT_EQ(vc_rle_and_n(ptrs, nullptr, 2, out.data(), out.size(), &len), -EINVAL);
  EXPECT_EQ(vc_rle_and_n(ptrs, lens, 2, out.data(), out.size(), nullptr), -EINVAL);
  EXPECT_EQ(vc_rle_and_n(ptrs, lens, 2, nullptr, out.size(), &len), -EINVAL);
  EXPECT_EQ(vc_rle_and_n(ptrs, lens, 1, nullptr, out.size(), &len), -EINVAL);
  const uint8_t* with_null[2] = {a.data(), nullptr};
  EXPECT_EQ(vc_rle_and_n(with_null, lens, 2, out.data(), out.size(), &len), -EINVAL);
  // NULL with length 0 is an empty stream (total 0): fine against another empty one, not against `a`.
  const uint8_t* empties[3] = {nullptr, nullptr, nullptr};
  const size_t zeros[3] = {0, 0, 0};
  len = 99;
  EXPECT_EQ(vc_rle_and_n(empties, zeros, 3, nullptr, 0, &len), 0);
  EXPECT_EQ(len, 0u);
  EXPECT_EQ(vc_rle_and_n(empties, zeros, 1, nullptr, 0, &len), 0);
  const size_t mixed[2] = {a.size(), 0};
  const uint8_t* a_and_empty[2] = {a.data(), nullptr};
  EXPECT_EQ(vc_rle_and_n(a_and_empty, mixed, 2, out.data(), out.size(), &len), -EINVAL);
  // No room at all: the needed size is still reported, nothing is written.
  EXPECT_EQ(vc_rle_and_n(ptrs, lens, 2, nullptr, 0, &len), -ENOSPC);
  EXPECT_EQ(len, a.size());
  EXPECT_EQ(vc_rle_and_n(ptrs, lens, 1, nullptr, 0, &len), -ENOSPC);
  EXPECT_EQ(len, a.size());
}

TEST(RleAndN, NeverWritesPastCap) {
  std::mt19937_64 rng(11);
  std::vector<Stream> in;
  for (int k = 0; k < 4; k++) in.push_back(encode(t::random_runs(100000, 300.0 + 50 * k, rng)));
  const AndResult full = and_n(in, 200000);
  ASSERT_EQ(full.rc, 0);
  std::vector<const uint8_t*> ptrs;
  std::vector<size_t> lens;
  for (const auto& s : in) {
    ptrs.push_back(s.data());
    lens.push_back(s.size());
  }
  for (size_t cap : {size_t{0}, size_t{1}, size_t{9}, size_t{10}, size_t{11}, full.len / 2, full.len - 1}) {
    Stream out(full.len + 32, 0xAB);
    size_t len = 0;
    EXPECT_EQ(vc_rle_and_n(ptrs.data(), lens.data(), in.size(), out.data(), cap, &len), -ENOSPC) << cap;
    EXPECT_EQ(len, full.len);
    for (size_t i = cap; i < out.size(); i++) ASSERT_EQ(out[i], 0xAB) << "cap " << cap << " byte " << i;
  }
}

TEST(RleAndN, DifferentTotalsAreInvalidAtAnyPosition) {
  std::mt19937_64 rng(3);
  for (size_t nstreams = 2; nstreams <= 5; nstreams++)
    for (size_t k = 0; k < nstreams; k++)
      for (long delta : {-1L, 1L, 100L}) {
        std::vector<Stream> in;
        for (size_t j = 0; j < nstreams; j++) {
          const size_t nbits = j == k ? static_cast<size_t>(static_cast<long>(1000) + delta) : 1000;
          in.push_back(encode(t::random_runs(nbits, 20.0, rng)));
        }
        SCOPED_TRACE(testing::Message() << "n=" << nstreams << " k=" << k << " delta=" << delta);
        EXPECT_EQ(and_n(in, 4096).rc, -EINVAL);
        EXPECT_EQ(and_chain(in, 4096).rc, -EINVAL);
      }
  // Totals that differ in a stream whose runs are all past the others' (one long empty run each).
  EXPECT_EQ(and_n({encode(Bitset(10)), encode(Bitset(10)), encode(Bitset(11))}, 64).rc, -EINVAL);
  EXPECT_EQ(and_n({encode(Bitset(11)), encode(Bitset(10))}, 64).rc, -EINVAL);
}

TEST(RleAndN, RejectsMalformedStreamsAtAnyPosition) {
  std::vector<Malformed> cases = malformed_streams();
  cases.push_back({"zero run after an occupied first run", {0x00, 0x02, 0x00, 0x03}, -EBADMSG});
  const Stream ok = encode(Bitset(5));
  Bitset full5(5);
  for (size_t i = 0; i < 5; i++) full5.set(i);
  const Stream ok_full = encode(full5);
  for (const auto& c : cases) {
    for (size_t nstreams = 1; nstreams <= 4; nstreams++)
      for (size_t k = 0; k < nstreams; k++)
        for (const Stream* other : {&ok, &ok_full}) {
          SCOPED_TRACE(testing::Message() << c.what << " n=" << nstreams << " k=" << k);
          std::vector<Stream> in(nstreams, *other);
          in[k] = c.rle;
          EXPECT_EQ(and_n(in, 64).rc, c.err);
          if (nstreams == 2) {
            EXPECT_EQ(and_chain(in, 64).rc, c.err);
          }
        }
  }
  // Runs whose total overflows 64 bits.
  const Stream huge{0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x01,
                    0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x01};
  EXPECT_EQ(and_n({huge}, 64).rc, -EBADMSG);
  EXPECT_EQ(and_n({huge, huge, huge}, 64).rc, -EBADMSG);
}

}  // namespace
