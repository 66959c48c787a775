// The per-frame fitter (fitter.hpp; host/fit/README.md has the steps and the rules).
#include "voxcap/fit/fitter.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <stdexcept>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "voxcap/base/clock.hpp"
#include "voxcap/fit/failure.hpp"
#include "voxcap/fit/heading.hpp"
#include "voxcap/fit/sides.hpp"

namespace vc::fit {
namespace {

constexpr double kMinFeatureConfidence = 0.05;  // a triangulated feature below this is not used
constexpr double kSampleRadius = 0.8;           // cylinder samples fill this fraction of a limb's radius
constexpr double kTorsoExclusion = 0.85;        // limb samples inside this much of the torso do not count
constexpr double kMaxTurnPerFrameDeg = 25;      // a larger jump of the torso's axes is not believed
constexpr double kSlack = 0.03;                 // m: goals near full reach may be this much short
constexpr int kStraightForgetFrames = 30;       // straight this long: rho(t-1) is no guide any more
constexpr int kBelieveTurnFrames = 6;           // a larger turn the PCA insists on this long is believed
constexpr double kSameCandidateDeg = 10;        // ... when its headings agree within this
constexpr double kHintAgreeDeg = 45;            // ... and the hands and feet agree within this
constexpr double kFeatureSupport = 0.5;         // a leg at its feature with fewer samples in the hull ...
constexpr double kHullBeatsFeature = 1.5;  // ... takes the hull's end when that holds this many times more
constexpr double kYawRateGain = 0.2;       // the turn rate's smoothing (a PCA is noisy by a few degrees)
constexpr double kMaxTurnRateDeg = 4;      // the predicted turn per frame at most (240 deg/s at 60 Hz)
constexpr double kSwapMargin =
    0.08;  // m: a pair's features taken crosswise fit their limbs' paths this much better
constexpr double kDeepInTorso = 0.6;  // a hand feature this deep in the torso cylinder is not a wrist
constexpr double kOnePointM = 0.06;   // m: a pair's two features this close are one point ...
constexpr double kOnePointApartM =
    0.2;  // ... that is wrong for one of them when their paths are this far apart
constexpr double kLumbarLeanDeg = 10;  // the pelvis tilts with the torso's lean beyond this
constexpr int kNearReachSteps = 4;     // cm: a limb near full reach is tried this much bent (1 cm steps) ...
constexpr int kNearReachDirs = 12;     // ... in this many directions about its root-to-end line
constexpr double kSidesPadM = 0.25;    // m: the box searched for the feet's sides, around hips and feet

struct OneEuro {
  bool init = false;
  double x = 0, dx = 0;
  static double alpha(double cutoff_hz, double dt) {
    const double tau = 1.0 / (2 * M_PI * cutoff_hz);
    return 1.0 / (1.0 + tau / dt);
  }
  double filter(double v, double dt, double min_cutoff, double beta) {
    if (!init) {
      init = true;
      x = v;
      dx = 0;
      return v;
    }
    const double d = (v - x) / dt;
    dx += alpha(1.0, dt) * (d - dx);
    x += alpha(min_cutoff + beta * std::abs(dx), dt) * (v - x);
    return x;
  }
};

struct LimbTrack {
  bool have = false;              // a last good end
  Vec3 last_local{0.0};           // end - root in the root's frame, last good
  Vec3 vel_local{0.0};            // per frame
  int lost = 0;                   // frames since the last good end
  int straight_frames = 1 << 20;  // frames in a row it has been straight (never bent: rho unknown)
};

struct Moments {
  int n = 0;
  Vec3 mean_local{0.0};  // in the cylinder's frame, relative to its neck point
  double cov[3][3] = {};
};

Vec3 level(const Vec3& v) {
  return {v.x, v.y, 0};
}

double angle_deg(const Vec3& a, const Vec3& b) {
  return std::acos(std::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0, 1.0)) * 180 / M_PI;
}

}  // namespace

struct Fitter::State {
  config::FittingOptions opt;
  double rate_hz;
  HullBits hull;
  SamplePattern pattern;
  struct Sample {
    double t, rc, rs;  // along the segment, and r cos a, r sin a in units of the sampled radius
  };
  std::vector<Sample> samples;
  BodyModel body;
  bool initialized = false;
  uint32_t body_version = 0;
  std::vector<InitMeasurement> init_meas;
  int uninit_frames = 0;
  Layer1 l1;
  Layer2 l2;
  Vec3 centroid_off_local{0.0};  // torso voxels' centroid - neck, in the torso frame (at init)
  double init_torso_voxels = 0;
  std::array<LimbTrack, kLimbCount> limbs{};
  std::array<LimbPose, kLimbCount> last{};  // each limb's fitted pose (previous frame while fitting)
  bool have_last = false;
  bool have_head = false;
  Vec3 last_head{0.0};
  int failing = 0;
  uint32_t trunk_off = 0;          // the last frames' trunk off the hull (failure.hpp), bit 0 the last one
  bool reacquire_pending = false;  // re-initialized on a hull without a torso: the next torso decides
  // The torso's turn about the vertical (radians per frame, smoothed): the next frame's cylinder and
  // the PCA's reference are the last torso frame turned on by it (a turning performer is met, not
  // chased: the cylinder placed at the last heading would bias the PCA toward it).
  double yaw_rate = 0;
  // A shoulder line the PCA gave that was turned too far from the reference to be believed at once:
  // believed when the PCA keeps giving it (kBelieveTurnFrames frames, within kSameCandidateDeg).
  Vec3 turn_candidate{0.0};
  int turn_candidate_frames = 0;
  bool heading_measured = false;  // the last pca() took its shoulder line from the voxels (else kept)
  StageTimes times;
  std::array<OneEuro, 3 * pipeline::kPoseJointCount> euro{};
  bool have_seq = false;
  uint64_t last_seq = 0;
  // The pairs' naming (hands, feet): taken crosswise while set; the number of changes.
  std::array<bool, 2> swapped{};
  std::array<uint64_t, 2> swaps{};
  uint64_t one_point_frames = 0;  // a pair's features on one point, one of them taken as lost
  // The body's own heading (heading.hpp): the feet on the hull, voting on the torso's sign.
  HeadingVote heading_vote;
  uint64_t heading_flips = 0;
  // The feet's names from the hull (README, "The feet's names from the hull").
  PairSides sides;
  uint64_t hull_named_feet = 0;   // frames where the hull changed an untrusted foot name
  std::array<bool, 5> off_leg{};  // this frame: the feature was on the other leg (by feature id)

  State(const rig::VoxelGrid& grid, const config::FittingOptions& o, double rate)
      : opt(o),
        rate_hz(rate > 0 ? rate : 60),
        hull(grid),
        pattern(cylinder_sample_pattern(o.samples)),
        sides(grid) {
    std::string why;
    if (!opt.valid(&why)) throw std::invalid_argument("fit: " + why);
    for (const SamplePattern::S& p : pattern.samples)
      samples.push_back({p.t, static_cast<double>(p.r) * p.c, static_cast<double>(p.r) * p.s});
    if (!opt.body.empty()) apply_body_toml(opt.body.string(), &body);  // fail early on a bad file
  }

  void reset() {
    initialized = false;
    init_meas.clear();
    uninit_frames = 0;
    l1 = Layer1{};
    l2 = Layer2{};
    limbs = {};
    have_last = false;
    have_head = false;
    failing = 0;
    trunk_off = 0;
    euro = {};
    have_seq = false;
    yaw_rate = 0;
    turn_candidate_frames = 0;
    swapped = {};
    heading_vote.reset();
  }

