// The renderer. Per camera, once: the normalized image coordinates (a, b) of every pixel centre
// (exact inverse of the OpenCV model), so that its line of sight is centre + t * R^T (a, b, 1) with
// t the depth along the optical axis; the depth of the room along it; the floor point (x, y) it
// sees, if any; the static room image (2x2 supersampled); and per 16x16 tile the bounds of its
// (a, b) and of its floor points.
//
// Per frame: the ~20 body primitives (capsules) from the pose. Each becomes, for this camera, a
// family of lines through the camera centre parametrized by (a, b) and, for the floor shadow, a
// family of lines from the light through the floor points (x, y). For such a family, "the line
// meets this quadric" is the sign of its discriminant, a quadratic form of the direction and so
// a conic in the two parameters: for a spheroid holding the capsule (a cheap, bounded first
// reject), for the capsule's infinite cylinder, and for its two cap spheres. Where the line enters
// the cylinder tells which surface it enters the capsule by. All of that is evaluated in float,
// four pixels at a time, with margins that make every verdict certain or "undecided"; only the
// undecided pixels (on an outline, within float error) get the exact ray-capsule test in double,
// so the images equal exact ray casting. A primitive's tiles come from the exact bounding box of
// its projection (the projections of its two end ellipsoids). Per tile, the body is drawn front to
// back (nearest hit per pixel); a floor pixel the body leaves visible is in shadow when the segment
// from the light to its floor point meets the body.
//
// Noise and flicker are applied in the same pass that lays down the room: every output value is
// finish(clean value, index) = clamp(gain * clean + noise[key + index]), with the gain in Q7 and the
// noise from a seeded Gaussian table read at a per-image offset. Body and shadow pixels overwrite
// their values through the same function, so the result equals noise applied after a clean render.
//
// Limits: hard shadows on the floor only (not on walls or the body), no self-shadowing, no
// inter-reflection, no motion blur, no anti-aliasing of body edges (the truth mask is binary).
#include "voxcap/sim/scene.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include <opencv2/core/hal/intrin.hpp>

#include "room.hpp"

namespace vc::sim {
namespace {

constexpr int kTile = 16;
constexpr std::size_t kNoiseSlack = std::size_t{1} << 20;

struct Rect2 {
  double x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL;
  void add(double x, double y) {
    x0 = std::min(x0, x);
    x1 = std::max(x1, x);
    y0 = std::min(y0, y);
    y1 = std::max(y1, y);
  }
  bool empty() const { return x0 > x1; }
  bool overlaps(const Rect2& o) const { return !(o.x0 > x1 || o.x1 < x0 || o.y0 > y1 || o.y1 < y0); }
  static Rect2 everything() { return {-HUGE_VAL, HUGE_VAL, -HUGE_VAL, HUGE_VAL}; }
  // Grows to hold the perspective image (x/z, y/z) of the ellipsoid p0 + B y, |y| <= 1; to
  // everything when it reaches z <= 0. The bounds are where a plane x = u z (y = v z) touches it:
  // (p0x - u p0z)^2 = |B^T (1, 0, -u)|^2, a quadratic in u.
  void add_projection(const cv::Vec3d& p0, const cv::Matx33d& B) {
    const cv::Vec3d r[3] = {
        {B(0, 0), B(0, 1), B(0, 2)}, {B(1, 0), B(1, 1), B(1, 2)}, {B(2, 0), B(2, 1), B(2, 2)}};
    const double a = p0[2] * p0[2] - r[2].dot(r[2]);
    if (!(p0[2] > 0 && a > 1e-12)) {
      *this = everything();
      return;
    }
    double lo[2], hi[2];
    for (int i = 0; i < 2; ++i) {
      const double b = p0[i] * p0[2] - r[i].dot(r[2]), c = p0[i] * p0[i] - r[i].dot(r[i]);
      const double root = std::sqrt(std::max(0.0, b * b - a * c));
      lo[i] = (b - root) / a;
      hi[i] = (b + root) / a;
    }
    add(lo[0], lo[1]);
    add(hi[0], hi[1]);
  }
};

struct TileInfo {
  Rect2 rays;   // normalized image coordinates (x/z, y/z) of its pixels
  Rect2 floor;  // world x, y of its floor pixels (empty when none)
};

struct CameraCache {
  std::once_flag once;
  cv::Vec3d center;
  cv::Matx33d R;
  cv::Matx33d Rt;
  // Per pixel (row-major), structure of arrays so the per-row loops vectorize:
  std::vector<float> a, b;    // normalized image coordinates: the line of sight is R^T (a, b, 1)
  std::vector<float> room_z;  // the room's depth along that line (t at the wall/floor/ceiling)
  std::vector<float> fx, fy;  // the floor point it sees (world x, y); NaN where it sees no floor
  cv::Mat room;               // CV_8UC3, RGB, clean
  int tiles_x = 0, tiles_y = 0;
  std::vector<TileInfo> tiles;
};

// A quadratic form in (u, v, 1), evaluated in float: certainly negative below -tol, certainly
// positive above +tol (float evaluation errs by a few ulps of the sum of the terms' magnitudes;
// the margin is 100x that, for |u|, |v| up to the bound it was made for).
struct Conic {
  float q[6] = {}, tol = 0;  // q0 u^2 + q1 uv + q2 v^2 + q3 u + q4 v + q5

