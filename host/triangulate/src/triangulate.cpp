// Robust multi-view triangulation and the left/right agreement (host/triangulate/README.md).
//
// One point (triangulate_point). Every view's pixel is undistorted to normalized coordinates x_i
// (cv::undistortPoints with the camera's K and k1 k2 p1 p2 k3). The linear (DLT) solution of
// X ~ [R_i | t_i] X for views i is the right singular vector of the stacked rows
// w_i (x_i P_i3 - P_i1), w_i (y_i P_i3 - P_i2) (Hartley & Zisserman, Multiple View Geometry, 12.2).
// Outliers: every pair of views gives a two-view DLT hypothesis (exhaustive: n(n-1)/2 <= 28 for eight
// cameras, so no random sampling is needed); a view agrees with a hypothesis when the point is in
// front of it and reprojects (with distortion, Camera::project) within inlier_px of its pixel. The
// hypothesis with the most agreeing views wins (ties: the smaller sum of their errors); the point is
// re-solved by weighted DLT over them and refined by Gauss-Newton on the weighted reprojection error
// in normalized coordinates scaled by the focal length (Levenberg-damped, a few steps), and the set of
// agreeing views is taken once more around the refined point. Fewer than two agreeing views: no point.
//
// A pair of features (hands, feet). The edges name a hand by the image side it is on, so a camera
// behind the performer calls the left hand "right_hand", and one that sees the hands cross swaps its
// labels for that time. The labels are therefore dropped: each camera's one or two observations of
// the pair are unlabelled candidates. Point A is the hypothesis (a pair of cameras, one candidate of
// each) that the most cameras agree with; its candidates are taken out and point B is found the same
// way among the rest. A and B are then named in 3D:
//   - while the pair is followed, by continuity: the assignment of A, B to the last left and right
//     positions (extrapolated at constant velocity over one frame) with the smaller summed distance;
//     when both assignments cost about the same while A and B are far apart (or the naming is not
//     trusted), the cameras' kept swaps vote (confirm or correct), and without a vote it is untrusted;
//     Feet only: a point beyond a side's gate (how far a foot moves since it was last seen) is not
//     that side, and a point beside the other foot is dropped rather than named; with one point seen,
//     a point away from where a foot stands still (planted) is the other foot, and a lone foot named by
//     continuity is reported untrusted unless the cameras' kept swaps vote for its name;
//   - when the pair is named afresh (the first frame, or both sides unseen for identity_gap_frames),
//     by the cameras' kept swaps when at least two cameras whose swap is decided agree, else by the
//     initialization rule: the performer faces the front cameras, left = up x facing, so the point
//     further along that direction (from the other point, or from the head) is the left.
// Then the body's right (the fit's torso right, set_body_right; feet only while apart more sideways
// than fore-aft, a stride being turned sideways by the heading's error): names that put the right point more
// than a margin to the left of the left one for kBodyRenameFrames frames in a row are swapped, names
// that agree by more than the margin are trusted (README, "The body's right").
// Then each camera's swap is re-decided where its two candidates fit the named points clearly better
// one way than the other (error ratio below swap_ratio); otherwise it keeps the swap it had.
//
// Limits: one performer; a pair's two points must be seen by two cameras each; the initialization rule
// needs the performer to face the front cameras when the pair is first named.
#include "voxcap/triangulate/triangulate.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include <opencv2/calib3d.hpp>

#include "voxcap/proto.h"

