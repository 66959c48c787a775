#include "voxcap/rig/voxel_grid.hpp"

#include <cmath>
#include <sstream>

namespace vc::rig {

bool VoxelGrid::locate(const cv::Vec3d& p_world, int* i, int* j, int* k) const {
  const double fi = std::floor((p_world[0] - min_m[0]) / voxel_m);
  const double fj = std::floor((p_world[1] - min_m[1]) / voxel_m);
  const double fk = std::floor((p_world[2] - min_m[2]) / voxel_m);
  if (!(fi >= 0 && fj >= 0 && fk >= 0 && fi < nx && fj < ny && fk < nz)) return false;
  *i = static_cast<int>(fi);
  *j = static_cast<int>(fj);
  *k = static_cast<int>(fk);
  return true;
}

bool VoxelGrid::valid(std::string* why) const {
  std::ostringstream os;
  constexpr int kMaxDim = 4096;
  constexpr std::size_t kMaxCount = std::size_t{1} << 31;
  if (!(voxel_m > 0) || !std::isfinite(voxel_m)) {
    os << "voxel_m must be a positive number, got " << voxel_m;
  } else if (!std::isfinite(min_m[0]) || !std::isfinite(min_m[1]) || !std::isfinite(min_m[2])) {
    os << "min_m must be finite";
  } else if (nx < 1 || ny < 1 || nz < 1 || nx > kMaxDim || ny > kMaxDim || nz > kMaxDim) {
    os << "dimensions must be in [1, " << kMaxDim << "], got " << nx << "x" << ny << "x" << nz;
  } else if (count() > kMaxCount) {
    os << "too many voxels (" << count() << " > " << kMaxCount << ")";
  } else {
    return true;
  }
  if (why) *why = os.str();
  return false;
}

VoxelGrid VoxelGrid::covering(const cv::Vec3d& lo_m, const cv::Vec3d& hi_m, double voxel_m) {
  VoxelGrid g;
  g.voxel_m = voxel_m;
  int n[3];
  for (int a = 0; a < 3; ++a) {
    n[a] = std::max(1, static_cast<int>(std::ceil((hi_m[a] - lo_m[a]) / voxel_m - 1e-9)));
    g.min_m[a] = 0.5 * (lo_m[a] + hi_m[a]) - 0.5 * n[a] * voxel_m;
  }
  g.nx = n[0];
  g.ny = n[1];
  g.nz = n[2];
  return g;
}

}  // namespace vc::rig