  // ---- Torso segmentation: the occupied voxels inside the cylinder placed at (neck, R). ----
  Moments segment(const Vec3& neck, const Mat3& R, double scale) const {
    const double a = body.torso_half_width_m * 1.05 * scale, b = body.torso_half_depth_m * 1.1 * scale;
    const double zlo = -body.spine_m, zhi = -0.03;
    Vec3 lo(1e9), hi(-1e9);
    for (int c = 0; c < 8; ++c) {
      const Vec3 q((c & 1) ? a : -a, (c & 2) ? b : -b, (c & 4) ? zhi : zlo);
      const Vec3 p = neck + R * q;
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    const rig::VoxelGrid& g = hull.grid();
    int i0, j0, k0, i1, j1, k1;
    hull.cell(lo, &i0, &j0, &k0);
    hull.cell(hi, &i1, &j1, &k1);
    i0 = std::max(i0, 0), j0 = std::max(j0, 0), k0 = std::max(k0, 0);
    i1 = std::min(i1, g.nx - 1), j1 = std::min(j1, g.ny - 1), k1 = std::min(k1, g.nz - 1);
    const Mat3 Rt = glm::transpose(R);
    const double ia2 = 1 / (a * a), ib2 = 1 / (b * b);
    double s1[3] = {0, 0, 0}, s2[6] = {0, 0, 0, 0, 0, 0};
    int n = 0;
    const uint8_t* bits = hull.bits();
    for (int k = k0; k <= k1; ++k)
      for (int j = j0; j <= j1; ++j) {
        const size_t row = g.index(0, j, k);
        for (int i = i0; i <= i1; ++i) {
          const size_t idx = row + static_cast<size_t>(i);
          if (!((bits[idx >> 3] >> (idx & 7)) & 1u)) continue;
          const Vec3 q = Rt * (hull.centre(i, j, k) - neck);
          if (q.z < zlo || q.z > zhi || q.x * q.x * ia2 + q.y * q.y * ib2 > 1) continue;
          ++n;
          s1[0] += q.x, s1[1] += q.y, s1[2] += q.z;
          s2[0] += q.x * q.x, s2[1] += q.x * q.y, s2[2] += q.x * q.z;
          s2[3] += q.y * q.y, s2[4] += q.y * q.z, s2[5] += q.z * q.z;
        }
      }
    Moments m;
    m.n = n;
    if (n == 0) return m;
    const Vec3 mu(s1[0] / n, s1[1] / n, s1[2] / n);
    m.mean_local = mu;
    m.cov[0][0] = s2[0] / n - mu.x * mu.x;
    m.cov[0][1] = m.cov[1][0] = s2[1] / n - mu.x * mu.y;
    m.cov[0][2] = m.cov[2][0] = s2[2] / n - mu.x * mu.z;
    m.cov[1][1] = s2[3] / n - mu.y * mu.y;
    m.cov[1][2] = m.cov[2][1] = s2[4] / n - mu.y * mu.z;
    m.cov[2][2] = s2[5] / n - mu.z * mu.z;
    return m;
  }

  // ---- PCA: the torso frame from the moments (in the cylinder's frame R), with the components
  // ordered and signed by continuity with R (the previous torso frame). ----
  // `right_hint`: the performer's right as the hands and feet say (level, zero when they do not): the
  // sign of a large turn believed on persistence (the PCA's axis has no sign of its own).
  Mat3 pca(const Moments& m, const Mat3& R, bool free = false, const Vec3& right_hint = Vec3(0.0),
           const Vec3& body_right = Vec3(0.0)) {
    double C[3][3];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) C[r][c] = m.cov[r][c];
    double vals[3];
    Vec3 v[3];
    eigen_sym3(C, vals, v);
    // The spine: the component nearest the previous z; the shoulder line: the one of the other two
    // nearest the previous x. Signs: toward the previous axes.
    int zi = 0;
    for (int r = 1; r < 3; ++r)
      if (std::abs(v[r].z) > std::abs(v[zi].z)) zi = r;
    int xi = zi == 0 ? 1 : 0, yi = 3 - zi - xi;
    if (std::abs(v[yi].x) > std::abs(v[xi].x)) std::swap(xi, yi);
    Vec3 z = v[zi].z < 0 ? -v[zi] : v[zi];
    Vec3 x = v[xi].x < 0 ? -v[xi] : v[xi];
    const double lx = vals[xi], ly = vals[yi];
    if (free) {  // re-acquiring: R is only a hint; the shoulder line is the wider component
      heading_measured = false;
      if (lx < ly) x = v[yi].x < 0 ? -v[yi] : v[yi];
      x = glm::normalize(x - glm::dot(x, z) * z);
      return R * Mat3(x, glm::cross(z, x), z);
    }
    // Cross-section too round to tell the shoulder line: keep the previous one.
    heading_measured = lx >= 1.15 * ly;
    if (!heading_measured) x = Vec3(1, 0, 0);
    if (angle_deg(z, Vec3(0, 0, 1)) > kMaxTurnPerFrameDeg) z = Vec3(0, 0, 1);
    x = glm::normalize(x - glm::dot(x, z) * z);
    if (angle_deg(x, Vec3(1, 0, 0)) > kMaxTurnPerFrameDeg) {
      // Not believed at once (a lumpy hull, an arm across the chest); believed when it persists:
      // the torso turned faster than the prediction, or the heading was lost.
      const Vec3 xw = level(R * x);
      const bool same = turn_candidate_frames > 0 && glm::length(xw) > 1e-6 &&
                        angle_deg(xw, turn_candidate) < kSameCandidateDeg;
      turn_candidate_frames = same ? turn_candidate_frames + 1 : 1;
      turn_candidate = xw;
      // Believed only with the hands and feet for a witness: the axis within kHintAgreeDeg of their
      // right, its sign theirs (the PCA's axis has no sign of its own).
      // The feet on the hull (`body_right`, when they tell) witness too, and sign it before the names:
      // they do not depend on them (a fighting stance turns the feet 45-90 degrees, so either witness
      // will do).
      auto agrees = [&xw](const Vec3& h) {
        return glm::length(h) > 0.05 && glm::length(xw) > 1e-6 &&
               std::min(angle_deg(xw, h), angle_deg(-xw, h)) < kHintAgreeDeg;
      };
      const bool witnessed = agrees(right_hint) || agrees(body_right);
      const bool body_signs = glm::length(body_right) > 0.05 && glm::length(xw) > 1e-6 &&
                              std::abs(glm::dot(glm::normalize(xw), glm::normalize(body_right))) > 0.5;
      const Vec3 sign_by = body_signs ? body_right : right_hint;
      if (turn_candidate_frames < kBelieveTurnFrames || !witnessed) {
        x = glm::normalize(Vec3(1, 0, 0) - z.x * z);
        heading_measured = false;
      } else if (glm::dot(xw, sign_by) < 0) {
        x = -x;
      }
    } else {
      turn_candidate_frames = 0;
    }
    const Vec3 y = glm::cross(z, x);
    return R * Mat3(x, y, z);
  }