namespace vc::triangulate {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kUncertainCap = 0.45;  // confidence of a point whose left/right naming is not trusted
// The body's right (README, "The body's right"): a pair's two points count as on their sides when
// they are this far apart along it (metres; hands: farther than crossed forearms reach, feet: the
// init pose's stance is 15-25 cm), and names that contradict it this many frames in a row are swapped.
constexpr double kBodyApartHandsM = 0.30;
constexpr double kBodyApartFeetM = 0.08;
constexpr int kBodyRenameFrames = 8;
// The body's right turned by more than this from one given value to the next (degrees) turned round
// at once: a body turns at most ~3 degrees a frame, ~90 over the 30 frames a heading may be old; a
// fit whose torso sign flipped (a re-initialization, the heading vote) turns it by ~180.
constexpr double kBodyTurnedRoundDeg = 135;
// Continuity's gate (README, "Left and right"): a point farther than this from a side's prediction
// (metres, plus the per-frame allowance for each frame the side went unseen) is not that side. A foot
// or hand moves at most ~10 m/s, 17 cm a frame at 60 Hz.
constexpr double kGateM = 0.25;
constexpr double kGatePerFrameM = 0.10;
// A planted foot (README, "Left and right"): seen kPlantedFrames more times within kStillM of where it
// stands (the mean of those positions, metres; the feet's points scatter by ~5 cm); a single point
// farther than kPlantedAwayM from it is the other foot.
constexpr int kPlantedFrames = 3;
constexpr double kStillM = 0.06;
constexpr double kPlantedAwayM = 0.12;

struct Prepared {
  const rig::Camera* cam = nullptr;
  cv::Vec2d xn;  // undistorted normalized coordinates
  double w = 1;
  double f = 1;  // mean focal length, pixels
};

Prepared prepare(const std::vector<rig::Camera>& cameras, const View& v) {
  if (v.camera < 0 || static_cast<size_t>(v.camera) >= cameras.size())
    throw std::invalid_argument("triangulate: camera index " + std::to_string(v.camera) +
                                " is not in the rig");
  const rig::Camera& c = cameras[static_cast<size_t>(v.camera)];
  std::vector<cv::Point2d> in{v.uv_px}, out;
  cv::undistortPoints(in, out, cv::Mat(c.K), cv::Mat(c.dist));
  Prepared p;
  p.cam = &c;
  p.xn = cv::Vec2d(out[0].x, out[0].y);
  p.w = std::max(v.weight, 1e-3);
  p.f = 0.5 * (c.K(0, 0) + c.K(1, 1));
  return p;
}

std::optional<cv::Vec3d> dlt(const std::vector<Prepared>& views, const std::vector<int>& use) {
  cv::Mat A(static_cast<int>(2 * use.size()), 4, CV_64F);
  int r = 0;
  for (int i : use) {
    const Prepared& p = views[static_cast<size_t>(i)];
    const cv::Matx33d& R = p.cam->R_cam_from_world;
    const cv::Vec3d& t = p.cam->t_cam_from_world;
    for (int k = 0; k < 2; ++k) {
      const double x = p.xn[k];
      for (int j = 0; j < 3; ++j) A.at<double>(r, j) = p.w * (x * R(2, j) - R(k, j));
      A.at<double>(r, 3) = p.w * (x * t[2] - t[k]);
      ++r;
    }
  }
  cv::Mat w, u, vt;
  cv::SVD::compute(A, w, u, vt, cv::SVD::FULL_UV);
  const double h = vt.at<double>(3, 3);
  if (std::abs(h) < 1e-12) return std::nullopt;  // a point at infinity: parallel rays
  cv::Vec3d X(vt.at<double>(3, 0) / h, vt.at<double>(3, 1) / h, vt.at<double>(3, 2) / h);
  if (!std::isfinite(X[0]) || !std::isfinite(X[1]) || !std::isfinite(X[2])) return std::nullopt;
  return X;
}

// Distorted pixel reprojection error, or +inf behind the camera.
double reproj_error(const Prepared& p, const cv::Point2d& uv, const cv::Vec3d& X) {
  if (p.cam->to_cam(X)[2] <= 1e-6) return std::numeric_limits<double>::infinity();
  const cv::Point2d q = p.cam->project(X);
  return std::hypot(q.x - uv.x, q.y - uv.y);
}

cv::Vec3d refine(const std::vector<Prepared>& views, const std::vector<int>& use, cv::Vec3d X,
                 int iterations) {
  double lambda = 1e-3;
  auto cost = [&](const cv::Vec3d& P) {
    double c = 0;
    for (int i : use) {
      const Prepared& p = views[static_cast<size_t>(i)];
      const cv::Vec3d xc = p.cam->to_cam(P);
      if (xc[2] <= 1e-6) return std::numeric_limits<double>::infinity();
      const double ex = p.f * (xc[0] / xc[2] - p.xn[0]), ey = p.f * (xc[1] / xc[2] - p.xn[1]);
      c += p.w * (ex * ex + ey * ey);
    }
    return c;
  };
  double c0 = cost(X);
  for (int it = 0; it < iterations && std::isfinite(c0); ++it) {
    cv::Matx33d H = cv::Matx33d::zeros();
    cv::Vec3d g(0, 0, 0);
    for (int i : use) {
      const Prepared& p = views[static_cast<size_t>(i)];
      const cv::Matx33d& R = p.cam->R_cam_from_world;
      const cv::Vec3d xc = p.cam->to_cam(X);
      const double z = xc[2];
      const double rx = p.f * (xc[0] / z - p.xn[0]), ry = p.f * (xc[1] / z - p.xn[1]);
      for (int k = 0; k < 2; ++k) {
        const double res = k == 0 ? rx : ry;
        cv::Vec3d J;
        for (int j = 0; j < 3; ++j) J[j] = p.f * (R(k, j) / z - xc[k] * R(2, j) / (z * z));
        H += p.w * (J * J.t());
        g += p.w * res * J;
      }
    }
    bool improved = false;
    for (int tries = 0; tries < 5 && !improved; ++tries) {
      cv::Matx33d Hd = H;
      for (int j = 0; j < 3; ++j) Hd(j, j) *= 1 + lambda;
      cv::Vec3d step;
      if (!cv::solve(Hd, -g, step, cv::DECOMP_CHOLESKY)) break;
      const cv::Vec3d Xn = X + step;
      const double c1 = cost(Xn);
      if (c1 < c0) {
        X = Xn;
        improved = true;
        c0 = c1;
        lambda = std::max(lambda * 0.1, 1e-9);
      } else {
        lambda *= 10;
      }
    }
    if (!improved) break;
  }
  return X;
}

double widest_angle(const std::vector<Prepared>& views, const std::vector<int>& use, const cv::Vec3d& X) {
  double best = 0;
  for (size_t a = 0; a < use.size(); ++a)
    for (size_t b = a + 1; b < use.size(); ++b) {
      const cv::Vec3d da = cv::normalize(views[static_cast<size_t>(use[a])].cam->center_world() - X);
      const cv::Vec3d db = cv::normalize(views[static_cast<size_t>(use[b])].cam->center_world() - X);
      best = std::max(best, std::acos(std::clamp(da.dot(db), -1.0, 1.0)));
    }
  return best;
}

// The views within inlier_px of X, and the sum of their errors.
std::vector<int> agreeing(const std::vector<Prepared>& prepared, const std::vector<View>& views,
                          const cv::Vec3d& X, double inlier_px, double* sum) {
  std::vector<int> in;
  *sum = 0;
  for (size_t i = 0; i < views.size(); ++i) {
    const double e = reproj_error(prepared[i], views[i].uv_px, X);
    if (e < inlier_px) {
      in.push_back(static_cast<int>(i));
      *sum += e;
    }
  }
  return in;
}

}  // namespace

