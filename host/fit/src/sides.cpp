// Which limb of a pair a point lies on, through the hull (sides.hpp).
#include "voxcap/fit/sides.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace vc::fit {
namespace {

constexpr uint16_t kUnreached = std::numeric_limits<uint16_t>::max();
constexpr int kNear = 2;  // voxels: a root or a point this close to the hull is taken as on it

}  // namespace

PairSides::PairSides(const rig::VoxelGrid& grid) : voxel_m_(grid.voxel_m) {
  const size_t cells = std::min<size_t>(grid.count(), kMaxCells);
  dist_[0].assign(cells, kUnreached);
  dist_[1].assign(cells, kUnreached);
  queue_.assign(cells, 0);
}

bool PairSides::compute(const HullBits& hull, const Vec3& root_left, const Vec3& root_right,
                        const Vec3* points, int n, double pad_m) {
  valid_ = false;
  seeded_[0] = seeded_[1] = false;
  hull_ = &hull;
  Vec3 lo = glm::min(root_left, root_right), hi = glm::max(root_left, root_right);
  for (int q = 0; q < n; ++q) lo = glm::min(lo, points[q]), hi = glm::max(hi, points[q]);
  const double top = std::max(root_left.z, root_right.z) + voxel_m_;
  lo -= Vec3(pad_m);
  hi = Vec3(hi.x + pad_m, hi.y + pad_m, top);
  const rig::VoxelGrid& g = hull.grid();
  int i1, j1, k1;
  hull.cell(lo, &i0_, &j0_, &k0_);
  hull.cell(hi, &i1, &j1, &k1);
  i0_ = std::max(i0_, 0), j0_ = std::max(j0_, 0), k0_ = std::max(k0_, 0);
  i1 = std::min(i1, g.nx - 1), j1 = std::min(j1, g.ny - 1), k1 = std::min(k1, g.nz - 1);
  bx_ = i1 - i0_ + 1, by_ = j1 - j0_ + 1, bz_ = k1 - k0_ + 1;
  if (bx_ <= 0 || by_ <= 0 || bz_ <= 0) return false;
  const size_t cells = static_cast<size_t>(bx_) * static_cast<size_t>(by_) * static_cast<size_t>(bz_);
  if (cells > dist_[0].size()) return false;
  search(hull, 0, root_left);
  search(hull, 1, root_right);
  valid_ = true;
  return true;
}

void PairSides::search(const HullBits& hull, int which, const Vec3& root) {
  std::vector<uint16_t>& d = dist_[which];
  const size_t cells = static_cast<size_t>(bx_) * static_cast<size_t>(by_) * static_cast<size_t>(bz_);
  std::fill(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(cells), kUnreached);
  // The seed: the root's voxel, or the nearest occupied one within kNear voxels (Manhattan).
  int ri, rj, rk;
  hull.cell(root, &ri, &rj, &rk);
  int best = -1, bi = 0, bj = 0, bk = 0;
  for (int dk = -kNear; dk <= kNear; ++dk)
    for (int dj = -kNear; dj <= kNear; ++dj)
      for (int di = -kNear; di <= kNear; ++di) {
        const int i = ri + di, j = rj + dj, k = rk + dk;
        const int m = std::abs(di) + std::abs(dj) + std::abs(dk);
        if (!in_box(i, j, k) || !hull.at(i, j, k) || (best >= 0 && m >= best)) continue;
        best = m, bi = i, bj = j, bk = k;
      }
  seeded_[which] = best >= 0;
  if (best < 0) return;
  size_t head = 0, tail = 0;
  const int s = cell_index(bi, bj, bk);
  d[static_cast<size_t>(s)] = static_cast<uint16_t>(best);
  queue_[tail++] = s;
  const int sx = 1, sy = bx_, sz = bx_ * by_;
  while (head < tail) {
    const int c = queue_[head++];
    const int i = c % bx_, j = (c / bx_) % by_, k = c / sz;
    const uint16_t next = static_cast<uint16_t>(std::min<int>(d[static_cast<size_t>(c)] + 1, kUnreached - 1));
    auto visit = [&](int ii, int jj, int kk, int cc) {
      if (d[static_cast<size_t>(cc)] != kUnreached || !hull.at(i0_ + ii, j0_ + jj, k0_ + kk)) return;
      d[static_cast<size_t>(cc)] = next;
      queue_[tail++] = cc;
    };
    if (i > 0) visit(i - 1, j, k, c - sx);
    if (i + 1 < bx_) visit(i + 1, j, k, c + sx);
    if (j > 0) visit(i, j - 1, k, c - sy);
    if (j + 1 < by_) visit(i, j + 1, k, c + sy);
    if (k > 0) visit(i, j, k - 1, c - sz);
    if (k + 1 < bz_) visit(i, j, k + 1, c + sz);
  }
}

double PairSides::distance_m(int which, const Vec3& p) const {
  if (!valid_) return -1;
  int pi, pj, pk;
  hull_->cell(p, &pi, &pj, &pk);
  int best = -1;
  for (int dk = -kNear; dk <= kNear; ++dk)
    for (int dj = -kNear; dj <= kNear; ++dj)
      for (int di = -kNear; di <= kNear; ++di) {
        const int i = pi + di, j = pj + dj, k = pk + dk;
        if (!in_box(i, j, k)) continue;
        const uint16_t v = dist_[which][static_cast<size_t>(cell_index(i, j, k))];
        if (v == kUnreached) continue;
        const int m = v + std::abs(di) + std::abs(dj) + std::abs(dk);
        if (best < 0 || m < best) best = m;
      }
  return best < 0 ? -1 : best * voxel_m_;
}

int PairSides::side(const Vec3& p, double margin_m) const {
  if (!valid_ || !seeded_[0] || !seeded_[1]) return 0;
  const double dl = distance_m(0, p), dr = distance_m(1, p);
  if (dl < 0 && dr < 0) return 0;
  if (dl < 0) return 1;
  if (dr < 0) return -1;
  if (dl - dr >= margin_m) return 1;
  if (dr - dl >= margin_m) return -1;
  return 0;
}

}  // namespace vc::fit
