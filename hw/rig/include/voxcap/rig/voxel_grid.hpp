// The shared voxel grid (DESIGN.md): voxel (i,j,k) has centre min + (i+1/2, j+1/2, k+1/2) * size,
// linear index i + nx*(j + ny*k); a hull is a bitset in that order, bit 0 of byte 0 first (LSB-first).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

namespace vc::rig {

struct VoxelGrid {
  cv::Vec3d min_m{0, 0, 0};  // world position of the grid's min corner
  double voxel_m = 0;        // edge length of one (cubic) voxel
  int nx = 0, ny = 0, nz = 0;

  cv::Vec3d center(int i, int j, int k) const {
    return {min_m[0] + (i + 0.5) * voxel_m, min_m[1] + (j + 0.5) * voxel_m,
            min_m[2] + (k + 0.5) * voxel_m};
  }
  std::size_t index(int i, int j, int k) const {
    return static_cast<std::size_t>(i) +
           static_cast<std::size_t>(nx) * (static_cast<std::size_t>(j) +
                                           static_cast<std::size_t>(ny) * static_cast<std::size_t>(k));
  }
  std::size_t count() const {
    return static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz);
  }
  // Bytes of a hull bitset over this grid.
  std::size_t bitset_bytes() const { return (count() + 7) / 8; }
  cv::Vec3d max_m() const { return min_m + cv::Vec3d(nx, ny, nz) * voxel_m; }
  // The voxel containing p_world; false when p lies outside the grid (max faces are outside).
  bool locate(const cv::Vec3d& p_world, int* i, int* j, int* k) const;

  bool valid(std::string* why) const;

  // The smallest grid of voxel_m voxels whose box contains [lo_m, hi_m], centred on that box.
  static VoxelGrid covering(const cv::Vec3d& lo_m, const cv::Vec3d& hi_m, double voxel_m);
};

// Bit access in a hull bitset (LSB-first).
inline bool hull_bit(const std::uint8_t* bits, std::size_t idx) {
  return (bits[idx >> 3] >> (idx & 7)) & 1u;
}
inline void hull_set(std::uint8_t* bits, std::size_t idx) {
  bits[idx >> 3] = static_cast<std::uint8_t>(bits[idx >> 3] | (1u << (idx & 7)));
}

}  // namespace vc::rig