  Conic() = default;
  Conic(const cv::Matx33d& S, double uv_bound) {
    const double c[6] = {S(0, 0), 2 * S(0, 1), S(1, 1), 2 * S(0, 2), 2 * S(1, 2), S(2, 2)};
    const double m = 1 + uv_bound;
    double mag = 0;
    for (int i = 0; i < 6; ++i) {
      q[i] = static_cast<float>(c[i]);
      mag += std::abs(c[i]);
    }
    tol = std::isfinite(m) ? static_cast<float>(1e-5 * mag * m * m) : HUGE_VALF;
  }
  float operator()(float u, float v) const {
    return q[0] * u * u + q[1] * u * v + q[2] * v * v + q[3] * u + q[4] * v + q[5];
  }
};

// One primitive as a family of lines o + t * M (u, v, 1) in its scaled-local frame, for the
// renderer's loops: (u, v) are a camera pixel's normalized coordinates (lines of sight, t = depth)
// or a floor point's world x, y (lines from the light, t = 1 at the floor). The capsule is the
// unit cylinder x^2 + y^2 <= 1 for |z| <= core, capped by the unit spheres at z = +-core.
struct LineFamily {
  int k = 0;                // the primitive's index
  cv::Matx33d M;            // (u, v, 1) -> local direction
  cv::Vec3d o;              // the common origin, local
  Rect2 rect;               // (u, v) outside it => miss
  double t_min = 0;         // no hit has a smaller t (lines of sight: the nearest depth of its box)
  float t_max = HUGE_VALF;  // hits beyond are not wanted (lines from the light: the floor)
  // Float copies for classify(). Each discriminant of "line meets quadric" is a quadratic form of
  // the direction d = M w, w = (u, v, 1), hence a conic in (u, v): cyl for the infinite cylinder,
  // cap[0] / cap[1] for the spheres at z = +core / -core. Their B coefficients are linear:
  // beta . w (cylinder: o0 d0 + o1 d1) and cap_beta[c] . w ((o - centre) . d).
  Conic bound, cyl, cap[2];  // bound: an ellipsoid holding the capsule (a cheap first reject)
  float m[9] = {};           // M, row-major
  float beta[3] = {}, cap_beta[2][3] = {};
  float o2 = 0, core = 0;
};

// S = b b^T - c N for the line o + t d, d = M w, against a quadric with A = d^T N' d, B = b . w,
// C = c: the discriminant B^2 - A C as a form in w.
cv::Matx33d discriminant_form(const cv::Vec3d& b, double c, const cv::Matx33d& N) {
  return b * b.t() - c * N;
}

// G maps (u, v, 1) to the world direction of the line; origin is its world start.
LineFamily make_family(int k, const Primitive& p, const cv::Matx33d& G, const cv::Vec3d& origin,
                       const Rect2& rect) {
  LineFamily f;
  f.k = k;
  f.M = p.to_local * G;
  f.o = p.to_local_point(origin);
  f.rect = rect;
  const double bound = std::max({std::abs(rect.x0), std::abs(rect.x1), std::abs(rect.y0), std::abs(rect.y1)});
  const cv::Vec3d m0(f.M(0, 0), f.M(0, 1), f.M(0, 2)), m1(f.M(1, 0), f.M(1, 1), f.M(1, 2));
  // Cylinder: A = dx^2 + dy^2, B = ox dx + oy dy, C = ox^2 + oy^2 - 1.
  const cv::Vec3d beta = f.o[0] * m0 + f.o[1] * m1;
  f.cyl = Conic(discriminant_form(beta, f.o[0] * f.o[0] + f.o[1] * f.o[1] - 1.0, m0 * m0.t() + m1 * m1.t()),
                bound);
  // The spheroid (x^2 + y^2) / (core + 1) + z^2 / (core + 1)^2 <= 1 holds the capsule (on the cap at
  // height core + s, s in [0, 1], the worst case is s = 1); unlike the cylinder it is bounded.
  // With D its diagonal: A = d^T D d, B = o^T D d, C = o^T D o - 1.
  {
    const double e = p.core + 1;
    const cv::Matx33d D(1 / e, 0, 0, 0, 1 / e, 0, 0, 0, 1 / (e * e));
    f.bound = Conic(discriminant_form(f.M.t() * (D * f.o), f.o.dot(D * f.o) - 1.0, f.M.t() * D * f.M), bound);
  }
  // Spheres: A = d . d, B = (o - c) . d, C = |o - c|^2 - 1.
  const cv::Matx33d MtM = f.M.t() * f.M;
  for (int c = 0; c < 2; ++c) {
    const cv::Vec3d oc = f.o - cv::Vec3d(0, 0, c == 0 ? p.core : -p.core);
    const cv::Vec3d cb = f.M.t() * oc;
    f.cap[c] = Conic(discriminant_form(cb, oc.dot(oc) - 1.0, MtM), bound);
    for (int i = 0; i < 3; ++i) f.cap_beta[c][i] = static_cast<float>(cb[i]);
  }
  for (int i = 0; i < 9; ++i) f.m[i] = static_cast<float>(f.M.val[i]);
  for (int i = 0; i < 3; ++i) f.beta[i] = static_cast<float>(beta[i]);
  f.o2 = static_cast<float>(f.o[2]);
  f.core = static_cast<float>(p.core);
  return f;
}

constexpr int kTilePixels = kTile * kTile;

// What classify() says of a tile's lines: per row, a bit per pixel.
struct TileClass {
  std::uint32_t rows = 0;           // rows with any bit set
  std::uint16_t hit[kTile] = {};    // certainly enters the capsule, at t (float), not beyond t_max
  std::uint16_t exact[kTile] = {};  // undecided in float: Primitive::intersect_local decides
  float t[kTilePixels];
};
static_assert(kTile <= 16, "a row's bits are 16 wide");

// Classifies the lines (u, v) of a tile (rows x n, row r at U0 + r * stride) for a family; the
// lines in neither mask certainly miss the capsule (or meet it beyond t_max). Undecided in float
// are lines near an outline, nearly along the axis, or from inside the cylinder. Where the line
// enters the cylinder tells by which surface it enters the capsule: the side on the core, else
// the cap on that side (see Primitive::intersect_local). Four lines at a time where the CPU has
// 128-bit SIMD; the scalar tail computes the same.
void classify(const LineFamily& f, const float* U0, const float* V0, std::size_t stride, int n, int rows,
              TileClass* out) {
  out->rows = 0;
#if CV_SIMD128
  using cv::v_float32x4;
  using cv::v_setall_f32;
  struct VConic {
    v_float32x4 q[6], tol, ntol;
    explicit VConic(const Conic& c) : tol(v_setall_f32(c.tol)), ntol(v_setall_f32(-c.tol)) {
      for (int j = 0; j < 6; ++j) q[j] = v_setall_f32(c.q[j]);
    }
    v_float32x4 operator()(const v_float32x4& u, const v_float32x4& v) const {
      return q[0] * u * u + q[1] * u * v + q[2] * v * v + q[3] * u + q[4] * v + q[5];
    }
  };
  const VConic bound(f.bound), cyl(f.cyl), top(f.cap[0]), bottom(f.cap[1]);
  v_float32x4 m[9], beta[3], cb[2][3];
  for (int j = 0; j < 9; ++j) m[j] = v_setall_f32(f.m[j]);
  for (int j = 0; j < 3; ++j) {
    beta[j] = v_setall_f32(f.beta[j]);
    cb[0][j] = v_setall_f32(f.cap_beta[0][j]);
    cb[1][j] = v_setall_f32(f.cap_beta[1][j]);
  }
  const v_float32x4 zero = v_setall_f32(0.f), core = v_setall_f32(f.core), o2 = v_setall_f32(f.o2);
  const v_float32x4 tmax = v_setall_f32(f.t_max), axis = v_setall_f32(1e-3f);
#endif
  for (int r = 0; r < rows; ++r) {
    const float* U = U0 + static_cast<std::size_t>(r) * stride;
    const float* V = V0 + static_cast<std::size_t>(r) * stride;
    float* t = out->t + r * kTile;
    unsigned hits = 0, exacts = 0;
    int i = 0;
#if CV_SIMD128
    for (; i + 4 <= n; i += 4) {
      const v_float32x4 u = cv::v_load(U + i), v = cv::v_load(V + i);
      const v_float32x4 inside = bound(u, v) >= bound.ntol;  // false for NaN
      if (!cv::v_check_any(inside)) continue;
      const v_float32x4 disc = cyl(u, v);
      const int maybe = cv::v_signmask(inside & (disc >= cyl.ntol));
      if (maybe == 0) continue;
      const v_float32x4 d0 = m[0] * u + m[1] * v + m[2], d1 = m[3] * u + m[4] * v + m[5],
                        d2 = m[6] * u + m[7] * v + m[8];
      const v_float32x4 A = d0 * d0 + d1 * d1, AA = A + d2 * d2;
      const v_float32x4 tc =
          (zero - (beta[0] * u + beta[1] * v + beta[2]) - cv::v_sqrt(cv::v_max(disc, zero))) / A;
      const v_float32x4 z = o2 + tc * d2;
      // Decidable: the cylinder is certainly met, not nearly along the axis, ahead of the origin.
      const v_float32x4 sure = (disc > cyl.tol) & (A > axis * AA) & (tc > zero);
      const v_float32x4 above = z > core, on_cap = above | (z < zero - core);
      v_float32x4 tt = tc, decided = sure, cap_miss = zero;
      if (cv::v_check_any(on_cap)) {
        // The cap on the side where the line enters the cylinder.
        const v_float32x4 sdisc = cv::v_select(above, top(u, v), bottom(u, v));
        const v_float32x4 stol = cv::v_select(above, top.tol, bottom.tol);
        const v_float32x4 sb = cv::v_select(above, cb[0][0] * u + cb[0][1] * v + cb[0][2],
                                            cb[1][0] * u + cb[1][1] * v + cb[1][2]);
        tt = cv::v_select(on_cap, (zero - sb - cv::v_sqrt(cv::v_max(sdisc, zero))) / AA, tc);
        cap_miss = on_cap & (sdisc < zero - stol);
        decided = sure & ~(on_cap & (sdisc <= stol) & (sdisc >= zero - stol));
      }
      cv::v_store(t + i, tt);
      hits |= static_cast<unsigned>(cv::v_signmask(decided & ~cap_miss & (tt <= tmax))) << i;
      exacts |= static_cast<unsigned>(maybe & ~cv::v_signmask(decided)) << i;
    }
#endif
    for (; i < n; ++i) {
      const float u = U[i], v = V[i];
      const float disc = f.cyl(u, v);
      if (!(f.bound(u, v) >= -f.bound.tol && disc >= -f.cyl.tol)) continue;
      const float d0 = f.m[0] * u + f.m[1] * v + f.m[2], d1 = f.m[3] * u + f.m[4] * v + f.m[5];
      const float d2 = f.m[6] * u + f.m[7] * v + f.m[8];
      const float A = d0 * d0 + d1 * d1, AA = A + d2 * d2;
      const unsigned bit = 1u << i;
      exacts |= bit;  // until decided
      if (!(disc > f.cyl.tol && A > 1e-3f * AA)) continue;
      const float tc =
          (0.f - (f.beta[0] * u + f.beta[1] * v + f.beta[2]) - std::sqrt(std::max(disc, 0.f))) / A;
      const float z = f.o2 + tc * d2;
      if (!(tc > 0.f)) continue;
      float tt = tc;
      if (z > f.core || z < 0.f - f.core) {
        const int c = z > f.core ? 0 : 1;
        const float sdisc = f.cap[c](u, v);
        if (sdisc <= f.cap[c].tol && sdisc >= 0.f - f.cap[c].tol) continue;
        exacts &= ~bit;
        if (sdisc < 0.f) continue;
        tt = (0.f - (f.cap_beta[c][0] * u + f.cap_beta[c][1] * v + f.cap_beta[c][2]) - std::sqrt(sdisc)) / AA;
      }
      exacts &= ~bit;
      t[i] = tt;
      if (tt <= f.t_max) hits |= bit;
    }
    out->hit[r] = static_cast<std::uint16_t>(hits);
    out->exact[r] = static_cast<std::uint16_t>(exacts);
    if (hits | exacts) out->rows |= 1u << r;
  }
}

// A body pixel's colour from its primitive and where its line of sight (a, b) enters it (t):
// ambient, Lambert towards the point light, and a little light from above, in float. Everything
// is done in the primitive's frame: the entry in scaled-local coordinates is q = o + t M (a, b, 1);
// the unscaled local offset from the centre is r * q; the normal is (q0 / r0, q1 / r1,
// (q2 - clamp(q2, -core, core)) / r2) (as Primitive::normal, before the rotation R).
struct PartShading {
  float o[3] = {}, m[9] = {}, core = 0;
  float r[3] = {}, inv_r[3] = {};
  float to_light[3] = {};  // R^T (light - centre)
  float up[3] = {};        // R^T (0, 0, 1)
  float albedo[3] = {};