double confidence(double mean_weight, int used, int reported, double rms_px, double widest_angle_rad,
                  const Options& options) {
  if (used < 2 || reported < used) return 0;
  const double count = used == 2 ? 0.5 : used == 3 ? 0.85 : 1.0;
  const double agreement = std::sqrt(static_cast<double>(used) / reported);
  const double sigma = options.inlier_px / 2;
  const double fit = std::exp(-0.5 * (rms_px / sigma) * (rms_px / sigma));
  const double geometry = std::min(1.0, widest_angle_rad / (20.0 * kPi / 180.0));
  return std::clamp(mean_weight, 0.0, 1.0) * count * agreement * fit * geometry;
}

bool off_the_body(const HullMap* hull, const cv::Vec3d& p) {
  if (!hull || !hull->on()) return false;
  const double margin = kHullMarginVoxels * hull->grid().voxel_m;
  return hull->clearance(p, margin) > margin;
}

PointResult triangulate_point(const std::vector<rig::Camera>& cameras, const std::vector<View>& views,
                              const Options& options, const HullMap* hull) {
  PointResult res;
  if (views.size() < 2) return res;
  std::vector<Prepared> prepared;
  prepared.reserve(views.size());
  for (const View& v : views) prepared.push_back(prepare(cameras, v));

  std::vector<int> best;
  double best_sum = std::numeric_limits<double>::infinity();
  for (size_t a = 0; a < views.size(); ++a)
    for (size_t b = a + 1; b < views.size(); ++b) {
      const std::optional<cv::Vec3d> X = dlt(prepared, {static_cast<int>(a), static_cast<int>(b)});
      if (!X || off_the_body(hull, *X)) continue;  // not the body: a ghost of two views
      double sum = 0;
      std::vector<int> in = agreeing(prepared, views, *X, options.inlier_px, &sum);
      if (in.size() > best.size() || (in.size() == best.size() && sum < best_sum)) {
        best = std::move(in);
        best_sum = sum;
      }
    }
  if (best.size() < 2) return res;

  cv::Vec3d X;
  for (int round = 0; round < 2; ++round) {
    const std::optional<cv::Vec3d> X0 = dlt(prepared, best);
    if (!X0) return res;
    X = refine(prepared, best, *X0, options.refine_iterations);
    double sum = 0;
    std::vector<int> in = agreeing(prepared, views, X, options.inlier_px, &sum);
    if (in == best) break;
    if (in.size() < 2) return res;
    best = std::move(in);
  }
  double sq = 0, wsum = 0;
  for (int i : best) {
    const double e = reproj_error(prepared[static_cast<size_t>(i)], views[static_cast<size_t>(i)].uv_px, X);
    if (!std::isfinite(e) || e >= options.inlier_px) return res;  // the last round moved the point away
    sq += e * e;
    wsum += std::clamp(views[static_cast<size_t>(i)].weight, 0.0, 1.0);
  }
  res.ok = true;
  res.p_world = X;
  res.inliers = best;
  res.rms_px = std::sqrt(sq / static_cast<double>(best.size()));
  res.confidence =
      confidence(wsum / static_cast<double>(best.size()), static_cast<int>(best.size()),
                 static_cast<int>(views.size()), res.rms_px, widest_angle(prepared, best, X), options);
  return res;
}

