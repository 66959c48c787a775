// The merged hull as the fitter reads it: decoded once per frame from the frame's RLE into a reused
// bitset (no allocation after the first frame), then looked up by world point.
#pragma once

#include <cstdint>
#include <vector>

#include "voxcap/fit/model.hpp"
#include "voxcap/rig/voxel_grid.hpp"

namespace vc::fit {

class HullBits {
 public:
  explicit HullBits(const rig::VoxelGrid& grid);

  // Decodes a hull (voxcap/rle.h) over the grid; false (and an empty hull) when the stream is
  // malformed or does not cover exactly the grid.
  bool decode(const std::vector<uint8_t>& rle);
  // Copies a bitset of the grid's size (tests, offline tools).
  void assign(const std::vector<uint8_t>& bits);

  const rig::VoxelGrid& grid() const { return grid_; }
  const uint8_t* bits() const { return bits_.data(); }

  // Whether the voxel holding p_world is occupied (false outside the grid).
  bool at(const Vec3& p) const {
    const double fx = (p.x - min_x_) * inv_, fy = (p.y - min_y_) * inv_, fz = (p.z - min_z_) * inv_;
    if (!(fx >= 0 && fy >= 0 && fz >= 0 && fx < nx_ && fy < ny_ && fz < nz_)) return false;
    const size_t idx =
        static_cast<size_t>(fx) +
        static_cast<size_t>(grid_.nx) *
            (static_cast<size_t>(fy) + static_cast<size_t>(grid_.ny) * static_cast<size_t>(fz));
    return (bits_[idx >> 3] >> (idx & 7)) & 1u;
  }
  bool at(int i, int j, int k) const {
    if (i < 0 || j < 0 || k < 0 || i >= grid_.nx || j >= grid_.ny || k >= grid_.nz) return false;
    return rig::hull_bit(bits_.data(), grid_.index(i, j, k));
  }
  // The voxel holding p (may be outside the grid).
  void cell(const Vec3& p, int* i, int* j, int* k) const;
  Vec3 centre(int i, int j, int k) const {
    return {min_x_ + (i + 0.5) * grid_.voxel_m, min_y_ + (j + 0.5) * grid_.voxel_m,
            min_z_ + (k + 0.5) * grid_.voxel_m};
  }

 private:
  rig::VoxelGrid grid_;
  double min_x_, min_y_, min_z_, inv_, nx_, ny_, nz_;
  std::vector<uint8_t> bits_;
};

}  // namespace vc::fit
