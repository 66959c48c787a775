// Which limb of a pair a point lies on, from the hull alone (host/fit/README.md, "The feet's names
// from the hull"): a cue for a foot's left/right that does not come from the names. Below the hips a
// leg is hull voxels connected to its own hip joint; a point on the right leg is reached from the
// right hip through the hull along that leg, and from the left hip only across the pelvis, a hip
// width further. So the distance through the hull's occupied voxels from each root (the two hip
// joints) tells the side where it differs by clearly more than noise; where the limbs touch (legs
// together, a crossover step) both distances are about the same and nothing is said.
//
// The distance is the 6-connected path length (a breadth-first search over occupied voxels, in a box
// around the roots and the points asked about, cut above the roots so that no path leaves through the
// trunk and an arm): per axis additive, so the step across between the hips is never folded into the
// drop down the leg as a diagonal path would fold it.
#pragma once

#include <cstdint>
#include <vector>

#include "voxcap/fit/hull.hpp"
#include "voxcap/fit/model.hpp"

namespace vc::fit {

class PairSides {
 public:
  // Buffers for the largest box searched (kMaxCells voxels), allocated once.
  explicit PairSides(const rig::VoxelGrid& grid);

  static constexpr int kMaxCells = 1 << 19;

  // The distances through `hull` from each root (index 0 the left limb's, 1 the right one's) to every
  // occupied voxel of the box that holds both roots and `points` (n of them), grown by pad_m, with
  // nothing above the roots' higher one by more than a voxel. A root not on the hull is moved to an
  // occupied voxel within 2 voxels (a fitted hip is not exactly at the hull's). False (nothing known)
  // when the box is too large or neither root is on the hull.
  bool compute(const HullBits& hull, const Vec3& root_left, const Vec3& root_right, const Vec3* points, int n,
               double pad_m);

  // The distance (metres) through the hull from root `which` (0 left, 1 right) to p: p's voxel, or the
  // nearest reached voxel within 2 voxels of it (a feature lies on its limb's surface or a voxel off
  // it), plus that offset. Negative when not reached (or compute() failed).
  double distance_m(int which, const Vec3& p) const;

  // The side p lies on: -1 the left limb, +1 the right one, when it is at least margin_m nearer that
  // root through the hull than the other (or reached from that root only); 0 when neither, and always
  // when a root was not on the hull.
  int side(const Vec3& p, double margin_m) const;

 private:
  int cell_index(int i, int j, int k) const { return (i - i0_) + bx_ * ((j - j0_) + by_ * (k - k0_)); }
  bool in_box(int i, int j, int k) const {
    return i >= i0_ && j >= j0_ && k >= k0_ && i < i0_ + bx_ && j < j0_ + by_ && k < k0_ + bz_;
  }
  void search(const HullBits& hull, int which, const Vec3& root);

  double voxel_m_;
  bool valid_ = false;
  bool seeded_[2] = {false, false};  // each root found on the hull
  int i0_ = 0, j0_ = 0, k0_ = 0, bx_ = 0, by_ = 0, bz_ = 0;
  std::vector<uint16_t> dist_[2];  // steps from each root; kUnreached where not reached
  std::vector<int> queue_;
  const HullBits* hull_ = nullptr;
};

}  // namespace vc::fit