  PartShading() = default;
  PartShading(const Primitive& p, const LineFamily& sight, const cv::Vec3d& light, const cv::Vec3d& colour) {
    const cv::Vec3d tl = p.R.t() * (light - p.center);
    for (int i = 0; i < 3; ++i) {
      o[i] = static_cast<float>(sight.o[i]);
      r[i] = static_cast<float>(p.radii[i]);
      inv_r[i] = static_cast<float>(1.0 / p.radii[i]);
      to_light[i] = static_cast<float>(tl[i]);
      up[i] = static_cast<float>(p.R(2, i));
      albedo[i] = static_cast<float>(colour[i]);
    }
    std::copy(std::begin(sight.m), std::end(sight.m), m);
    core = sight.core;
  }
  cv::Vec3b operator()(float a, float b, float t) const {
    float q[3], n[3], l[3];
    for (int i = 0; i < 3; ++i) q[i] = o[i] + t * (m[3 * i] * a + m[3 * i + 1] * b + m[3 * i + 2]);
    n[0] = q[0] * inv_r[0];
    n[1] = q[1] * inv_r[1];
    n[2] = (q[2] - std::clamp(q[2], -core, core)) * inv_r[2];
    for (int i = 0; i < 3; ++i) l[i] = to_light[i] - r[i] * q[i];
    const float nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    const float ll = l[0] * l[0] + l[1] * l[1] + l[2] * l[2];
    const float nl = n[0] * l[0] + n[1] * l[1] + n[2] * l[2];
    const float nz = n[0] * up[0] + n[1] * up[1] + n[2] * up[2];
    float light = 0.40f;
    if (nn > 0) light += (0.62f * std::max(0.f, nl) / std::sqrt(ll) + 0.08f * nz) / std::sqrt(nn);
    return {cv::saturate_cast<std::uint8_t>(albedo[0] * light),
            cv::saturate_cast<std::uint8_t>(albedo[1] * light),
            cv::saturate_cast<std::uint8_t>(albedo[2] * light)};
  }
};

std::uint8_t to_u8(double v) {
  return cv::saturate_cast<std::uint8_t>(v);
}

// The last step of every output value: clamp(gain * v + noise). Identity when there is neither.
// The flicker gain is applied in Q7 (steps of 1/128) so that 16-bit lanes hold the product.
struct Finish {
  const std::uint8_t* pos = nullptr;  // noise table slices at the image's offset, or null
  const std::uint8_t* neg = nullptr;
  int gain_q7 = 128;  // in [64, 192): flicker is below 0.5

