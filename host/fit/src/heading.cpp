// The body's heading cue from the feet on the hull (heading.hpp; README "The heading from the body").
#include "voxcap/fit/heading.hpp"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

namespace vc::fit {
namespace {

constexpr double kBelowAnkleTopM = 0.02;     // m: the foot's voxels start this far below the ankle ...
constexpr double kBelowAnkleBottomM = 0.16;  // ... and end this far below it
constexpr double kFootReachM = 0.24;         // m: level distance from the ankle searched
constexpr double kMinReachM = 0.03;          // m: mean offset per foot the cue needs ...
constexpr double kMaxReachM = 0.14;          // ... and at most (further: the feature is not at its ankle)
constexpr double kFeetAgreeCos = 0.5;        // the two feet's offsets within 60 degrees of each other
constexpr int kMinFootVoxels = 3;
// m: an ankle higher above the floor (z = 0) than this is in the air (a kick, a jump): its foot points
// wherever the leg swings it, not where the body stands facing (a standing ankle is 8-16 cm up, a
// walking step's swinging one up to ~30 cm; cmu/02_06's kicks put it at 0.66-0.81 m).
constexpr double kMaxAnkleHeightM = 0.35;
constexpr double kAgainstCos = -0.5;  // torso forward and feet forward more than 120 degrees apart

}  // namespace

FeetCue feet_forward(const HullBits& hull, const FeatureSet& f, const std::array<bool, 5>& ok) {
  FeetCue cue;
  const rig::VoxelGrid& g = hull.grid();
  std::array<Vec3, 2> off{Vec3(0.0), Vec3(0.0)};
  std::array<bool, 2> have{false, false};
  for (int side = 0; side < 2; ++side) {
    const size_t fi = 3 + static_cast<size_t>(side), oi = 4 - static_cast<size_t>(side);
    if (!ok[fi] || f[fi].z > kMaxAnkleHeightM) continue;
    const Vec3 a = f[fi];
    const bool other = ok[oi];
    const Vec3 o = f[oi];
    int i0, j0, k0, i1, j1, k1;
    hull.cell(a - Vec3(kFootReachM, kFootReachM, kBelowAnkleBottomM), &i0, &j0, &k0);
    hull.cell(a + Vec3(kFootReachM, kFootReachM, -kBelowAnkleTopM), &i1, &j1, &k1);
    i0 = std::max(i0, 0), j0 = std::max(j0, 0), k0 = std::max(k0, 0);
    i1 = std::min(i1, g.nx - 1), j1 = std::min(j1, g.ny - 1), k1 = std::min(k1, g.nz - 1);
    Vec3 sum(0.0);
    int n = 0;
    for (int k = k0; k <= k1; ++k)
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) {
          if (!hull.at(i, j, k)) continue;
          const Vec3 p = hull.centre(i, j, k);
          const Vec3 d(p.x - a.x, p.y - a.y, 0);
          const double dd = glm::dot(d, d);
          if (dd > kFootReachM * kFootReachM) continue;
          if (other) {
            const Vec3 e(p.x - o.x, p.y - o.y, 0);
            if (glm::dot(e, e) < dd) continue;  // the other foot's
          }
          sum += d;
          ++n;
        }
    if (n < kMinFootVoxels) continue;
    off[static_cast<size_t>(side)] = sum / static_cast<double>(n);
    have[static_cast<size_t>(side)] = true;
  }
  const Vec3 total = off[0] + off[1];
  cue.feet = static_cast<int>(have[0]) + static_cast<int>(have[1]);
  if (cue.feet < 2) return cue;
  const double len = glm::length(total);
  cue.reach_m = len / 2;
  for (const Vec3& o : off) {
    const double l = glm::length(o);
    if (l < kMinReachM || l > kMaxReachM) return cue;
  }
  if (glm::dot(glm::normalize(off[0]), glm::normalize(off[1])) < kFeetAgreeCos) return cue;
  cue.forward = total / len;
  cue.valid = true;
  return cue;
}

bool faces_away(const Mat3& R, const FeetCue& cue) {
  if (!cue.valid) return false;
  const Vec3 y(R[1].x, R[1].y, 0);
  const double ly = glm::length(y);
  return ly >= 1e-6 && glm::dot(y / ly, cue.forward) < kAgainstCos;
}

bool HeadingVote::update(const Mat3& R, const FeetCue& cue) {
  // No verdict (cue invalid, torso lying flat): the count stays as it is, for at most kMaxGapFrames
  // frames: a verdict older than that says nothing about the torso now.
  if (!cue.valid || glm::length(Vec3(R[1].x, R[1].y, 0)) < 1e-6) {
    if (++gap_ > kMaxGapFrames) against_ = 0;
    return false;
  }
  gap_ = 0;
  if (faces_away(R, cue)) {
    if (++against_ >= kFlipFrames) {
      against_ = 0;
      return true;
    }
  } else {
    against_ = 0;
  }
  return false;
}

Mat3 turned_round(const Mat3& R) {
  return Mat3(-R[0], -R[1], R[2]);
}

}  // namespace vc::fit