// ---- FeatureTriangulator ----

FeatureTriangulator::FeatureTriangulator(std::vector<rig::Camera> cameras, std::vector<int> front_cameras,
                                         Options options)
    : cameras_(std::move(cameras)), front_(std::move(front_cameras)), opt_(options) {
  std::string why;
  if (!opt_.valid(&why)) throw std::invalid_argument("triangulation: " + why);
  for (int c : front_)
    if (c < 0 || static_cast<size_t>(c) >= cameras_.size())
      throw std::invalid_argument("triangulation: front camera " + std::to_string(c) + " is not in the rig");
  swap_.assign(cameras_.size(), {-1, -1});
}

int FeatureTriangulator::swapped(int camera, Pair pair) const {
  if (camera < 0 || static_cast<size_t>(camera) >= swap_.size()) return -1;
  return swap_[static_cast<size_t>(camera)][static_cast<size_t>(pair)];
}

bool FeatureTriangulator::usable(const Observation& o) const {
  return o.present && (o.state == VC_FEATURE_TRACKING || o.state == VC_FEATURE_PREDICTED) &&
         o.confidence > opt_.min_confidence && std::isfinite(o.uv_px.x) && std::isfinite(o.uv_px.y) &&
         std::abs(o.uv_px.x) < 1e6 && std::abs(o.uv_px.y) < 1e6;
}

double FeatureTriangulator::view_weight(const Observation& o) const {
  return std::clamp(o.confidence, 0.0, 1.0) * (o.state == VC_FEATURE_PREDICTED ? opt_.predicted_weight : 1.0);
}

namespace {

void fill(pipeline::Feature3D* f, const PointResult& r, const std::vector<View>& views, int reported) {
  if (reported < 2) {
    f->state = pipeline::Feature3DState::TooFewViews;
    return;
  }
  if (!r.ok) {
    f->state = pipeline::Feature3DState::Inconsistent;
    return;
  }
  f->state = pipeline::Feature3DState::Triangulated;
  f->p_world = {r.p_world[0], r.p_world[1], r.p_world[2]};
  f->confidence = static_cast<float>(r.confidence);
  f->reproj_px = static_cast<float>(r.rms_px);
  f->views.clear();
  for (int i : r.inliers) f->views.push_back(static_cast<uint16_t>(views[static_cast<size_t>(i)].camera));
  std::sort(f->views.begin(), f->views.end());
}

}  // namespace

std::array<pipeline::Feature3D, 5> FeatureTriangulator::process(const std::vector<CameraObservations>& frame,
                                                                const HullMap* hull) {
  seen_ = hull && hull->on() ? hull : nullptr;
  hull_ = hull_rule_ ? seen_ : nullptr;
  reject_ = hull_reject_ ? hull_ : nullptr;
  std::array<pipeline::Feature3D, 5> out;
  for (size_t i = 0; i < out.size(); ++i) out[i].feature_id = static_cast<uint16_t>(i);
  ++frames_;

  std::vector<View> head_views;
  for (const CameraObservations& c : frame) {
    if (c.camera < 0 || static_cast<size_t>(c.camera) >= cameras_.size()) continue;
    const Observation& o = c.features[VC_FEATURE_HEAD];
    if (usable(o)) head_views.push_back({c.camera, o.uv_px, view_weight(o)});
  }
  const PointResult head = triangulate_point(cameras_, head_views, opt_, reject_);
  fill(&out[VC_FEATURE_HEAD], head, head_views, static_cast<int>(head_views.size()));
  on_the_body(&out[VC_FEATURE_HEAD]);
  std::optional<cv::Vec3d> head_p;
  if (head.ok) head_p = head.p_world;

  solve_pair(frame, Pair::hands, head_p, &out);
  solve_pair(frame, Pair::feet, head_p, &out);
  hull_ = seen_ = reject_ = nullptr;
  return out;
}

void FeatureTriangulator::on_the_body(pipeline::Feature3D* f) const {
  f->hull_clearance_m = -1;
  if (!seen_ || f->state != pipeline::Feature3DState::Triangulated) return;
  const cv::Vec3d p(f->p_world[0], f->p_world[1], f->p_world[2]);
  const double c = seen_->clearance(p, kHullClearanceCapM);
  if (c < 0) return;
  f->hull_clearance_m = static_cast<float>(std::min(c, kHullClearanceCapM));
  // Outside the hull at all: where the silhouettes say there is no body (README, "On the body").
  if (hull_ && c > 0) f->confidence = std::min(f->confidence, static_cast<float>(kUncertainCap));
}