  // ---- Cylinder samples of one limb in the hull: occupied ones outside the torso. ----
  // The hot loop (every angle of every limb): each segment's frame is set up once, in world and in
  // the torso's scaled frame, so a sample costs three multiply-adds per frame and a bit lookup.
  int count_limb(int limb, const Vec3& root, const Vec3& hinge, const Vec3& end) const {
    const Mat3 Rt = glm::transpose(l1.R_torso_world);
    // Torso frame scaled so that the exclusion ellipse is the unit circle.
    const Vec3 sc(1 / (kTorsoExclusion * body.torso_half_width_m),
                  1 / (kTorsoExclusion * body.torso_half_depth_m), 1);
    const double zlo = -body.spine_m;
    int n = 0;
    const int other = limb ^ 1;  // the limb of the same pair (the other arm, the other leg)
    // The other limb's box, to skip its exact test for most samples.
    Vec3 olo(1e9), ohi(-1e9);
    if (have_last) {
      const LimbPose& o = last[static_cast<size_t>(other)];
      const double r = std::max(body.upper_radius_m(other), body.lower_radius_m(other));
      olo = glm::min(glm::min(o.root, o.hinge), o.end) - Vec3(r);
      ohi = glm::max(glm::max(o.root, o.hinge), o.end) + Vec3(r);
    }
    for (int seg = 0; seg < 2; ++seg) {
      const Vec3 A = seg == 0 ? root : hinge, B = seg == 0 ? hinge : end;
      const Vec3 ax = B - A;
      const double len = glm::length(ax);
      if (len < 1e-6) continue;
      const Vec3 u = ax / len;
      const Vec3 any = std::abs(u.z) < 0.9 ? Vec3(0, 0, 1) : Vec3(1, 0, 0);
      const double r = kSampleRadius * (seg == 0 ? body.upper_radius_m(limb) : body.lower_radius_m(limb));
      const Vec3 p1 = r * glm::normalize(glm::cross(u, any)), p2 = r * glm::normalize(glm::cross(u, p1));
      const Vec3 qA = sc * (Rt * (A - l1.neck_world)), qax = sc * (Rt * ax);
      const Vec3 q1 = sc * (Rt * p1), q2 = sc * (Rt * p2);
      const size_t from = seg == 0 ? 0 : static_cast<size_t>(pattern.upper);
      const size_t to = seg == 0 ? static_cast<size_t>(pattern.upper) : samples.size();
      for (size_t i = from; i < to; ++i) {
        const Sample& s = samples[i];
        const Vec3 p = A + s.t * ax + s.rc * p1 + s.rs * p2;
        if (!hull.at(p)) continue;
        const Vec3 q = qA + s.t * qax + s.rc * q1 + s.rs * q2;
        if (q.z < 0 && q.z > zlo && q.x * q.x + q.y * q.y < 1) continue;
        if (p.x > olo.x && p.y > olo.y && p.z > olo.z && p.x < ohi.x && p.y < ohi.y && p.z < ohi.z &&
            in_other(other, p))
          continue;
        ++n;
      }
    }
    return n;
  }

  // ---- The pelvis frame (host/fit/README.md, "Legs"): the torso's heading, tilted forward or back
  // with the torso's lean beyond kLumbarLeanDeg. Bending at the hips (squatting, sitting, picking
  // something up) the pelvis tilts with the trunk, and the hip joints go back and up with it; the
  // first few degrees of a lean are the lumbar spine's (and the torso PCA's noise with the arms near
  // it), so a level pelvis stays level there. No side tilt: the hips stay level left to right. ----
  static Mat3 pelvis_frame(const Mat3& R_torso) {
    const Mat3 H = level_heading(R_torso);
    const Vec3 zt = R_torso[2];
    const double lean = std::atan2(glm::dot(zt, H[1]), glm::dot(zt, H[2]));  // forward positive
    const double dz = kLumbarLeanDeg * M_PI / 180;
    const double p = std::copysign(std::max(0.0, std::abs(lean) - dz), lean);
    const Vec3 z = std::cos(p) * H[2] + std::sin(p) * H[1], y = std::cos(p) * H[1] - std::sin(p) * H[2];
    return Mat3(H[0], y, z);
  }

  // Whether p lies inside the fitted torso cylinder (at this frame's neck and torso frame), widened
  // by widen_m.
  bool inside_torso(const Vec3& p, double widen_m = 0) const {
    const Vec3 q = glm::transpose(l1.R_torso_world) * (p - l1.neck_world);
    const double x = q.x / (body.torso_half_width_m + widen_m), y = q.y / (body.torso_half_depth_m + widen_m);
    return q.z < 0 && q.z > -body.spine_m && x * x + y * y < 1;
  }

  // Whether p lies deep inside the fitted torso: within kDeepInTorso of the cylinder's half width and
  // depth, and 5 cm or more from its top and bottom.
  bool deep_in_torso(const Vec3& p) const {
    const Vec3 q = glm::transpose(l1.R_torso_world) * (p - l1.neck_world);
    const double x = q.x / (kDeepInTorso * body.torso_half_width_m),
                 y = q.y / (kDeepInTorso * body.torso_half_depth_m);
    return q.z < -0.05 && q.z > -body.spine_m + 0.05 && x * x + y * y < 1;
  }

  // A wrist goal moved out of the torso: a point inside the fitted torso cylinder, from 5 cm below the
  // neck down to the hip joints (the pelvis is torso too), is moved out along the cylinder's radius
  // (its height kept) to the cylinder's surface. A hand pressed against the body merges with it in the
  // images, so its feature is pulled into the body; the hand itself is never inside.
  Vec3 out_of_torso(const Vec3& p) const {
    const Mat3& R = l1.R_torso_world;
    const Vec3 q = glm::transpose(R) * (p - l1.neck_world);
    if (!(q.z < -0.05 && q.z > -(body.spine_m + body.pelvis_drop_m))) return p;
    // The wrist's centre lies a forearm's radius off the skin.
    const double r = body.forearm_radius_m;
    const double x = q.x / (body.torso_half_width_m + r), y = q.y / (body.torso_half_depth_m + r);
    const double e = std::sqrt(x * x + y * y);
    if (e >= 1) return p;
    // On the axis there is no radial direction: out of the front (where hands are held).
    const Vec3 out = e > 1e-6 ? Vec3(q.x / e, q.y / e, q.z) : Vec3(0, body.torso_half_depth_m + r, q.z);
    return l1.neck_world + R * out;
  }

  // Whether p lies inside the other limb of the pair as fitted at t-1 (its own radii): hull there
  // is that limb's, not this one's (legs together, hands crossing).
  bool in_other(int other, const Vec3& p) const {
    const LimbPose& o = last[static_cast<size_t>(other)];
    auto near = [&p](const Vec3& a, const Vec3& b, double r) {
      const Vec3 ab = b - a;
      const double t = std::clamp(glm::dot(p - a, ab) / std::max(1e-12, glm::dot(ab, ab)), 0.0, 1.0);
      const Vec3 dq = p - (a + t * ab);
      return glm::dot(dq, dq) < r * r;
    };
    return near(o.root, o.hinge, body.upper_radius_m(other)) ||
           near(o.hinge, o.end, body.lower_radius_m(other));
  }

  int count_limb_at(int limb, const Vec3& root, const Vec3& end, const Vec3& bend_world) const {
    const LimbPose lp = solve_limb(root, end, body.upper_m(limb), body.lower_m(limb), bend_world);
    return count_limb(limb, lp.root, lp.hinge, lp.end);
  }

