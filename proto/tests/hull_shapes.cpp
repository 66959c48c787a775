// Synthetic hull bitsets (see hull_shapes.hpp). Geometry in metres in a 2 m cube centred on x, y with
// the floor at z = 0; only the voxels in each capsule's bounding box are tested, so a 128^3 body takes
// milliseconds.
#include "hull_shapes.hpp"

#include <algorithm>
#include <cmath>

namespace vc::proto::testing {
namespace {

struct Vec3 {
  double x, y, z;
};
Vec3 operator+(Vec3 a, Vec3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
Vec3 operator-(Vec3 a, Vec3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
Vec3 operator*(double s, Vec3 a) {
  return {s * a.x, s * a.y, s * a.z};
}
double dot(Vec3 a, Vec3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

struct Capsule {
  Vec3 a, b;
  double r;
};

double dist_to_segment(Vec3 p, const Capsule& c) {
  Vec3 ab = c.b - c.a;
  double t = std::clamp(dot(p - c.a, ab) / std::max(dot(ab, ab), 1e-12), 0.0, 1.0);
  Vec3 d = p - (c.a + t * ab);
  return std::sqrt(dot(d, d));
}

// A limb of two segments from `root` with lengths l1, l2, swung by angles (radians) in the x-z plane
// and y-z plane: enough variety for run structure, no anatomy claims.
void add_limb(std::vector<Capsule>& caps, Vec3 root, double l1, double l2, double r, double swing_xz,
              double swing_yz, double bend) {
  Vec3 d1{std::sin(swing_xz), std::sin(swing_yz), -std::cos(swing_xz) * std::cos(swing_yz)};
  Vec3 mid = root + l1 * d1;
  Vec3 d2{std::sin(swing_xz + bend), std::sin(swing_yz), -std::cos(swing_xz + bend) * std::cos(swing_yz)};
  caps.push_back({root, mid, r});
  caps.push_back({mid, mid + l2 * d2, r * 0.85});
}

}  // namespace

size_t Bitset::count() const {
  size_t c = 0;
  for (size_t i = 0; i < nbits; i++) c += get(i);
  return c;
}

Bitset operator&(const Bitset& a, const Bitset& b) {
  Bitset r(a.nbits);
  for (size_t i = 0; i < r.bytes.size(); i++) r.bytes[i] = a.bytes[i] & b.bytes[i];
  return r;
}

Bitset random_bitset(size_t nbits, double density, std::mt19937_64& rng) {
  Bitset b(nbits);
  std::bernoulli_distribution coin(density);
  for (size_t i = 0; i < nbits; i++)
    if (coin(rng)) b.set(i);
  return b;
}

Bitset random_runs(size_t nbits, double mean_run, std::mt19937_64& rng) {
  Bitset b(nbits);
  std::geometric_distribution<size_t> len(1.0 / std::max(mean_run, 1.0));
  bool occupied = std::bernoulli_distribution(0.5)(rng);
  for (size_t pos = 0; pos < nbits; occupied = !occupied) {
    size_t n = std::min(nbits - pos, len(rng) + 1);
    if (occupied)
      for (size_t i = pos; i < pos + n; i++) b.set(i);
    pos += n;
  }
  return b;
}

Bitset human_hull(int n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double voxel_m = 2.0 / n;
  const Vec3 min_corner{-1.0, -1.0, 0.0};
  Vec3 hip{0.05 * u(rng), 0.05 * u(rng), 0.95};
  Vec3 neck = hip + Vec3{0.05 * u(rng), 0.05 * u(rng), 0.55};
  std::vector<Capsule> caps;
  caps.push_back({hip, neck, 0.16});                                         // torso
  caps.push_back({neck + Vec3{0, 0, 0.18}, neck + Vec3{0, 0, 0.22}, 0.11});  // head
  for (int side : {-1, 1}) {
    Vec3 shoulder = neck + Vec3{0.2 * side, 0, -0.05};
    // One draw per statement, last argument first: the order gcc gave the old call's arguments (it is
    // unspecified there, and clang drew them the other way), so release figures stay as recorded.
    const double arm_c = side * 0.6 * (u(rng) + 1) / 2;
    const double arm_b = 0.4 * u(rng);
    const double arm_a = side * (0.3 + 1.2 * (u(rng) + 1) / 2);
    add_limb(caps, shoulder, 0.3, 0.28, 0.05, arm_a, arm_b, arm_c);
    Vec3 hip_joint = hip + Vec3{0.1 * side, 0, -0.05};
    const double leg_c = -side * 0.4 * (u(rng) + 1) / 2;
    const double leg_b = 0.3 * u(rng);
    const double leg_a = side * 0.25 * (u(rng) + 1) / 2;
    add_limb(caps, hip_joint, 0.43, 0.42, 0.075, leg_a, leg_b, leg_c);
  }
  Bitset b(static_cast<size_t>(n) * n * n);
  for (const Capsule& c : caps) {
    auto lo = [&](double a, double bb, double m) {
      return std::max(0, static_cast<int>(std::floor((std::min(a, bb) - c.r - m) / voxel_m)));
    };
    auto hi = [&](double a, double bb, double m) {
      return std::min(n - 1, static_cast<int>(std::ceil((std::max(a, bb) + c.r - m) / voxel_m)));
    };
    for (int k = lo(c.a.z, c.b.z, min_corner.z); k <= hi(c.a.z, c.b.z, min_corner.z); k++)
      for (int j = lo(c.a.y, c.b.y, min_corner.y); j <= hi(c.a.y, c.b.y, min_corner.y); j++)
        for (int i = lo(c.a.x, c.b.x, min_corner.x); i <= hi(c.a.x, c.b.x, min_corner.x); i++) {
          Vec3 p = min_corner + Vec3{(i + 0.5) * voxel_m, (j + 0.5) * voxel_m, (k + 0.5) * voxel_m};
          if (dist_to_segment(p, c) <= c.r)
            b.set(static_cast<size_t>(i) + n * (j + static_cast<size_t>(n) * k));
        }
  }
  return b;
}

Bitset extrude(const Bitset& body, int n, int axis) {
  Bitset out(body.nbits);
  auto idx = [n](int i, int j, int k) {
    return static_cast<size_t>(i) + n * (j + static_cast<size_t>(n) * k);
  };
  for (int a = 0; a < n; a++)
    for (int c = 0; c < n; c++) {
      auto at = [&](int t) { return axis == 0 ? idx(t, a, c) : axis == 1 ? idx(a, t, c) : idx(a, c, t); };
      int first = -1, last = -1;
      for (int t = 0; t < n; t++)
        if (body.get(at(t))) {
          if (first < 0) first = t;
          last = t;
        }
      for (int t = first; first >= 0 && t <= last; t++) out.set(at(t));
    }
  return out;
}

Bitset extrude_horizontal(const Bitset& body, int n, double angle_rad) {
  Bitset out(body.nbits);
  const double c = std::cos(angle_rad), s = std::sin(angle_rad);
  const size_t plane = static_cast<size_t>(n) * n;
  // Per voxel of a slice: its line (across coordinate, offset to be >= 0) and its place along it.
  std::vector<int> line(plane);
  std::vector<double> along(plane);
  for (int j = 0; j < n; j++)
    for (int i = 0; i < n; i++) {
      line[i + static_cast<size_t>(n) * j] = static_cast<int>(std::lround(-i * s + j * c)) + 2 * n;
      along[i + static_cast<size_t>(n) * j] = i * c + j * s;
    }
  std::vector<double> lo(4 * static_cast<size_t>(n) + 1), hi(lo.size());
  for (int k = 0; k < n; k++) {
    const size_t base = plane * k;
    std::fill(lo.begin(), lo.end(), 1e30);
    std::fill(hi.begin(), hi.end(), -1e30);
    for (size_t v = 0; v < plane; v++)
      if (body.get(base + v)) {
        lo[line[v]] = std::min(lo[line[v]], along[v]);
        hi[line[v]] = std::max(hi[line[v]], along[v]);
      }
    for (size_t v = 0; v < plane; v++)
      if (along[v] >= lo[line[v]] && along[v] <= hi[line[v]]) out.set(base + v);
  }
  return out;
}

std::vector<uint8_t> reference_rle(const Bitset& b) {
  std::vector<uint64_t> runs;
  if (b.nbits > 0) {
    bool state = false;
    uint64_t run = 0;
    for (size_t i = 0; i < b.nbits; i++) {
      if (b.get(i) != state) {
        runs.push_back(run);
        state = !state;
        run = 0;
      }
      run++;
    }
    runs.push_back(run);
  }
  std::vector<uint8_t> out;
  for (uint64_t v : runs) {
    do {
      uint8_t byte = v & 0x7F;
      v >>= 7;
      out.push_back(v ? static_cast<uint8_t>(byte | 0x80) : byte);
    } while (v);
  }
  return out;
}

}  // namespace vc::proto::testing