void FeatureTriangulator::set_body_right(const std::optional<cv::Vec3d>& right) {
  body_right_.reset();
  if (!right) return;
  const cv::Vec3d level((*right)[0], (*right)[1], 0);
  const double n = cv::norm(level);
  if (!(std::isfinite(n) && n > 1e-6)) return;
  body_right_ = level / n;
  // Turned round at once: a pair the body confirmed before is named as it was (the names are followed
  // frame by frame), so the body, not the names, jumped; the body has no say on that pair until it
  // turns round again (README, "The body's right").
  if (last_right_ && last_right_->dot(*body_right_) < std::cos(kBodyTurnedRoundDeg * kPi / 180))
    for (PairState& st : pairs_) {
      if (st.turned)
        st.turned = false;
      else if (st.verdict > 0)
        st.turned = true;
      st.against = 0;
    }
  last_right_ = body_right_;
}

void FeatureTriangulator::check_body_right(Pair pair, const cv::Vec3d& a, const cv::Vec3d& b, bool* a_left,
                                           bool* certain) {
  PairState& st = pairs_[static_cast<size_t>(pair)];
  if (!body_right_ || st.turned) {
    st.against = 0;
    return;
  }
  // How far the point named right is to the right of the one named left, along the body's right.
  const cv::Vec3d d = *a_left ? b - a : a - b;
  const double lateral = d.dot(*body_right_);
  const double apart = pair == Pair::hands ? kBodyApartHandsM : kBodyApartFeetM;
  if (pair == Pair::feet) {
    // Feet apart fore-aft (a stride): a heading error of θ turns a stride s into a lateral offset
    // s·sin θ (the fit's torso right is 20-30° off for tens of frames in walking), so the body's right
    // decides only while the feet are at least as far apart sideways as fore-aft.
    const cv::Vec3d forward = cv::Vec3d(0, 0, 1).cross(*body_right_);
    if (std::abs(lateral) < std::abs(d.dot(forward))) {
      st.against = 0;
      return;
    }
  }
  if (lateral < -apart) {
    // Contradicted: untrusted while it lasts (it may be a brief crossing), swapped once it persists.
    *certain = false;
    st.verdict = -1;
    if (++st.against >= kBodyRenameFrames) {
      *a_left = !*a_left;
      *certain = true;
      st.against = 0;
      ++st.renames;
    }
    return;
  }
  st.against = 0;
  if (lateral > apart) {  // confirmed by a cue that does not come from the names
    *certain = true;
    st.verdict = 1;
  }
}