  // ---- Layer 2: the method's search for rho (eq. 3) about the previous bend direction, at three
  // stretches of the segment (0, kSlack/2, kSlack: goals near full reach are noisy). ----
  // Returns whether the limb was searched (bent), not kept.
  bool fit_layer2(int limb) {
    const size_t li = static_cast<size_t>(limb);
    const Mat3& F = limb_frame(l1, limb);
    const Vec3 root = limb_root(body, l1, limb), end = l1.end_world[li];
    const double L1 = body.upper_m(limb), L2 = body.lower_m(limb);
    const Vec3 bend_world = F * l2.bend_local[li];
    const LimbPose now = solve_limb(root, end, L1, L2, bend_world);
    const double straight_rad = opt.straight_deg * M_PI / 180;
    l2.slack_m[li] = 0;
    if (now.bend_rad < straight_rad) {  // the method: keep rho(t-1)
      ++limbs[li].straight_frames;
      last[li] = now;
      bend_near_reach(limb, root, end, bend_world);
      return false;
    }
    const Vec3 seg = end - root;
    const double d = glm::length(seg);
    const Vec3 u = seg / d;
    Vec3 e1 = glm::normalize(now.hinge - (root + glm::dot(now.hinge - root, u) * u));
    Vec3 e2 = glm::cross(u, e1);
    auto hinge_of = [&](double dd, double* a, double* h) {
      *a = (L1 * L1 - L2 * L2 + dd * dd) / (2 * dd);
      *h = std::sqrt(std::max(0.0, L1 * L1 - *a * *a));
    };
    auto eval = [&](double a, double h, double dd, double xi) {
      const Vec3 hinge = root + a * u + h * (std::cos(xi) * e1 + std::sin(xi) * e2);
      return count_limb(limb, root, hinge, root + dd * u);
    };
    double a0, h0;
    hinge_of(d, &a0, &h0);
    LimbTrack& track = limbs[li];
    if (track.straight_frames > kStraightForgetFrames) {
      // Bending out of a limb straight for long: rho(t-1) means nothing; the best of the whole circle.
      const int n = 2 * std::max(opt.steps, 12);
      double best_xi = 0;
      int best = -1;
      for (int l = 0; l < n; ++l) {
        const double xi = -M_PI + 2 * M_PI * l / n;
        const int k = eval(a0, h0, d, xi);
        if (k > best || (k == best && std::abs(xi) < std::abs(best_xi))) best = k, best_xi = xi;
      }
      const Vec3 e1n = std::cos(best_xi) * e1 + std::sin(best_xi) * e2;
      e2 = glm::cross(u, e1n);
      e1 = e1n;
    }
    // The method's search (eq. 3) at the goal's distance.
    const double s = opt.span_deg * M_PI / 180;
    const int nu = opt.steps;
    const double step = nu > 1 ? 2 * s / (nu - 1) : s;
    double sum_w = 0, sum_xi = 0, best_xi = 0;
    int best_n = -1;
    for (int l = 0; l < nu; ++l) {
      const double xi = nu == 1 ? 0 : -s + step * l;
      const int k = eval(a0, h0, d, xi);
      if (k > best_n) best_n = k, best_xi = xi;
      const double match = std::pow(static_cast<double>(k), opt.k);
      sum_w += match;
      sum_xi += xi * match;
    }
    double best_rho = sum_w > 0 ? sum_xi / sum_w : 0;
    // The stretches: at that angle and a step either side; one that holds more samples wins.
    double best_slack = 0, prev_a = a0, prev_h = h0;
    for (int c = 1; c <= 2; ++c) {
      const double slack = c * 0.5 * kSlack;
      const double dd = std::min(d + slack, L1 + L2);
      double a, h;
      hinge_of(dd, &a, &h);
      // A bent limb: the stretch moves the hinge by less than half a voxel; nothing to choose.
      if (std::abs(h - prev_h) + std::abs(a - prev_a) < 0.5 * hull.grid().voxel_m) break;
      prev_a = a, prev_h = h;
      for (double xi : {best_rho, best_xi - step, best_xi + step}) {
        const int k = eval(a, h, dd, xi);
        if (k > best_n) best_n = k, best_slack = slack, best_rho = xi;
      }
      if (dd >= L1 + L2) break;  // straight already: more slack changes nothing
    }
    const Vec3 best_e1 = e1;
    Vec3 dir = std::cos(best_rho) * best_e1 + std::sin(best_rho) * e2;
    if (is_arm(limb)) {
      // An elbow inside the torso is never right (arms against the body): the nearest rho that
      // takes it out, when one does.
      const double dd = std::min(d + best_slack, L1 + L2);
      const double a = (L1 * L1 - L2 * L2 + dd * dd) / (2 * dd);
      const double h = std::sqrt(std::max(0.0, L1 * L1 - a * a));
      auto hinge_at = [&](double xi) {
        return root + a * u + h * (std::cos(best_rho + xi) * best_e1 + std::sin(best_rho + xi) * e2);
      };
      if (inside_torso(hinge_at(0))) {
        for (int turn = 1; turn <= 36; ++turn) {
          const double xi = turn * 5 * M_PI / 180;
          const double pick = !inside_torso(hinge_at(xi)) ? xi : !inside_torso(hinge_at(-xi)) ? -xi : 0;
          if (pick != 0) {
            dir = std::cos(best_rho + pick) * best_e1 + std::sin(best_rho + pick) * e2;
            break;
          }
        }
      }
    }
    l2.bend_local[li] = glm::transpose(F) * dir;
    l2.slack_m[li] = best_slack;
    last[li] = solve_limb(root, end, L1, L2, dir, best_slack);
    track.straight_frames = last[li].bend_rad < straight_rad ? track.straight_frames + 1 : 0;
    return true;
  }

  // ---- Near full reach the law of cosines cannot tell the bend: a limb 1 cm short of full reach
  // has its hinge ~5 cm off the root-to-end line (a hanging arm's elbow bent 20 degrees), so 1 cm of
  // error in the measured lengths, the root or the end feature straightens it. There the hull decides:
  // the hinge placed as for a goal 1 to kNearReachSteps cm nearer than the end (the lower segment then
  // reaches the end, that much longer than measured), in kNearReachDirs directions about the segment;
  // the placement with the most samples in the hull wins over the straight limb when it holds more. ----
  void bend_near_reach(int limb, const Vec3& root, const Vec3& end, const Vec3& bend_world) {
    const size_t li = static_cast<size_t>(limb);
    const double L1 = body.upper_m(limb), L2 = body.lower_m(limb);
    const Vec3 seg = end - root;
    const double d = glm::length(seg);
    if (d < 1e-6) return;
    const Vec3 u = seg / d;
    Vec3 e1 = bend_world - glm::dot(bend_world, u) * u;
    if (glm::length(e1) < 1e-6) e1 = glm::cross(u, std::abs(u.z) < 0.9 ? Vec3(0, 0, 1) : Vec3(1, 0, 0));
    e1 = glm::normalize(e1);
    const Vec3 e2 = glm::cross(u, e1);
    int best = count_limb(limb, last[li].root, last[li].hinge, last[li].end);
    if (best == static_cast<int>(samples.size())) return;  // nothing can hold more
    double best_slack = 0;
    Vec3 best_dir(0.0);
    for (int c = 1; c <= kNearReachSteps; ++c) {
      const double dd = std::min(d, L1 + L2) - 0.01 * c;
      if (dd <= std::abs(L1 - L2) + 0.01) break;
      const double a = (L1 * L1 - L2 * L2 + dd * dd) / (2 * dd);
      const double h = std::sqrt(std::max(0.0, L1 * L1 - a * a));
      for (int l = 0; l < kNearReachDirs; ++l) {
        const double xi = 2 * M_PI * l / kNearReachDirs;
        const Vec3 dir = std::cos(xi) * e1 + std::sin(xi) * e2;
        const Vec3 hinge = root + a * u + h * dir;
        // An elbow's centre lies the upper arm's radius off the torso's skin at the least.
        if (is_arm(limb) && inside_torso(hinge, body.upper_arm_radius_m)) continue;
        const int k = count_limb(limb, root, hinge, end);
        if (k > best) best = k, best_slack = dd - d, best_dir = dir;
      }
    }
    if (best_slack >= 0) return;
    l2.bend_local[li] = glm::transpose(limb_frame(l1, limb)) * best_dir;
    l2.slack_m[li] = best_slack;
    last[li] = solve_limb(root, end, L1, L2, best_dir, best_slack);
  }