  std::uint8_t operator()(std::uint8_t v, std::size_t j) const {
    int g = gain_q7 == 128 ? v : std::min(255, (v * gain_q7 + 64) >> 7);
    if (pos) g = std::clamp(g + pos[j] - neg[j], 0, 255);  // one of pos, neg is 0
    return static_cast<std::uint8_t>(g);
  }
  // out = finish(in), in place when in is out (out is created if needed; a caller's ROI is done
  // row by row, with the values a continuous image would get).
  void lay(const cv::Mat& in, cv::Mat& out) const {
    out.create(in.rows, in.cols, CV_8UC3);
    const std::size_t row = static_cast<std::size_t>(in.cols) * 3;
    if (out.isContinuous() && in.isContinuous()) {
      apply(in.ptr<std::uint8_t>(), out.ptr<std::uint8_t>(), row * static_cast<std::size_t>(in.rows), 0);
      return;
    }
    for (int y = 0; y < in.rows; ++y) {
      apply(in.ptr<std::uint8_t>(y), out.ptr<std::uint8_t>(y), row, row * static_cast<std::size_t>(y));
    }
  }
  // out[j] = finish(in[j], j0 + j) for j < n, 16 values at a time where the CPU has 128-bit SIMD.
  void apply(const std::uint8_t* in, std::uint8_t* out, std::size_t n, std::size_t j0) const {
    if (gain_q7 == 128 && !pos) {
      if (in != out) std::memcpy(out, in, n);
      return;
    }
    std::size_t j = 0;
#if CV_SIMD128
    const std::uint8_t* np = pos ? pos + j0 : nullptr;
    const std::uint8_t* nn = neg ? neg + j0 : nullptr;
    const cv::v_uint16x8 g = cv::v_setall_u16(static_cast<std::uint16_t>(gain_q7)),
                         half = cv::v_setall_u16(64);
    auto gained = [&](const cv::v_uint8x16& v) {
      cv::v_uint16x8 lo, hi;
      cv::v_expand(v, lo, hi);  // v * gain_q7 + 64 < 2^16: no wrap
      return cv::v_pack(cv::v_shr<7>(cv::v_mul_wrap(lo, g) + half),
                        cv::v_shr<7>(cv::v_mul_wrap(hi, g) + half));
    };
    // On 8-bit lanes + and - saturate.
    if (gain_q7 == 128) {
      for (; j + 16 <= n; j += 16)
        cv::v_store(out + j, (cv::v_load(in + j) + cv::v_load(np + j)) - cv::v_load(nn + j));
    } else if (np) {
      for (; j + 16 <= n; j += 16)
        cv::v_store(out + j, (gained(cv::v_load(in + j)) + cv::v_load(np + j)) - cv::v_load(nn + j));
    } else {
      for (; j + 16 <= n; j += 16) cv::v_store(out + j, gained(cv::v_load(in + j)));
    }
#endif
    for (; j < n; ++j) out[j] = (*this)(in[j], j0 + j);
  }
};

}  // namespace

// render()'s working storage.
struct Scratch {
  std::vector<Primitive> prims;
  std::vector<LineFamily> sight, light;
  std::vector<const LineFamily*> body_cand, shadow_cand;
};

struct Scene::Impl {
  SceneOptions opt;
  rig::Calibration calib;
  Motion motion;
  Appearance look;
  detail::Room room;
  cv::Mat noise_pos, noise_neg;  // 1 x L, CV_8U: max(n, 0) and max(-n, 0) of round(sigma * N(0,1))
  std::vector<std::unique_ptr<CameraCache>> cams;

  Impl(const SceneOptions& o, rig::Calibration c, Motion m)
      : opt(o), calib(std::move(c)), motion(std::move(m)), look(appearance_preset(o.appearance)) {}

