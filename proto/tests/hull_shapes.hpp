// Synthetic hull bitsets for the RLE tests and benchmarks: random bitsets of any density, random run
// structures, and human-shaped hulls (a union of capsules: torso, head, limbs) in an n^3 grid, plus the
// "partial hull" a two-camera node would see (the body extruded along one axis, as a silhouette cone
// from far away would be). Bit order as in rle.h: voxel i + n*(j + n*k), LSB first.
#pragma once

#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

namespace vc::proto::testing {

struct Bitset {
  size_t nbits = 0;
  std::vector<uint8_t> bytes;  // ceil(nbits/8), padding bits 0

  explicit Bitset(size_t n = 0) : nbits(n), bytes((n + 7) / 8, 0) {}
  bool get(size_t i) const { return (bytes[i >> 3] >> (i & 7)) & 1u; }
  void set(size_t i) { bytes[i >> 3] = static_cast<uint8_t>(bytes[i >> 3] | (1u << (i & 7))); }
  size_t count() const;
  bool operator==(const Bitset&) const = default;
};

Bitset operator&(const Bitset& a, const Bitset& b);

// Each bit set independently with probability `density`.
Bitset random_bitset(size_t nbits, double density, std::mt19937_64& rng);

// Alternating runs with lengths drawn from a geometric distribution of mean `mean_run` (>= 1):
// exercises multi-byte varints when mean_run is large.
Bitset random_runs(size_t nbits, double mean_run, std::mt19937_64& rng);

// A standing person (capsules for torso, head, upper/lower arms and legs) in an n^3 grid spanning
// 2 m, posed with random joint angles drawn from `seed`.
Bitset human_hull(int n, uint64_t seed);

// The body extruded along grid axis `axis` (0 = x, 1 = y, 2 = z): every line of voxels parallel to
// that axis is filled between its first and last occupied voxel. A superset of `body`.
Bitset extrude(const Bitset& body, int n, int axis);

// The body extruded along the horizontal direction (cos a, sin a, 0), as `extrude` does along an axis:
// in every z slice, each line of that direction (voxel centres binned by their rounded distance across
// it) is filled between its first and last occupied voxel. What a node looking from angle a leaves of
// the body; several angles give the partial hulls of a ring of nodes.
Bitset extrude_horizontal(const Bitset& body, int n, double angle_rad);

// Reference (bit by bit) RLE encoder, independent of the library: the oracle of the property tests.
std::vector<uint8_t> reference_rle(const Bitset& b);

}  // namespace vc::proto::testing