  // ---- The feet's names from the hull (README, "The feet's names from the hull"): a foot point whose
  // name the triangulation did not trust is put on the leg the hull connects it to. Below the hips a
  // leg is hull connected to its own hip joint: a point on the right leg is nearer the right hip than
  // the left one through the hull by about a hip width (sides.hpp); half a hip width is asked for. On
  // the other leg: a lone point takes that leg's name; two points on one leg, the one named for the
  // other is not a foot this frame (that leg fitted to the hull from its track); two points each on the
  // other's leg are a pair named the wrong way round, taken crosswise for this frame. Nothing is kept
  // from frame to frame: the names are judged again on every frame they are not trusted. ----
  void feet_named_by_hull(FeatureSet* f, std::array<bool, 5>* ok, std::array<double, 5>* conf,
                          const std::array<bool, 5>& trusted) {
    constexpr size_t L = 3, R = 4;
    off_leg = {};
    FeatureSet& p = *f;
    std::array<bool, 5>& k = *ok;
    if (!((k[L] && !trusted[L]) || (k[R] && !trusted[R]))) return;
    Vec3 pts[2];
    int n = 0;
    if (k[L]) pts[n++] = p[L];
    if (k[R]) pts[n++] = p[R];
    const Vec3 hip_l = limb_root(body, l1, static_cast<int>(Limb::l_leg));
    const Vec3 hip_r = limb_root(body, l1, static_cast<int>(Limb::r_leg));
    if (!sides.compute(hull, hip_l, hip_r, pts, n, kSidesPadM)) return;
    const double margin = body.hip_half_width_m;
    const int sl = k[L] ? sides.side(p[L], margin) : 0, sr = k[R] ? sides.side(p[R], margin) : 0;
    const bool l_wrong = k[L] && !trusted[L] && sl > 0, r_wrong = k[R] && !trusted[R] && sr < 0;
    if (!l_wrong && !r_wrong) return;
    ++hull_named_feet;
    if ((l_wrong && k[R] && sr < 0) || (r_wrong && k[L] && sl > 0)) {  // each on the other's leg
      std::swap(p[L], p[R]);
      std::swap((*conf)[L], (*conf)[R]);
      return;
    }
    const size_t wrong = l_wrong ? L : R, other = l_wrong ? R : L;
    if (!k[other]) {  // a lone point: the leg it is on
      p[other] = p[wrong];
      (*conf)[other] = (*conf)[wrong];
      k[other] = true;
    }
    k[wrong] = false;  // both on one leg (or the lone point renamed): no feature for this leg
    off_leg[wrong] = true;
  }

  // The end of a leg whose feature was on the other leg: fitted to the hull from its track's
  // prediction (last end + velocity in the pelvis frame); false when that end is on the other leg.
  bool leg_end_from_track(int limb, const Vec3& root, Vec3* end) const {
    const LimbTrack& t = limbs[static_cast<size_t>(limb)];
    *end = fit_end_to_hull(limb, root, root + limb_frame(l1, limb) * (t.last_local + t.vel_local));
    const int other_side = limb_side(limb) < 0 ? 1 : -1;
    return sides.side(*end, body.hip_half_width_m) != other_side;
  }

  // ---- A foot feature against the leg's hull: one off its leg (a drifting or mislabelled track, a
  // point triangulated from the wrong blobs) leaves the leg's samples outside the hull. Then the leg is
  // fitted to the hull twice, from the feature and from the end its track predicts (last end + velocity
  // in the pelvis frame: a feature far off gives the search nothing to find near it), and the end
  // holding the most samples is taken when it holds kHullBeatsFeature times the feature's. A feature
  // that lies on its leg is kept as it is. ----
  Vec3 foot_checked_against_hull(int limb, const Vec3& root, const Vec3& feature) const {
    const size_t li = static_cast<size_t>(limb);
    const Mat3& F = limb_frame(l1, limb);
    const Vec3 bend = F * l2.bend_local[li];
    const int n_feat = count_limb_at(limb, root, feature, bend);
    if (n_feat >= kFeatureSupport * static_cast<double>(samples.size())) return feature;
    Vec3 best = feature;
    double need = kHullBeatsFeature * n_feat;
    const Vec3 e = fit_end_to_hull(limb, root, feature);
    const int n_e = count_limb_at(limb, root, e, bend);
    if (n_e > need) best = e, need = n_e;
    const LimbTrack& t = limbs[li];
    if (t.have && t.lost == 0) {
      const Vec3 p = fit_end_to_hull(limb, root, root + F * (t.last_local + t.vel_local));
      if (count_limb_at(limb, root, p, bend) > need) best = p;
    }
    return best;
  }

  // ---- A limb without a usable feature: predicted in its root's frame, then fitted to the hull
  // by turning the layer-1 segment up to +-20 degrees about two axes. ----
  Vec3 predict_end(int limb, const Vec3& root) {
    const size_t li = static_cast<size_t>(limb);
    LimbTrack& t = limbs[li];
    const Mat3& F = limb_frame(l1, limb);
    Vec3 local;
    if (t.have) {
      local = t.last_local;
      if (t.lost <= opt.predict_frames) {
        double damp = 0, f = 1;
        for (int i = 0; i < t.lost && i < 30; ++i) damp += (f *= 0.8);
        local += damp * t.vel_local;
      }
    } else {
      const double reach = 0.98 * (body.upper_m(limb) + body.lower_m(limb));
      local = Vec3(0, 0, -reach);  // never seen: arms hanging, legs standing
    }
    return fit_end_to_hull(limb, root, root + F * local);
  }

  // The limb's end fitted to the hull from a guess: the layer-1 segment turned up to +-20 degrees
  // about the root, then the lower segment +-45 degrees about its hinge; the most samples win.
  Vec3 fit_end_to_hull(int limb, const Vec3& root, const Vec3& guess) const {
    const size_t li = static_cast<size_t>(limb);
    const Mat3& F = limb_frame(l1, limb);
    const Vec3 local = glm::transpose(F) * (guess - root);
    const double len = glm::length(local);
    const Vec3 u0 = F * (local / std::max(len, 1e-9));
    const Vec3 any = std::abs(u0.z) < 0.9 ? Vec3(0, 0, 1) : Vec3(1, 0, 0);
    const Vec3 p1 = glm::normalize(glm::cross(u0, any)), p2 = glm::cross(u0, p1);
    const Vec3 bend = F * l2.bend_local[li];
    Vec3 best_end = root + len * u0;
    int best = count_limb_at(limb, root, best_end, bend);
    for (int ia = -2; ia <= 2; ++ia)
      for (int ib = -2; ib <= 2; ++ib) {
        if (ia == 0 && ib == 0) continue;
        const double aa = ia * 10 * M_PI / 180, bb = ib * 10 * M_PI / 180;
        const Vec3 u = glm::normalize(u0 + std::tan(aa) * p1 + std::tan(bb) * p2);
        const Vec3 e = root + len * u;
        const int c = count_limb_at(limb, root, e, bend);
        if (c > best) best = c, best_end = e;
      }
    // Then the lower segment about its hinge (a forearm swings about the elbow): +-45 degrees.
    const LimbPose lp = solve_limb(root, best_end, body.upper_m(limb), body.lower_m(limb), bend);
    const Vec3 w0 = glm::normalize(lp.end - lp.hinge);
    const Vec3 any2 = std::abs(w0.z) < 0.9 ? Vec3(0, 0, 1) : Vec3(1, 0, 0);
    const Vec3 q1 = glm::normalize(glm::cross(w0, any2)), q2 = glm::cross(w0, q1);
    const double L2 = body.lower_m(limb);
    Vec3 end = lp.hinge + L2 * w0;
    best = count_limb(limb, root, lp.hinge, end);
    for (int ia = -3; ia <= 3; ++ia)
      for (int ib = -3; ib <= 3; ++ib) {
        if (ia == 0 && ib == 0) continue;
        const Vec3 w =
            glm::normalize(w0 + std::tan(ia * 15 * M_PI / 180) * q1 + std::tan(ib * 15 * M_PI / 180) * q2);
        const Vec3 e = lp.hinge + L2 * w;
        const int c = count_limb(limb, root, lp.hinge, e);
        if (c > best) best = c, end = e;
      }
    return end;
  }