  CameraCache& cache(int cam) const;
  void build_cache(int cam, CameraCache& cc) const;
  // The room, the body and its shadow, each value passed through finish (noise and flicker).
  void render(int frame, int cam, const Finish& finish, cv::Mat& out, cv::Mat* sil, cv::Mat* shadow) const;
  Finish finish(std::uint64_t key, double gain) const;
};

namespace {

std::uint64_t image_key(std::uint64_t seed, std::uint64_t kind, std::uint64_t cam, std::uint64_t index) {
  return detail::mix64(seed ^ detail::mix64(kind * 0x9E3779B97F4A7C15ull ^
                                            detail::mix64(cam * 0xD1B54A32D192ED03ull ^ index)));
}

}  // namespace

bool SceneOptions::valid(std::string* why) const {
  std::ostringstream os;
  std::string w;
  if (!motion.valid(&w)) {
    os << "motion: " << w;
  } else if (!body.valid(&w)) {
    os << "body: " << w;
  } else if (!calibration && !rig.valid(&w)) {
    os << "rig: " << w;
  } else if (calibration && !calibration->valid(&w)) {
    os << "calibration: " << w;
  } else if (!(noise_sigma >= 0 && noise_sigma <= 50)) {
    os << "noise_sigma must be in [0, 50], got " << noise_sigma;
  } else if (!(flicker >= 0 && flicker < 0.5)) {
    os << "flicker must be in [0, 0.5), got " << flicker;
  } else if (!(shadow_factor > 0 && shadow_factor < 1)) {
    os << "shadow_factor must be in (0, 1), got " << shadow_factor;
  } else if (!(room_half_m > 1 && room_half_m < 100) || !(room_height_m > 2 && room_height_m < 100)) {
    os << "room_half_m must be in (1, 100) and room_height_m in (2, 100)";
  } else if (!(light_m[2] > 0.5 && light_m[2] < room_height_m)) {
    os << "the light must hang between 0.5 m and the ceiling";
  } else if (detail::room_style(room) < 0) {
    std::string known;
    for (const RoomPreset& r : room_presets()) known += (known.empty() ? "" : ", ") + r.name;
    os << "unknown room '" << room << "' (known: " << known << ")";
  } else {
    try {
      (void)appearance_preset(appearance);
    } catch (const std::invalid_argument& e) {
      os << e.what();
      if (why) *why = os.str();
      return false;
    }
    return true;
  }
  if (why) *why = os.str();
  return false;
}

Scene::Scene(const SceneOptions& options) {
  std::string why;
  if (!options.valid(&why)) throw std::invalid_argument("scene: " + why);
  rig::Calibration calib = options.calibration ? *options.calibration : default_rig(options.rig);
  impl_ = std::make_unique<Impl>(options, std::move(calib), Motion::create(options.motion, options.body));
  Impl& m = *impl_;
  // The room holds every camera (with half a metre to spare).
  double half = options.room_half_m;
  double height = options.room_height_m;
  for (const auto& cam : m.calib.cameras) {
    const cv::Vec3d c = cam.center_world();
    half = std::max({half, std::abs(c[0]) + 0.5, std::abs(c[1]) + 0.5});
    height = std::max(height, c[2] + 0.5);
    if (c[2] <= 0.05) throw std::invalid_argument("scene: camera " + cam.name + " is below the floor");
  }
  m.room.half_m = half;
  m.room.height_m = height;
  m.room.light_m = options.light_m;
  m.room.style = detail::room_style(options.room);
  // Noise table: Box-Muller from a counter-based generator, so it is the same everywhere.
  std::size_t max_values = 0;
  for (const auto& cam : m.calib.cameras) {
    max_values =
        std::max(max_values, static_cast<std::size_t>(cam.width) * static_cast<std::size_t>(cam.height) * 3);
  }
  const std::size_t n = max_values + kNoiseSlack;
  m.noise_pos = cv::Mat::zeros(1, static_cast<int>(n), CV_8U);
  m.noise_neg = cv::Mat::zeros(1, static_cast<int>(n), CV_8U);
  if (options.noise_sigma > 0) {
    auto* pos = m.noise_pos.ptr<std::uint8_t>();
    auto* neg = m.noise_neg.ptr<std::uint8_t>();
    for (std::size_t i = 0; i < n; i += 2) {
      const std::uint64_t h1 = detail::mix64(options.seed ^ (0xA5A5A5A5ull + i));
      const std::uint64_t h2 = detail::mix64(h1 ^ 0x5DEECE66Dull);
      const double u1 = (static_cast<double>(h1 >> 11) + 0.5) * (1.0 / 9007199254740992.0);
      const double u2 = static_cast<double>(h2 >> 11) * (1.0 / 9007199254740992.0);
      const double r = std::sqrt(-2.0 * std::log(u1));
      const double g[2] = {r * std::cos(2 * M_PI * u2), r * std::sin(2 * M_PI * u2)};
      for (std::size_t k = 0; k < 2 && i + k < n; ++k) {
        const long v = std::lround(std::clamp(options.noise_sigma * g[k], -255.0, 255.0));
        pos[i + k] = static_cast<std::uint8_t>(std::max(0L, v));
        neg[i + k] = static_cast<std::uint8_t>(std::max(0L, -v));
      }
    }
  }
  m.cams.resize(m.calib.cameras.size());
  for (auto& c : m.cams) c = std::make_unique<CameraCache>();
}

Scene::~Scene() = default;

const SceneOptions& Scene::options() const {
  return impl_->opt;
}
const rig::Calibration& Scene::calibration() const {
  return impl_->calib;
}
const Motion& Scene::motion() const {
  return impl_->motion;
}
int Scene::camera_count() const {
  return static_cast<int>(impl_->calib.cameras.size());
}
double Scene::fps() const {
  return impl_->motion.fps();
}

CameraCache& Scene::Impl::cache(int cam) const {
  if (cam < 0 || cam >= static_cast<int>(cams.size()))
    throw std::out_of_range("scene: no camera " + std::to_string(cam));
  CameraCache& cc = *cams[static_cast<std::size_t>(cam)];
  std::call_once(cc.once, [&] { build_cache(cam, cc); });
  return cc;
}

void Scene::Impl::build_cache(int cam_index, CameraCache& cc) const {
  const rig::Camera& cam = calib.cameras[static_cast<std::size_t>(cam_index)];
  const int w = cam.width, h = cam.height;
  cc.center = cam.center_world();
  cc.R = cam.R_cam_from_world;
  cc.Rt = cam.R_cam_from_world.t();
  const cv::Matx33d& Rt = cc.Rt;
  const std::size_t npix = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  cc.a.resize(npix);
  cc.b.resize(npix);
  cc.room_z.resize(npix);
  cc.fx.resize(npix);
  cc.fy.resize(npix);
  cc.room.create(h, w, CV_8UC3);
  cc.tiles_x = (w + kTile - 1) / kTile;
  cc.tiles_y = (h + kTile - 1) / kTile;
  cc.tiles.assign(static_cast<std::size_t>(cc.tiles_x) * static_cast<std::size_t>(cc.tiles_y), TileInfo{});
  // Undistorted coordinates of every pixel centre (one Newton solve each); the room's 2x2
  // supersamples interpolate between them (the distortion is smooth at this scale).
  std::vector<cv::Vec2d> und(npix);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x)
      und[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)] =
          cam.undistort(cv::Point2d(x, y));
  }
  auto und_at = [&](double fx, double fy) {
    // Bilinear (extrapolating at the border) in the grid of pixel centres.
    const int x0 = std::clamp(static_cast<int>(std::floor(fx)), 0, std::max(0, w - 2));
    const int y0 = std::clamp(static_cast<int>(std::floor(fy)), 0, std::max(0, h - 2));
    const int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
    const double ax = fx - x0, ay = fy - y0;
    auto U = [&](int xx, int yy) {
      return und[static_cast<std::size_t>(yy) * static_cast<std::size_t>(w) + static_cast<std::size_t>(xx)];
    };
    return (U(x0, y0) * (1 - ax) + U(x1, y0) * ax) * (1 - ay) + (U(x0, y1) * (1 - ax) + U(x1, y1) * ax) * ay;
  };
  static const double kSub[4][2] = {{-0.25, -0.25}, {0.25, -0.25}, {-0.25, 0.25}, {0.25, 0.25}};
  for (int y = 0; y < h; ++y) {
    auto* row = cc.room.ptr<cv::Vec3b>(y);
    for (int x = 0; x < w; ++x) {
      const std::size_t i =
          static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
      // The coordinates as stored (float) define the line every later test uses.
      cc.a[i] = static_cast<float>(und[i][0]);
      cc.b[i] = static_cast<float>(und[i][1]);
      const cv::Vec3d D = Rt * cv::Vec3d(cc.a[i], cc.b[i], 1.0);
      double t = 0;
      int face = 0;
      if (!room.hit(cc.center, D, &t, &face)) throw std::logic_error("scene: camera outside the room");
      cc.room_z[i] = static_cast<float>(t);
      TileInfo& tile = cc.tiles[static_cast<std::size_t>(y / kTile) * static_cast<std::size_t>(cc.tiles_x) +
                                static_cast<std::size_t>(x / kTile)];
      tile.rays.add(cc.a[i], cc.b[i]);
      cc.fx[i] = cc.fy[i] = std::numeric_limits<float>::quiet_NaN();
      if (face == detail::kFloor) {
        const cv::Vec3d p = cc.center + D * t;
        cc.fx[i] = static_cast<float>(p[0]);
        cc.fy[i] = static_cast<float>(p[1]);
        tile.floor.add(cc.fx[i], cc.fy[i]);
      }
      cv::Vec3d sum(0, 0, 0);
      for (const auto& sub : kSub) {
        const cv::Vec2d sxy = und_at(x + sub[0], y + sub[1]);
        const cv::Vec3d sd = Rt * cv::Vec3d(sxy[0], sxy[1], 1.0);
        double st = 0;
        int sface = 0;
        if (room.hit(cc.center, sd, &st, &sface)) sum += room.shade(sface, cc.center + sd * st);
      }
      sum *= 0.25;
      row[x] = cv::Vec3b(to_u8(sum[0]), to_u8(sum[1]), to_u8(sum[2]));
    }
  }
}