void FeatureTriangulator::solve_pair(const std::vector<CameraObservations>& frame, Pair pair,
                                     const std::optional<cv::Vec3d>& head,
                                     std::array<pipeline::Feature3D, 5>* out) {
  const int id_left = pair == Pair::hands ? VC_FEATURE_LEFT_HAND : VC_FEATURE_LEFT_FOOT;
  const int ids[2] = {id_left, id_left + 1};
  PairState& st = pairs_[static_cast<size_t>(pair)];

  // The candidates, without their labels; label[i] is the edge's (0 left, 1 right).
  struct Cand {
    View view;
    int label;
  };
  std::vector<Cand> cands;
  int cams_reporting[2] = {0, 0};
  for (const CameraObservations& c : frame) {
    if (c.camera < 0 || static_cast<size_t>(c.camera) >= cameras_.size()) continue;
    for (int s = 0; s < 2; ++s) {
      const Observation& o = c.features[static_cast<size_t>(ids[s])];
      if (!usable(o)) continue;
      cands.push_back({{c.camera, o.uv_px, view_weight(o)}, s});
      cams_reporting[s]++;
    }
  }

  // Find up to two points: each the pair of cameras (one candidate each) that the most cameras agree
  // with, one candidate per camera.
  std::vector<bool> taken(cands.size(), false);
  struct Found {
    PointResult r;
    std::vector<int> cand;  // indices into cands, one per camera used
    std::vector<View> views;
  };
  std::vector<Found> found;
  for (int k = 0; k < 2; ++k) {
    // Per camera, its free candidates.
    std::vector<std::vector<int>> per_cam(cameras_.size());
    for (size_t i = 0; i < cands.size(); ++i)
      if (!taken[i]) per_cam[static_cast<size_t>(cands[i].view.camera)].push_back(static_cast<int>(i));
    std::vector<int> cams;
    for (size_t c = 0; c < per_cam.size(); ++c)
      if (!per_cam[c].empty()) cams.push_back(static_cast<int>(c));
    if (cams.size() < 2) break;
    // Hypotheses: two-camera triangulations; score: cameras with a candidate within inlier_px.
    std::vector<int> best_sel;
    double best_sum = std::numeric_limits<double>::infinity();
    for (size_t a = 0; a < cams.size(); ++a)
      for (size_t b = a + 1; b < cams.size(); ++b)
        for (int ia : per_cam[static_cast<size_t>(cams[a])])
          for (int ib : per_cam[static_cast<size_t>(cams[b])]) {
            const PointResult h = triangulate_point(
                cameras_, {cands[static_cast<size_t>(ia)].view, cands[static_cast<size_t>(ib)].view}, opt_,
                reject_);
            if (!h.ok) continue;
            std::vector<int> sel;
            double sum = 0;
            for (int c : cams) {
              int pick = -1;
              double pick_e = opt_.inlier_px;
              for (int i : per_cam[static_cast<size_t>(c)]) {
                const rig::Camera& cam = cameras_[static_cast<size_t>(c)];
                if (cam.to_cam(h.p_world)[2] <= 1e-6) continue;
                const cv::Point2d q = cam.project(h.p_world);
                const cv::Point2d& uv = cands[static_cast<size_t>(i)].view.uv_px;
                const double e = std::hypot(q.x - uv.x, q.y - uv.y);
                if (e < pick_e) {
                  pick_e = e;
                  pick = i;
                }
              }
              if (pick >= 0) {
                sel.push_back(pick);
                sum += pick_e;
              }
            }
            if (sel.size() > best_sel.size() || (sel.size() == best_sel.size() && sum < best_sum)) {
              best_sel = std::move(sel);
              best_sum = sum;
            }
          }
    if (best_sel.size() < 2) break;
    Found f;
    for (int i : best_sel) f.views.push_back(cands[static_cast<size_t>(i)].view);
    f.r = triangulate_point(cameras_, f.views, opt_, reject_);
    if (!f.r.ok) break;
    for (int i : f.r.inliers) f.cand.push_back(best_sel[static_cast<size_t>(i)]);
    for (int i : f.cand) taken[static_cast<size_t>(i)] = true;
    // Confidence against every camera that reported this pair, not only the ones picked.
    found.push_back(std::move(f));
  }

  // Name the points: side[j] = index into found, or -1.
  int side[2] = {-1, -1};
  bool certain = st.certain;
  const uint64_t now = frames_;
  auto stale = [&](const Track& t) {
    return !t.last || now - t.last_frame > static_cast<uint64_t>(opt_.identity_gap_frames);
  };
  const bool follow = st.named && !(stale(st.side[0]) && stale(st.side[1]));
  auto predicted = [&](const Track& t) -> std::optional<cv::Vec3d> {
    if (!t.last || stale(t)) return std::nullopt;
    if (t.before && now - t.last_frame == 1) return *t.last + (*t.last - *t.before);
    return t.last;
  };
  // The cameras' kept swaps on found[0]: +1 it is the left, -1 the right (two or more decided cameras
  // agree and none disagrees), 0 no clear vote.
  auto vote = [&]() {
    int votes[2] = {0, 0};
    for (int i : found[0].cand) {
      const Cand& c = cands[static_cast<size_t>(i)];
      const int s = swap_[static_cast<size_t>(c.view.camera)][static_cast<size_t>(pair)];
      if (s >= 0) votes[c.label ^ s]++;
    }
    if (votes[0] >= 2 && votes[1] == 0) return 1;
    if (votes[1] >= 2 && votes[0] == 0) return -1;
    return 0;
  };
  bool a_left = true;
  // Feet: a point farther from a side's prediction than a foot can move since that side was last seen
  // is not that side (README, "Left and right": a second point triangulated on the same foot, or a
  // track that jumped to the other foot, must not pull the name across): gate(t) metres, or none when
  // the side has no prediction. Hands are not gated: crossing hands come within centimetres, and their
  // names are checked against the body's right with a wide margin.
  auto gate = [&](const Track& t) {
    return kGateM + kGatePerFrameM * static_cast<double>(now - t.last_frame - 1);
  };
  bool gated[2] = {false, false};  // found[k] fits neither side's gate: dropped for this frame
  // Feet, followed, one point seen: continuity named it against the other foot's old position only, so
  // its name is reported untrusted unless the cameras' kept swaps voted for it (README, "Left and right").
  bool lone = false;
  if (!found.empty() && follow) {
    const std::optional<cv::Vec3d> pl = predicted(st.side[0]), pr = predicted(st.side[1]);
    const std::optional<cv::Vec3d> pred[2] = {pl, pr};
    auto dist = [](const cv::Vec3d& a, const std::optional<cv::Vec3d>& b) {
      return b ? cv::norm(a - *b) : 0.5;  // an unknown side costs a fixed 0.5 m
    };
    // fits[k][s]: found[k] may be side s (within its gate, or the side has no prediction).
    bool fits[2][2] = {{true, true}, {true, true}};
    for (size_t k = 0; k < found.size(); ++k)
      for (int s = 0; s < 2; ++s)
        fits[k][s] =
            pair != Pair::feet || !pred[s] || cv::norm(found[k].r.p_world - *pred[s]) <= gate(st.side[s]);
    // One foot seen: a planted foot does not move (during a step only the swinging foot does), so a
    // point that lies away from where a foot has stood still is the other foot.
    if (pair == Pair::feet && found.size() == 1)
      for (int s = 0; s < 2; ++s)
        if (!stale(st.side[s]) && st.side[s].anchor && st.side[s].still >= kPlantedFrames &&
            cv::norm(found[0].r.p_world - *st.side[s].anchor) > kPlantedAwayM)
          fits[0][s] = false;
    bool clear = true;
    if (found.size() == 2) {
      const cv::Vec3d& A = found[0].r.p_world;
      const cv::Vec3d& B = found[1].r.p_world;
      const double keep = dist(A, pl) + dist(B, pr), swap = dist(A, pr) + dist(B, pl);
      const bool keep_ok = fits[0][0] && fits[1][1], swap_ok = fits[0][1] && fits[1][0];
      if (keep_ok || swap_ok || (!fits[0][0] && !fits[0][1]) || (!fits[1][0] && !fits[1][1]) || !(pl && pr)) {
        a_left = keep_ok && swap_ok ? keep <= swap : keep_ok ? true : swap_ok ? false : keep <= swap;
        // Far apart but no clear winner: continuity cannot say which is which.
        const double apart = cv::norm(A - B);
        clear = std::abs(keep - swap) >= 0.5 * apart || apart <= 0.1;
        if (!keep_ok && !swap_ok && pl && pr) {
          // One point fits no side: it is dropped and the other named by the side it fits.
          auto side_of = [&](int k) {
            if (fits[k][0] && fits[k][1])
              return dist(found[static_cast<size_t>(k)].r.p_world, pl) <=
                             dist(found[static_cast<size_t>(k)].r.p_world, pr)
                         ? 0
                         : 1;
            return fits[k][0] ? 0 : 1;
          };
          for (int k = 0; k < 2; ++k) gated[k] = !fits[k][0] && !fits[k][1];
          if (gated[0] && !gated[1]) a_left = side_of(1) == 1;  // B takes the side it fits
          if (gated[1] && !gated[0]) a_left = side_of(0) == 0;
        }
      } else {
        // Both points fit only the same side (two points on one foot): the nearer one takes it, the
        // other is dropped.
        const int s = fits[0][0] ? 0 : 1;
        const int keep_k = cv::norm(A - *pred[s]) <= cv::norm(B - *pred[s]) ? 0 : 1;
        gated[1 - keep_k] = true;
        a_left = (keep_k == 0) == (s == 0);
      }
    } else {
      const double dl = dist(found[0].r.p_world, pl), dr = dist(found[0].r.p_world, pr);
      a_left = fits[0][0] && fits[0][1] ? dl <= dr : fits[0][0];
      gated[0] = !fits[0][0] && !fits[0][1];
      clear = !(pl && pr) || std::abs(dl - dr) >= 0.05 || !(fits[0][0] && fits[0][1]);
      lone = pair == Pair::feet;
    }
    if (!clear || !certain) {
      // Re-check against the cameras' kept swaps: they confirm or correct; without them the naming
      // stays untrusted (continuity alone cannot repair a wrong naming).
      int v = gated[0] || gated[1] ? 0 : vote();
      // The cameras' kept swaps cannot put a point on a side it does not fit.
      if ((v > 0 && !fits[0][0]) || (v < 0 && !fits[0][1])) v = 0;
      if (v != 0) {
        a_left = v > 0;
        certain = true;
        lone = false;
      } else {
        certain = false;
      }
    } else if (lone && !gated[0]) {
      const int v = vote();
      if (v != 0 && (v > 0) == a_left && fits[0][a_left ? 0 : 1]) lone = false;
    }
  } else if (!found.empty()) {
    // Named afresh: the cameras' kept swaps vote, else the initialization rule.
    if (const int v = vote(); v != 0) {
      a_left = v > 0;
      certain = true;
    } else {
      cv::Vec3d facing(0, 0, 0);
      const cv::Vec3d ref = found.size() == 2 ? 0.5 * (found[0].r.p_world + found[1].r.p_world)
                            : head            ? *head
                                              : found[0].r.p_world;
      for (int c : front_) facing += cameras_[static_cast<size_t>(c)].center_world() - ref;
      facing[2] = 0;
      const cv::Vec3d left = cv::Vec3d(0, 0, 1).cross(facing);
      double along = 0;
      if (found.size() == 2)
        along = (found[0].r.p_world - found[1].r.p_world).dot(left);
      else if (head)
        along = (found[0].r.p_world - *head).dot(left);
      a_left = along >= 0;
      certain = !front_.empty() && cv::norm(left) > 1e-9 && std::abs(along) / cv::norm(left) > 0.1 &&
                (found.size() == 2 || head.has_value());
    }
    // One point named by a guess (feet held together seen as one blob at start-up: the head rule cannot
    // tell left from right) is reported, untrusted, but not followed: the pair is named afresh on the
    // next frame, by the initialization rule once both points are seen. Following the guess kept a wrong
    // naming for the whole take (live `walk` and `squat`), since continuity cannot repair it.
    st.named = certain || found.size() == 2;
  }
  if (found.size() == 2 && !gated[0] && !gated[1])
    check_body_right(pair, found[0].r.p_world, found[1].r.p_world, &a_left, &certain);
  if (!found.empty()) {
    if (!gated[0]) side[a_left ? 0 : 1] = 0;
    if (found.size() == 2 && !gated[1]) side[a_left ? 1 : 0] = 1;
  }
  st.certain = certain;

  // Results.
  for (int s = 0; s < 2; ++s) {
    pipeline::Feature3D& f = (*out)[static_cast<size_t>(ids[s])];
    if (side[s] < 0) {
      // By its own labels: two or more cameras reported it but it did not come out as a point.
      f.state = cams_reporting[s] >= 2 ? pipeline::Feature3DState::Inconsistent
                                       : pipeline::Feature3DState::TooFewViews;
      continue;
    }
    const Found& fd = found[static_cast<size_t>(side[s])];
    fill(&f, fd.r, fd.views, static_cast<int>(fd.views.size()));
    // The agreement term: the views used against those plus every camera with a candidate of the pair
    // that neither point took (a view that reported it and disagrees).
    int untaken = 0;
    {
      std::vector<int> cams_left;
      for (size_t i = 0; i < cands.size(); ++i)
        if (!taken[i]) cams_left.push_back(cands[i].view.camera);
      std::sort(cams_left.begin(), cams_left.end());
      untaken = static_cast<int>(std::unique(cams_left.begin(), cams_left.end()) - cams_left.begin());
    }
    const int reporting = static_cast<int>(fd.r.inliers.size()) + untaken;
    double wsum = 0;
    for (int i : fd.r.inliers) wsum += std::clamp(fd.views[static_cast<size_t>(i)].weight, 0.0, 1.0);
    std::vector<Prepared> prepared;
    for (const View& v : fd.views) prepared.push_back(prepare(cameras_, v));
    double conf =
        confidence(wsum / static_cast<double>(fd.r.inliers.size()), static_cast<int>(fd.r.inliers.size()),
                   reporting, fd.r.rms_px, widest_angle(prepared, fd.r.inliers, fd.r.p_world), opt_);
    if (!certain || lone) conf = std::min(conf, kUncertainCap);
    f.name_trusted = certain && !lone;
    f.confidence = static_cast<float>(conf);
    on_the_body(&f);
    Track& t = st.side[s];
    t.before = (t.last && now - t.last_frame == 1) ? t.last : std::nullopt;
    t.last = fd.r.p_world;
    t.last_frame = now;
    if (t.anchor && cv::norm(fd.r.p_world - *t.anchor) <= kStillM) {
      // The anchor is the mean of the positions where it stood (the last 10): one noisy point does
      // not move it.
      const double n = std::min(t.still + 1, 10);
      t.anchor = (n * *t.anchor + fd.r.p_world) / (n + 1);
      ++t.still;
    } else {
      t.anchor = fd.r.p_world;  // the first position seen, or it moved: it stands here from now on
      t.still = 0;
    }
  }

  // Re-decide each camera's swap where its candidates fit the named points clearly one way (only
  // while the naming is trusted: an uncertain naming must not overwrite what the cameras kept).
  if (!certain) return;
  for (const CameraObservations& c : frame) {
    if (c.camera < 0 || static_cast<size_t>(c.camera) >= cameras_.size()) continue;
    const rig::Camera& cam = cameras_[static_cast<size_t>(c.camera)];
    double err[2][2];  // err[label][performer side]
    bool have = true;
    for (int l = 0; l < 2; ++l)
      for (int s = 0; s < 2; ++s) {
        const Observation& o = c.features[static_cast<size_t>(ids[l])];
        if (!usable(o) || side[s] < 0) {
          have = false;
          continue;
        }
        const cv::Vec3d& X = found[static_cast<size_t>(side[s])].r.p_world;
        if (cam.to_cam(X)[2] <= 1e-6) {
          err[l][s] = 1e9;
        } else {
          const cv::Point2d q = cam.project(X);
          err[l][s] = std::hypot(q.x - o.uv_px.x, q.y - o.uv_px.y);
        }
      }
    if (!have) continue;
    const double direct = err[0][0] + err[1][1], crossed = err[0][1] + err[1][0];
    int& s = swap_[static_cast<size_t>(c.camera)][static_cast<size_t>(pair)];
    if (direct < opt_.swap_ratio * crossed)
      s = 0;
    else if (crossed < opt_.swap_ratio * direct)
      s = 1;
  }
}

}  // namespace vc::triangulate