  void initialize(const InitMeasurement& m, const Vec3& head, pipeline::PoseState* state) {
    body = m.body;
    if (!opt.body.empty()) apply_body_toml(opt.body.string(), &body);
    l1 = Layer1{};
    l1.R_torso_world = m.R_torso_world;
    l1.R_pelvis_world = level_heading(m.R_torso_world);
    l1.neck_world = m.neck_world;
    l1.head_world = head;
    l2 = Layer2{};
    limbs = {};
    have_last = false;
    const Moments mo = segment(l1.neck_world, l1.R_torso_world, 1.0);
    centroid_off_local = mo.n > 0 ? mo.mean_local : Vec3(0, 0, -0.5 * body.spine_m);
    centroid_off_local.x = 0;  // left-right symmetric by definition
    init_torso_voxels = mo.n;
    initialized = true;
    ++body_version;
    failing = 0;
    *state = pipeline::PoseState::Fitted;
  }

  // The performer's right as the features say: from the left to the right foot and hand (level).
  static Vec3 feature_right(const FeatureSet& f, const std::array<bool, 5>& ok, bool hands) {
    Vec3 v(0.0);
    if (ok[3] && ok[4]) v += level(f[4] - f[3]);
    if (hands && ok[1] && ok[2]) v += level(f[2] - f[1]);
    return v;
  }

  // Re-acquire the torso after a failed fit: a wider cylinder below the head, the heading hinted
  // by the feet and hands (else the last one), then a PCA that takes the wider horizontal component
  // for the shoulder line (signed by the hint). Pending until the hull shows a torso.
  void reacquire(const FeatureSet& f, const std::array<bool, 5>& ok, const FeetCue& cue) {
    // The feet on the hull first (they do not depend on the names), else the names.
    Vec3 x = cue.valid ? cue.right() : feature_right(f, ok, true);
    if (glm::length(x) < 0.05) x = level(l1.R_torso_world[0]);
    if (glm::length(x) < 1e-6) x = Vec3(1, 0, 0);
    x = glm::normalize(x);
    const Vec3 z(0, 0, 1);
    const Mat3 R(x, glm::cross(z, x), z);
    const Vec3 neck = ok[0] ? f[0] - Vec3(0, 0, body.neck_to_head_m) : l1.neck_world;
    const Moments m = segment(neck, R, 1.3);
    reacquire_pending = m.n < std::max(30.0, 0.3 * init_torso_voxels);
    l1.R_torso_world = reacquire_pending ? R : pca(m, R, true);
    l1.R_pelvis_world = level_heading(l1.R_torso_world);
    l1.neck_world = neck;
    l2 = Layer2{};
    limbs = {};
    have_last = false;
    ++body_version;
    failing = 0;
    yaw_rate = 0;
    turn_candidate_frames = 0;
    heading_vote.reset();
  }

  // The torso turned round (the feet said so): the limbs' histories are in the old frame and on
  // the wrong sides, so they start again as after a re-acquisition.
  void turn_round(Mat3* R) {
    *R = turned_round(*R);
    l2 = Layer2{};
    limbs = {};
    have_last = false;
    turn_candidate_frames = 0;
    ++heading_flips;
  }
};

Fitter::Fitter(const config::RigConfig& rig) : Fitter(rig.grid, rig.fitting, rig.trigger.rate_hz) {}
Fitter::Fitter(const rig::VoxelGrid& grid, const config::FittingOptions& options, double rate_hz)
    : s_(std::make_unique<State>(grid, options, rate_hz)) {}
Fitter::~Fitter() = default;

void Fitter::reset() {
  s_->reset();
}
bool Fitter::initialized() const {
  return s_->initialized;
}
const BodyModel& Fitter::body() const {
  return s_->body;
}
const Layer1& Fitter::layer1() const {
  return s_->l1;
}
const Layer2& Fitter::layer2() const {
  return s_->l2;
}
const StageTimes& Fitter::times() const {
  return s_->times;
}
int Fitter::failing_frames() const {
  return s_->failing;
}
const std::array<uint64_t, 2>& Fitter::pair_swaps() const {
  return s_->swaps;
}
bool Fitter::pair_swapped(int pair) const {
  return s_->swapped.at(static_cast<size_t>(pair));
}

uint64_t Fitter::late_frames() const {
  return late_frames_;
}
uint64_t Fitter::heading_flips() const {
  return s_->heading_flips;
}

uint64_t Fitter::hull_named_feet() const {
  return s_->hull_named_feet;
}

pipeline::Pose Fitter::fit(const pipeline::Frame& frame) {
  if (!s_->have_seq || frame.seq >= s_->last_seq) return fit_next(frame);
  // A frame older than the last one fitted: the assembler passes a complete frame on at once while an
  // older one waits for a late node until its deadline. It is fitted from a copy of the history as it
  // stands, which is then put back, so the history (t-1, the turn rate, the filters, the pairs' naming)
  // only goes forward and the frame still gets its pose. A copy per such frame: they are rare.
  auto history = std::make_unique<State>(*s_);
  pipeline::Pose pose = fit_next(frame);
  history->times = s_->times;
  s_ = std::move(history);
  ++late_frames_;
  return pose;
}

