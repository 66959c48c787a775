#include "voxcap/triangulate/hull_map.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "voxcap/rle.h"

namespace vc::triangulate {

bool HullMap::set(const rig::VoxelGrid& grid, const uint8_t* rle, size_t len) {
  on_ = false;
  std::string why;
  if (!rle || len == 0 || !grid.valid(&why)) return false;
  vc_rle_info info{};
  if (vc_rle_inspect(rle, len, &info) < 0 || info.total != grid.count() || info.occupied == 0) return false;
  grid_ = grid;
  bits_.resize(grid.bitset_bytes());
  if (vc_rle_decode(rle, len, bits_.data(), grid.count()) < 0) return false;
  on_ = true;
  return true;
}

double HullMap::clearance(const cv::Vec3d& p, double cap_m) const {
  if (!on_) return -1;
  int ci = 0, cj = 0, ck = 0;
  if (!grid_.locate(p, &ci, &cj, &ck)) return -1;
  if (occupied(ci, cj, ck)) return 0;
  const double s = grid_.voxel_m;
  // Distance from p to voxel (i,j,k)'s cube.
  auto dist = [&](int i, int j, int k) {
    const cv::Vec3d c = grid_.center(i, j, k);
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double e = std::max(0.0, std::abs(p[a] - c[a]) - 0.5 * s);
      d2 += e * e;
    }
    return std::sqrt(d2);
  };
  // Shells of growing Chebyshev radius r around p's voxel: every voxel of shell r is at least
  // (r - 1) * s from p, so once the best distance found is within that, no later shell beats it.
  const int rmax = static_cast<int>(std::ceil(cap_m / s)) + 1;
  double best = 1e9;
  for (int r = 1; r <= rmax; ++r) {
    if (best <= (r - 1) * s) break;
    const int i0 = std::max(ci - r, 0), i1 = std::min(ci + r, grid_.nx - 1);
    const int j0 = std::max(cj - r, 0), j1 = std::min(cj + r, grid_.ny - 1);
    const int k0 = std::max(ck - r, 0), k1 = std::min(ck + r, grid_.nz - 1);
    for (int k = k0; k <= k1; ++k)
      for (int j = j0; j <= j1; ++j) {
        const bool face = k == ck - r || k == ck + r || j == cj - r || j == cj + r;
        if (face) {
          for (int i = i0; i <= i1; ++i)
            if (occupied(i, j, k)) best = std::min(best, dist(i, j, k));
        } else {  // an inner row: only its two ends lie on the shell
          if (ci - r >= 0 && occupied(ci - r, j, k)) best = std::min(best, dist(ci - r, j, k));
          if (ci + r < grid_.nx && occupied(ci + r, j, k)) best = std::min(best, dist(ci + r, j, k));
        }
      }
  }
  return best;
}

}  // namespace vc::triangulate
