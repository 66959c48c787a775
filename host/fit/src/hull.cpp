#include "voxcap/fit/hull.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "voxcap/rle.h"

namespace vc::fit {

HullBits::HullBits(const rig::VoxelGrid& grid)
    : grid_(grid),
      min_x_(grid.min_m[0]),
      min_y_(grid.min_m[1]),
      min_z_(grid.min_m[2]),
      inv_(grid.voxel_m > 0 ? 1.0 / grid.voxel_m : 0),
      nx_(grid.nx),
      ny_(grid.ny),
      nz_(grid.nz),
      bits_(grid.bitset_bytes(), 0) {
  std::string why;
  if (!grid.valid(&why)) throw std::invalid_argument("fit: bad voxel grid: " + why);
}

bool HullBits::decode(const std::vector<uint8_t>& rle) {
  if (vc_rle_decode(rle.data(), rle.size(), bits_.data(), grid_.count()) != 0) {
    std::fill(bits_.begin(), bits_.end(), 0);
    return false;
  }
  return true;
}

void HullBits::assign(const std::vector<uint8_t>& bits) {
  if (bits.size() != bits_.size()) throw std::invalid_argument("fit: hull bitset of the wrong size");
  std::copy(bits.begin(), bits.end(), bits_.begin());
}

void HullBits::cell(const Vec3& p, int* i, int* j, int* k) const {
  *i = static_cast<int>(std::floor((p.x - min_x_) * inv_));
  *j = static_cast<int>(std::floor((p.y - min_y_) * inv_));
  *k = static_cast<int>(std::floor((p.z - min_z_) * inv_));
}

}  // namespace vc::fit