pipeline::Pose Fitter::fit_next(const pipeline::Frame& frame) {
  State& s = *s_;
  const uint64_t t0 = monotonic_ns();
  s.times = StageTimes{};
  pipeline::Pose pose;
  pose.body_version = s.body_version;
  auto finish = [&](pipeline::Pose& p) {
    p.t_fitted_ns = monotonic_ns();
    s.times.total_ns = p.t_fitted_ns - t0;
    return p;
  };
  if (!frame.merged || frame.rle.empty() || !s.hull.decode(frame.rle)) return finish(pose);
  const uint64_t t1 = monotonic_ns();
  s.times.decode_ns = t1 - t0;

  // The features (feature id order: head, left hand, right hand, left foot, right foot).
  FeatureSet f{};
  std::array<bool, 5> ok{};
  std::array<double, 5> conf{};
  std::array<bool, 5> trusted{true, true, true, true, true};  // the names the triangulation trusted
  for (const pipeline::Feature3D& ft : frame.features3d) {
    if (ft.feature_id >= 5 || ft.state != pipeline::Feature3DState::Triangulated) continue;
    if (!(ft.confidence >= kMinFeatureConfidence)) continue;
    const Vec3 p(ft.p_world[0], ft.p_world[1], ft.p_world[2]);
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    f[ft.feature_id] = p;
    ok[ft.feature_id] = true;
    conf[ft.feature_id] = std::min(1.0, static_cast<double>(ft.confidence));
    trusted[ft.feature_id] = ft.name_trusted;
  }

  // A pair taken crosswise (README: "A pair named the wrong way round"): the left limb gets the
  // right feature and the other way round, until continuity says otherwise.
  auto swap_pair = [&f, &ok, &conf, &trusted](int pair) {
    const size_t a = 1 + 2 * static_cast<size_t>(pair), b = a + 1;
    std::swap(f[a], f[b]);
    std::swap(ok[a], ok[b]);
    std::swap(conf[a], conf[b]);
    std::swap(trusted[a], trusted[b]);
  };
  for (int pair = 0; pair < 2; ++pair)
    if (s.swapped[static_cast<size_t>(pair)]) swap_pair(pair);
  // Where the feet point on the hull: the heading cue that does not come from the names.
  const FeetCue cue = feet_forward(s.hull, f, ok);

  pipeline::PoseState state = pipeline::PoseState::Fitted;
  if (!s.initialized) {
    ++s.uninit_frames;
    if (ok[0] && ok[1] && ok[2] && ok[3] && ok[4] && looks_like_init_pose(f)) {
      if (auto m = measure_init_frame(s.hull, f)) s.init_meas.push_back(*m);
    }
    if (static_cast<int>(s.init_meas.size()) >= s.opt.init_frames) {
      s.initialize(combine_measurements(s.init_meas), f[0], &state);
      s.init_meas.clear();
    } else if (s.uninit_frames >= std::max(4 * s.opt.init_frames, 120) && ok[0]) {
      // No initialization pose seen: average proportions scaled to the head's height.
      InitMeasurement m;
      const double top = f[0].z + 0.115 * f[0].z / 1.635;
      m.body = proportional_body(top);
      const Vec3 z(0, 0, 1);
      Vec3 x(1, 0, 0);
      if (cue.valid)
        x = cue.right();
      else if (ok[3] && ok[4] && glm::length(level(f[4] - f[3])) > 0.1)
        x = glm::normalize(level(f[4] - f[3]));
      m.R_torso_world = Mat3(x, glm::cross(z, x), z);
      m.neck_world = f[0] - Vec3(0, 0, m.body.neck_to_head_m);
      s.initialize(m, f[0], &state);
      s.reacquire(f, ok, cue);
      state = pipeline::PoseState::Fitted;
      --s.body_version;  // reacquire counted one more
    }
    if (!s.initialized) return finish(pose);
  }

  // ---- Torso segmentation and PCA (8.2), the cylinder as at t-1 moved with the head. ----
  Layer1& l1 = s.l1;
  const BodyModel& b = s.body;
  const Vec3 shift = ok[0] && s.have_head ? f[0] - s.last_head : Vec3(0.0);
  const Vec3 neck_pred = l1.neck_world + shift;
  // The torso frame as predicted for this frame: the last one turned on about the vertical.
  const double cy = std::cos(s.yaw_rate), sy = std::sin(s.yaw_rate);
  // Re-acquiring (the hull had no torso when the fit was re-initialized): the feet on the hull, when
  // they tell, hint the heading the free PCA is signed by, not the names it was re-initialized with.
  const Mat3 R_pred = s.reacquire_pending && cue.valid
                          ? Mat3(cue.right(), cue.forward, Vec3(0, 0, 1))
                          : Mat3(Vec3(cy, sy, 0), Vec3(-sy, cy, 0), Vec3(0, 0, 1)) * l1.R_torso_world;
  const Moments mo = s.segment(neck_pred, R_pred, 1.0);
  const uint64_t t2 = monotonic_ns();
  s.times.segment_ns = t2 - t1;
  const bool torso_ok = mo.n >= std::max(30.0, 0.3 * s.init_torso_voxels);
  // A large turn's witnesses: the names, and the feet on the hull when they tell.
  Mat3 R = torso_ok ? s.pca(mo, R_pred, s.reacquire_pending, State::feature_right(f, ok, true),
                            cue.valid ? cue.right() : Vec3(0.0))
                    : R_pred;
  {  // the turn rate: this frame's turn of the level heading, smoothed; bounded by what is believed
    const Vec3 a = level(l1.R_torso_world[0]), c = level(R[0]);
    const double turn = std::atan2(glm::cross(a, c).z, glm::dot(a, c));
    const double lim = kMaxTurnRateDeg * M_PI / 180;
    // Only a measured heading tells the rate (a kept one would only repeat the prediction): without one
    // the rate fades.
    if (!torso_ok || s.reacquire_pending)
      s.yaw_rate = 0;
    else if (s.heading_measured)
      s.yaw_rate = std::clamp((1 - kYawRateGain) * s.yaw_rate + kYawRateGain * turn, -lim, lim);
    else
      s.yaw_rate *= 1 - kYawRateGain;
  }
  if (torso_ok) s.reacquire_pending = false;
  // The torso's sign against the feet (README, "The heading from the body"): turned round when they
  // point clearly behind it for several frames.
  if (torso_ok && s.heading_vote.update(R, cue)) s.turn_round(&R);
  const uint64_t t3 = monotonic_ns();
  s.times.pca_ns = t3 - t2;

  // ---- Layer 1 (8.3): the neck on the torso's axis below the head; ends from the features. ----
  const Vec3 z = R[2];
  const Vec3 centroid = neck_pred + R_pred * mo.mean_local;
  Vec3 neck;
  if (torso_ok) {
    const Vec3 axis_pt = centroid - R * Vec3(s.centroid_off_local.x, s.centroid_off_local.y, 0);
    const Vec3 neck_from = ok[0] ? f[0] - Vec3(0, 0, b.neck_to_head_m) : centroid - R * s.centroid_off_local;
    neck = axis_pt + glm::dot(neck_from - axis_pt, z) * z;
  } else {
    neck = ok[0] ? f[0] - Vec3(0, 0, b.neck_to_head_m) : neck_pred;
  }
  const Vec3 head = ok[0] ? f[0] : neck + (l1.head_world - l1.neck_world);
  l1.R_torso_world = R;
  l1.R_pelvis_world = s.pelvis_frame(R);
  l1.neck_world = neck;
  l1.head_world = head;
  if (ok[0]) {
    s.last_head = f[0];
    s.have_head = true;
  }
  // The feet's untrusted names checked against the legs the hull connects them to.
  s.feet_named_by_hull(&f, &ok, &conf, trusted);
  // Each pair's features against its limbs' paths: the ends predicted from the last frame (in the
  // root's frame, so the body's own motion and turn are followed); when the features fit the two paths
  // crosswise clearly better (kSwapMargin), the pair's naming changed (the triangulation named them the
  // wrong way round, or stopped doing so): the assignment is swapped, and counted.
  for (int pair = 0; pair < 2; ++pair) {
    const int la = 2 * pair, lb = la + 1;
    const size_t fa = static_cast<size_t>(la) + 1, fb = fa + 1;
    const LimbTrack &ta = s.limbs[static_cast<size_t>(la)], &tb = s.limbs[static_cast<size_t>(lb)];
    if (!ok[fa] || !ok[fb] || !ta.have || !tb.have) continue;
    const Mat3& F = limb_frame(l1, la);
    const Vec3 pa = limb_root(b, l1, la) + F * (ta.lost == 0 ? ta.last_local + ta.vel_local : ta.last_local);
    const Vec3 pb = limb_root(b, l1, lb) + F * (tb.lost == 0 ? tb.last_local + tb.vel_local : tb.last_local);
    const double keep = glm::length(f[fa] - pa) + glm::length(f[fb] - pb);
    const double cross = glm::length(f[fa] - pb) + glm::length(f[fb] - pa);
    if (s.opt.follow_pair_swaps && ta.lost == 0 && tb.lost == 0 && cross + kSwapMargin < keep) {
      swap_pair(pair);
      s.swapped[static_cast<size_t>(pair)] = !s.swapped[static_cast<size_t>(pair)];
      ++s.swaps[static_cast<size_t>(pair)];
    } else if (glm::length(f[fa] - f[fb]) < kOnePointM && glm::length(pa - pb) > kOnePointApartM) {
      // Both features on one point while the limbs' paths are apart: one of them took the other's
      // hand (foot). The one further from its own path is wrong: taken as lost for this frame.
      const size_t wrong = glm::length(f[fa] - pa) > glm::length(f[fb] - pb) ? fa : fb;
      ok[wrong] = false;
      ++s.one_point_frames;
    }
  }
  bool predicted = !ok[0];
  for (int limb = 0; limb < kLimbCount; ++limb) {
    const size_t li = static_cast<size_t>(limb);
    const Vec3 root = limb_root(b, l1, limb);
    const Mat3& F = limb_frame(l1, limb);
    const double reach = b.upper_m(limb) + b.lower_m(limb);
    LimbTrack& t = s.limbs[li];
    // A hand feature deep inside the torso (a track on the shirt, or a point triangulated from two
    // hands) is never a wrist: taken as lost.
    const bool good = ok[li + 1] && glm::length(f[li + 1] - root) <= 1.3 * reach + 0.05 &&
                      !(is_arm(limb) && s.deep_in_torso(f[li + 1]));
    // A leg whose feature the hull put on the other leg (README, "The feet's names from the hull"):
    // fitted to the hull from its track, which goes on following it, unless that end is on the other
    // leg too (the track had followed the wrong name): then lost.
    Vec3 from_track(0.0);
    const bool on_track =
        !good && s.off_leg[li + 1] && t.have && t.lost == 0 && s.leg_end_from_track(limb, root, &from_track);
    if (good || on_track) {
      // A foot feature checked against the leg's hull (README, "A foot feature off its leg"). Not the
      // arms: near the torso or the other arm few of their samples count, and the check moved correct
      // wrists (README).
      const Vec3 end = on_track       ? from_track
                       : is_arm(limb) ? f[li + 1]
                                      : s.foot_checked_against_hull(limb, root, f[li + 1]);
      predicted = predicted || on_track;
      const Vec3 local = glm::transpose(F) * (end - root);
      t.vel_local = t.have && t.lost == 0 ? 0.5 * t.vel_local + 0.5 * (local - t.last_local) : Vec3(0.0);
      t.last_local = local;
      t.have = true;
      t.lost = 0;
      l1.end_world[li] = end;
    } else {
      ++t.lost;
      predicted = true;
      l1.end_world[li] = s.predict_end(limb, root);
    }
    // A wrist is never inside the torso (README, "Arms touching the torso").
    if (is_arm(limb)) l1.end_world[li] = s.out_of_torso(l1.end_world[li]);
  }
  const uint64_t t4 = monotonic_ns();
  s.times.layer1_ns = t4 - t3;

  // ---- Layer 2 (8.4). ----
  uint64_t tl = t4;
  for (int limb = 0; limb < kLimbCount; ++limb) {
    s.times.layer2_searched[static_cast<size_t>(limb)] = s.fit_layer2(limb);
    const uint64_t t = monotonic_ns();
    s.times.layer2_ns[static_cast<size_t>(limb)] = t - tl;
    tl = t;
  }

  s.have_last = true;

  // ---- The pose, its confidence, and whether the fit failed. ----
  const std::array<Vec3, pipeline::kPoseJointCount> joints = forward_kinematics(b, l1, s.l2);
  int hits = 0;
  for (int limb = 0; limb < kLimbCount; ++limb) {
    const size_t li = static_cast<size_t>(limb);
    hits += s.count_limb(limb, s.last[li].root, s.last[li].hinge, s.last[li].end);
  }
  const double support = hits / (4.0 * static_cast<double>(s.pattern.samples.size()));
  double feat = 0;
  for (int i = 0; i < 5; ++i) feat += ok[static_cast<size_t>(i)] ? conf[static_cast<size_t>(i)] : 0;
  feat /= 5;
  double confidence = 0.5 * feat + 0.5 * support;
  if (!torso_ok) confidence *= 0.5;
  const bool head_far = ok[0] && glm::length(f[0] - neck) > b.neck_to_head_m + 0.25;
  // A heading turned the wrong way: the torso facing away from where the feet point on the hull. Without
  // that cue no verdict: the feet's names come from this torso's right (README, "Turning round").
  const bool heading_wrong = cue.valid && faces_away(R, cue);
  // The trunk off the hull (failure.hpp): a torso the PCA tilted or turned away from the body. Only
  // where the cylinder held a torso: a hull without one is the check above's (no body to be off).
  const bool trunk_off = torso_ok && trunk_off_hull(trunk_in_hull(s.hull, joints));
  const bool failed = !torso_ok || support < 0.3 || head_far || heading_wrong || trunk_off;
  s.failing = failed ? s.failing + 1 : 0;
  s.trunk_off = ((s.trunk_off << 1) | (trunk_off ? 1u : 0u)) & ((1u << kTrunkOffHullWindow) - 1);
  if (s.failing >= s.opt.reinit_after_frames || std::popcount(s.trunk_off) >= kTrunkOffHullFrames) {
    s.reacquire(f, ok, cue);
    s.trunk_off = 0;
    state = pipeline::PoseState::Reinitialized;
  } else if (predicted) {
    state = pipeline::PoseState::Predicted;
  }

  // Output (optionally One-Euro smoothed).
  double dt = 1.0 / s.rate_hz;
  if (s.have_seq && frame.seq > s.last_seq) dt = static_cast<double>(frame.seq - s.last_seq) / s.rate_hz;
  s.have_seq = true;
  s.last_seq = frame.seq;
  for (int j = 0; j < pipeline::kPoseJointCount; ++j)
    for (int c = 0; c < 3; ++c) {
      double v = joints[static_cast<size_t>(j)][c];
      if (s.opt.smoothing == config::Smoothing::OneEuro)
        v = s.euro[3 * static_cast<size_t>(j) + static_cast<size_t>(c)].filter(
            v, dt, s.opt.one_euro_min_cutoff, s.opt.one_euro_beta);
      pose.p_world[static_cast<size_t>(j)][static_cast<size_t>(c)] = v;
    }
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      pose.torso_R_world[3 * static_cast<size_t>(r) + static_cast<size_t>(c)] = R[c][r];
  pose.state = state;
  pose.body_version = s.body_version;
  pose.confidence = static_cast<float>(std::clamp(confidence, 0.0, 1.0));
  return finish(pose);
}

void FitStage::configure(const pipeline::StageContext& ctx) {
  if (!ctx.rig) throw std::invalid_argument("fit: no rig configuration");
  fitter_ = std::make_unique<Fitter>(*ctx.rig);
  heading_ = ctx.body_heading;
}

void FitStage::process(pipeline::Frame& frame) {
  frame.pose = fitter_->fit(frame);
  publish_heading(frame.pose, frame.seq, heading_.get());
}

void publish_heading(const pipeline::Pose& pose, uint64_t seq, pipeline::BodyHeading* heading) {
  if (!heading || pose.state != pipeline::PoseState::Fitted) return;
  const std::array<double, 9>& R = pose.torso_R_world;  // row-major, columns the performer's axes
  heading->publish(seq, {R[0], R[3], R[6]});
}

}  // namespace vc::fit
