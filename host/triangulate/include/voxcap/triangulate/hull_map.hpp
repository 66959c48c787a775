// The merged hull of one frame as a lookup for the triangulation (host/triangulate/README.md, "On
// the body"): a 3D feature must lie on the body, and the visual hull contains the body, so a point
// well outside the merged hull is not the part it names. The hull's RLE is decoded once per frame
// into a bitset kept between frames (no allocation after the first frame); a point's clearance is
// then a few bit lookups: none for a point inside, a growing shell of voxels around it for one
// outside, up to a cap.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "voxcap/rig/voxel_grid.hpp"

namespace vc::triangulate {

class HullMap {
 public:
  // The hull of a frame over `grid` (proto RLE, voxcap/rle.h). Returns false and leaves the map
  // off (clearance() < 0) for an empty or malformed RLE, one whose total is not the grid's voxel
  // count, or an empty hull: the rule then says nothing about the frame.
  bool set(const rig::VoxelGrid& grid, const uint8_t* rle, size_t len);
  void clear() { on_ = false; }
  bool on() const { return on_; }
  const rig::VoxelGrid& grid() const { return grid_; }

  // How far p lies outside the hull, metres: the distance from p to the nearest occupied voxel (its
  // cube), 0 when p lies in an occupied voxel. A point farther than `cap_m` gets a value above cap_m
  // (the search stops there). -1 when the map is off or p lies outside the grid (the hull says
  // nothing there: a body part outside the volume is not carved).
  double clearance(const cv::Vec3d& p, double cap_m) const;

 private:
  bool occupied(int i, int j, int k) const { return rig::hull_bit(bits_.data(), grid_.index(i, j, k)); }
  rig::VoxelGrid grid_;
  std::vector<uint8_t> bits_;
  bool on_ = false;
};

}  // namespace vc::triangulate