void Scene::Impl::render(int frame, int cam_index, const Finish& finish, cv::Mat& out, cv::Mat* sil,
                         cv::Mat* shadow) const {
  if (frame < 0) throw std::out_of_range("scene: negative frame");
  CameraCache& cc = cache(cam_index);
  const rig::Camera& cam = calib.cameras[static_cast<std::size_t>(cam_index)];
  const int w = cam.width, h = cam.height;
  // Reuse the caller's buffers (create() keeps them when the size and type already match).
  finish.lay(cc.room, out);
  if (sil) {
    sil->create(h, w, CV_8UC1);
    sil->setTo(0);
  }
  if (shadow) {
    shadow->create(h, w, CV_8UC1);
    shadow->setTo(0);
  }

  // Working storage, kept per thread so that a frame allocates nothing.
  thread_local Scratch scratch;
  std::vector<Primitive>& prims = scratch.prims;
  build_primitives(motion.body_pose(frame), motion.body(), motion.feet(), &prims);
  const std::size_t np = prims.size();
  const cv::Vec3d L = opt.light_m;
  // Lines of sight (u, v) = (a, b): world direction Rt (a, b, 1). Lines from the light to the
  // floor point (x, y, 0): direction (x - Lx, y - Ly, -Lz), t = 1 on the floor.
  const cv::Matx33d G_light(1, 0, -L[0], 0, 1, -L[1], 0, 0, -L[2]);
  std::vector<LineFamily>& sight = scratch.sight;
  std::vector<LineFamily>& light = scratch.light;
  sight.clear();
  light.clear();
  // Flip z for the light's view: it looks down, floor point (x, y) = L + Lz (u, v) for
  // (u, v) = ((X - L)_x, (X - L)_y) / -(X - L)_z.
  const cv::Matx33d flip_z(1, 0, 0, 0, 1, 0, 0, 0, -1);
  for (std::size_t k = 0; k < np; ++k) {
    const Primitive& p = prims[k];
    // The capsule is its end ellipsoid swept along the core; (u, v) = (x/z, y/z) is
    // quasi-linear, so its extremes over the capsule are reached on an end ellipsoid.
    const cv::Matx33d axes = p.R * cv::Matx33d::diag(p.radii);
    const cv::Vec3d half = cv::Vec3d(p.R(0, 2), p.R(1, 2), p.R(2, 2)) * p.half_length;
    Rect2 screen, footprint;
    double z_min = HUGE_VAL;
    for (const cv::Vec3d& end : {p.center + half, p.center - half}) {
      const cv::Vec3d pc = cc.R * (end - cc.center);
      const cv::Matx33d B = cc.R * axes;
      z_min = std::min(z_min, pc[2] - std::sqrt(B(2, 0) * B(2, 0) + B(2, 1) * B(2, 1) + B(2, 2) * B(2, 2)));
      screen.add_projection(pc, B);
      const cv::Vec3d pl = flip_z * (end - L);
      footprint.add_projection(pl, flip_z * axes);
    }
    if (!footprint.empty() && std::isfinite(footprint.x0)) {
      footprint = {L[0] + L[2] * footprint.x0, L[0] + L[2] * footprint.x1, L[1] + L[2] * footprint.y0,
                   L[1] + L[2] * footprint.y1};
    }
    const int ki = static_cast<int>(k);
    sight.push_back(make_family(ki, p, cc.Rt, cc.center, screen));
    sight.back().t_min = std::max(0.0, z_min);
    if (opt.shadows) {
      light.push_back(make_family(ki, p, G_light, L, footprint));
      light.back().t_max = 1.f;
    }
  }
  // Front to back, so that most pixels a farther part would cover are already nearer.
  std::sort(sight.begin(), sight.end(),
            [](const LineFamily& x, const LineFamily& y) { return x.t_min < y.t_min; });

  PartShading shading[kPartCount];
  for (const LineFamily& f : sight) {
    const Primitive& p = prims[static_cast<std::size_t>(f.k)];
    shading[f.k] = PartShading(p, f, L, look.albedo(part_material(p.part)));
  }
  const double factor = opt.shadow_factor;
  const std::size_t stride = static_cast<std::size_t>(w);
  std::vector<const LineFamily*>& body_cand = scratch.body_cand;
  std::vector<const LineFamily*>& shadow_cand = scratch.shadow_cand;
  float depth[kTilePixels];                // nearest so far along each line of sight
  std::int8_t hit[kTilePixels];            // its part, where body bit
  std::uint16_t body[kTile], dark[kTile];  // per row, a bit per pixel
  TileClass cls;
  for (int ty = 0; ty < cc.tiles_y; ++ty) {
    for (int tx = 0; tx < cc.tiles_x; ++tx) {
      const TileInfo& tile = cc.tiles[static_cast<std::size_t>(ty) * static_cast<std::size_t>(cc.tiles_x) +
                                      static_cast<std::size_t>(tx)];
      body_cand.clear();
      shadow_cand.clear();
      for (const LineFamily& f : sight) {
        if (f.rect.overlaps(tile.rays)) body_cand.push_back(&f);
      }
      if (!tile.floor.empty()) {
        for (const LineFamily& f : light) {
          if (f.rect.overlaps(tile.floor)) shadow_cand.push_back(&f);
        }
      }
      if (body_cand.empty() && shadow_cand.empty()) continue;
      const int x0 = tx * kTile, y0 = ty * kTile;
      const int tw = std::min(w, x0 + kTile) - x0, th = std::min(h, y0 + kTile) - y0;
      auto pixel = [&](int yy, int xx) {
        return static_cast<std::size_t>(y0 + yy) * stride + static_cast<std::size_t>(x0 + xx);
      };
      for (int yy = 0; yy < th; ++yy) {
        std::memcpy(&depth[yy * kTile], &cc.room_z[pixel(yy, 0)],
                    static_cast<std::size_t>(tw) * sizeof(float));
        body[yy] = dark[yy] = 0;
      }
      // The body: the nearest hit per pixel.
      for (const LineFamily* f : body_cand) {
        const Primitive& p = prims[static_cast<std::size_t>(f->k)];
        const auto t_min = static_cast<float>(f->t_min);
        classify(*f, &cc.a[pixel(0, 0)], &cc.b[pixel(0, 0)], stride, tw, th, &cls);
        for (unsigned rows = cls.rows; rows != 0; rows &= rows - 1) {
          const int yy = std::countr_zero(rows);
          for (unsigned bits = cls.hit[yy] | cls.exact[yy]; bits != 0; bits &= bits - 1) {
            const int xx = std::countr_zero(bits), j = yy * kTile + xx;
            if (depth[j] <= t_min) continue;
            float t = cls.t[j];
            if (cls.exact[yy] >> xx & 1) {
              double te;
              const std::size_t i = pixel(yy, xx);
              if (!p.intersect_local(f->o, f->M * cv::Vec3d(cc.a[i], cc.b[i], 1.0), 0.0, &te)) continue;
              t = static_cast<float>(te);
            }
            if (t < depth[j]) {
              depth[j] = t;
              hit[j] = static_cast<std::int8_t>(f->k);
              body[yy] = static_cast<std::uint16_t>(body[yy] | 1u << xx);
            }
          }
        }
      }
      // The shadow, on the floor pixels the body leaves visible (no floor: NaN, never classified).
      for (const LineFamily* f : shadow_cand) {
        const Primitive& p = prims[static_cast<std::size_t>(f->k)];
        classify(*f, &cc.fx[pixel(0, 0)], &cc.fy[pixel(0, 0)], stride, tw, th, &cls);
        for (unsigned rows = cls.rows; rows != 0; rows &= rows - 1) {
          const int yy = std::countr_zero(rows);
          const unsigned open = ~static_cast<unsigned>(body[yy] | dark[yy]);
          unsigned now = cls.hit[yy] & open;
          for (unsigned bits = cls.exact[yy] & open; bits != 0; bits &= bits - 1) {
            const int xx = std::countr_zero(bits);
            const std::size_t i = pixel(yy, xx);
            double te;
            if (p.intersect_local(f->o, f->M * cv::Vec3d(cc.fx[i], cc.fy[i], 1.0), 0.0, &te) && te <= 1.0) {
              now |= 1u << xx;
            }
          }
          dark[yy] = static_cast<std::uint16_t>(dark[yy] | now);
        }
      }
      // Shade.
      for (int yy = 0; yy < th; ++yy) {
        auto* orow = out.ptr<cv::Vec3b>(y0 + yy) + x0;
        const auto* rrow = cc.room.ptr<cv::Vec3b>(y0 + yy) + x0;
        for (unsigned bits = body[yy]; bits != 0; bits &= bits - 1) {
          const int xx = std::countr_zero(bits), j = yy * kTile + xx;
          const std::size_t i = pixel(yy, xx);
          const cv::Vec3b c = shading[hit[j]](cc.a[i], cc.b[i], depth[j]);
          for (std::size_t ch = 0; ch < 3; ++ch)
            orow[xx][static_cast<int>(ch)] = finish(c[static_cast<int>(ch)], 3 * i + ch);
          if (sil) sil->at<std::uint8_t>(y0 + yy, x0 + xx) = 255;
        }
        for (unsigned bits = dark[yy]; bits != 0; bits &= bits - 1) {
          const int xx = std::countr_zero(bits);
          const std::size_t i = pixel(yy, xx);
          const cv::Vec3b& px = rrow[xx];
          for (std::size_t ch = 0; ch < 3; ++ch) {
            orow[xx][static_cast<int>(ch)] = finish(to_u8(px[static_cast<int>(ch)] * factor), 3 * i + ch);
          }
          if (shadow) shadow->at<std::uint8_t>(y0 + yy, x0 + xx) = 255;
        }
      }
    }
  }
}

Finish Scene::Impl::finish(std::uint64_t key, double gain) const {
  Finish f;
  f.gain_q7 = static_cast<int>(std::lround(std::clamp(gain, 0.5, 1.49) * 128.0));
  if (opt.noise_sigma > 0) {
    const std::size_t off = static_cast<std::size_t>(key % kNoiseSlack);
    f.pos = noise_pos.ptr<std::uint8_t>() + off;
    f.neg = noise_neg.ptr<std::uint8_t>() + off;
  }
  return f;
}

double Scene::flicker_gain(int frame) const {
  if (impl_->opt.flicker <= 0) return 1.0;
  const double u = detail::hash01(frame, 0x46, impl_->opt.seed ^ 0xF11C4E4ull);
  return 1.0 + impl_->opt.flicker * (2 * u - 1);
}

void Scene::render(int frame, int cam, cv::Mat& rgb_out, cv::Mat* silhouette_truth,
                   cv::Mat* shadow_truth) const {
  const Finish f = impl_->finish(
      image_key(impl_->opt.seed, 1, static_cast<std::uint64_t>(cam), static_cast<std::uint64_t>(frame)),
      flicker_gain(frame));
  impl_->render(frame, cam, f, rgb_out, silhouette_truth, shadow_truth);
}

void Scene::render_clean(int frame, int cam, cv::Mat& rgb_out, cv::Mat* silhouette_truth,
                         cv::Mat* shadow_truth) const {
  impl_->render(frame, cam, Finish{}, rgb_out, silhouette_truth, shadow_truth);
}

void Scene::render_background(int cam, int i, cv::Mat& rgb_out) const {
  if (i < 0) throw std::out_of_range("scene: negative background index");
  const CameraCache& cc = impl_->cache(cam);
  double gain = 1.0;
  if (impl_->opt.flicker > 0) {
    gain = 1.0 + impl_->opt.flicker * (2 * detail::hash01(i, 0x42, impl_->opt.seed ^ 0xB6C6ull) - 1);
  }
  const Finish f = impl_->finish(
      image_key(impl_->opt.seed, 2, static_cast<std::uint64_t>(cam), static_cast<std::uint64_t>(i)), gain);
  f.lay(cc.room, rgb_out);
}

void Scene::render_background_clean(int cam, cv::Mat& rgb_out) const {
  impl_->cache(cam).room.copyTo(rgb_out);
}

BodyPose Scene::body_pose(int frame) const {
  return impl_->motion.body_pose(frame);
}

std::array<cv::Vec3d, kJointCount> Scene::joints(int frame) const {
  return body_pose(frame).p_world;
}

std::vector<Primitive> Scene::primitives(int frame) const {
  std::vector<Primitive> prims;
  build_primitives(body_pose(frame), impl_->motion.body(), impl_->motion.feet(), &prims);
  return prims;
}

std::vector<FeatureTruth> Scene::features(int frame, int cam_index) const {
  const rig::Camera& cam = impl_->calib.cameras.at(static_cast<std::size_t>(cam_index));
  const BodyPose pose = body_pose(frame);
  const std::vector<Primitive> prims = primitives(frame);
  const cv::Vec3d C = cam.center_world();
  std::vector<FeatureTruth> out;
  for (int f = 0; f < kFeatureCount; ++f) {
    FeatureTruth t;
    t.feature = static_cast<Feature>(f);
    const cv::Vec3d& p = pose.p(feature_joint(t.feature));
    t.uv = cam.project(p);
    t.depth_m = cam.to_cam(p)[2];
    t.in_image = t.depth_m > 0 && cam.in_image(t.uv);
    for (const Primitive& prim : prims) {
      if (part_of_feature(prim.part, t.feature)) continue;
      double hit;
      if (prim.intersect(C, p - C, 0.0, &hit) && hit < 1.0) {
        t.occluded = true;
        break;
      }
    }
    t.visible = t.in_image && !t.occluded;
    out.push_back(t);
  }
  return out;
}

bool Scene::occupied(const cv::Vec3d& p_world, int frame) const {
  if (p_world[2] < 0) return false;
  for (const Primitive& prim : primitives(frame)) {
    if (prim.contains(p_world)) return true;
  }
  return false;
}

namespace {

// Calls fn(prim, voxel index) for every voxel centre inside a primitive (above the floor), primitive
// by primitive in Part order, visiting only the voxels of the primitive's bounding box.
template <typename Fn>
void for_each_inside(const rig::VoxelGrid& grid, const std::vector<Primitive>& prims, Fn&& fn) {
  std::string why;
  if (!grid.valid(&why)) throw std::invalid_argument("occupancy: grid: " + why);
  for (const Primitive& prim : prims) {
    cv::Vec3d lo(HUGE_VAL, HUGE_VAL, HUGE_VAL), hi(-HUGE_VAL, -HUGE_VAL, -HUGE_VAL);
    for (const cv::Vec3d& c : prim.box_corners()) {
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], c[a]);
        hi[a] = std::max(hi[a], c[a]);
      }
    }
    int i0[3], i1[3];
    const int n[3] = {grid.nx, grid.ny, grid.nz};
    bool empty = false;
    for (int a = 0; a < 3; ++a) {
      // Voxel centres min + (i + 1/2) v inside [lo, hi].
      i0[a] = std::max(0, static_cast<int>(std::ceil((lo[a] - grid.min_m[a]) / grid.voxel_m - 0.5)));
      i1[a] = std::min(n[a] - 1, static_cast<int>(std::floor((hi[a] - grid.min_m[a]) / grid.voxel_m - 0.5)));
      if (i0[a] > i1[a]) empty = true;
    }
    if (empty) continue;
    for (int k = i0[2]; k <= i1[2]; ++k) {
      for (int j = i0[1]; j <= i1[1]; ++j) {
        for (int i = i0[0]; i <= i1[0]; ++i) {
          const cv::Vec3d c = grid.center(i, j, k);
          if (c[2] >= 0 && prim.contains(c)) fn(prim, grid.index(i, j, k));
        }
      }
    }
  }
}

}  // namespace

void Scene::occupancy(const rig::VoxelGrid& grid, int frame, std::vector<std::uint8_t>* bits) const {
  bits->assign(grid.bitset_bytes(), 0);
  for_each_inside(grid, primitives(frame),
                  [&](const Primitive&, std::size_t v) { rig::hull_set(bits->data(), v); });
}

void Scene::occupancy_parts(const rig::VoxelGrid& grid, int frame, std::vector<std::uint8_t>* part) const {
  std::string why;
  if (!grid.valid(&why)) throw std::invalid_argument("occupancy: grid: " + why);
  part->assign(static_cast<std::size_t>(grid.nx) * static_cast<std::size_t>(grid.ny) *
                   static_cast<std::size_t>(grid.nz),
               kNoPart);
  // Primitives come in Part order: a later (higher) part overwrites an earlier one.
  for_each_inside(grid, primitives(frame),
                  [&](const Primitive& p, std::size_t v) { (*part)[v] = static_cast<std::uint8_t>(p.part); });
}

}  // namespace vc::sim
