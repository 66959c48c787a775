#include "voxcap/edge/track/tracker.hpp"

#include "voxcap/edge/segment.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

namespace vc::track {

namespace {

// The distance of every non-zero pixel of `in` to the nearest zero pixel (0 at zero pixels), by the
// two-pass 3x3 chamfer with OpenCV's DIST_L2 / DIST_MASK_3 weights (1 step 0.955, diagonal 1.3693);
// pixels beyond the region's edge are not zeros. What cv::distanceTransform gives, without its
// per-call buffers (a few small regions per frame).
void chamfer_distance(const cv::Mat1b& in, cv::Mat1f& d) {
  constexpr float a = 0.955f, b = 1.3693f, far = 1e6f;
  const int w = in.cols, h = in.rows;
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* src = in[y];
    float* row = d[y];
    const float* up = y > 0 ? d[y - 1] : nullptr;
    for (int x = 0; x < w; ++x) {
      if (!src[x]) {
        row[x] = 0;
        continue;
      }
      float v = far;
      if (x > 0) v = std::min(v, row[x - 1] + a);
      if (up) {
        v = std::min(v, up[x] + a);
        if (x > 0) v = std::min(v, up[x - 1] + b);
        if (x + 1 < w) v = std::min(v, up[x + 1] + b);
      }
      row[x] = v;
    }
  }
  for (int y = h - 1; y >= 0; --y) {
    float* row = d[y];
    const float* down = y + 1 < h ? d[y + 1] : nullptr;
    for (int x = w - 1; x >= 0; --x) {
      float v = row[x];
      if (v == 0) continue;
      if (x + 1 < w) v = std::min(v, row[x + 1] + a);
      if (down) {
        v = std::min(v, down[x] + a);
        if (x + 1 < w) v = std::min(v, down[x + 1] + b);
        if (x > 0) v = std::min(v, down[x - 1] + b);
      }
      row[x] = v;
    }
  }
}

cv::Point2f centre_of(const cv::Rect& r) {
  return {float(r.x) + 0.5f * float(r.width), float(r.y) + 0.5f * float(r.height)};
}

double iou(const cv::Rect& a, const cv::Rect& b) {
  const double inter = (a & b).area();
  const double uni = double(a.area()) + double(b.area()) - inter;
  return uni > 0 ? inter / uni : 0.0;
}

// The wrist and the ankle beyond the junction (joint_beyond_blob()): the slope of the distance penalty,
// below 1 so that the clearance's rise (slope 1 from the junction to the cap's centre) wins, above 0 so
// that the flat ridge behind the centre loses.
constexpr float kJointSlope = 0.6f;
// The largest radius of the covered limb beside a blob of half-length L and half-width W:
// max(kLimbRadiusPerHalfLength L, kLimbRadiusPerHalfWidth W) (a forearm is as wide as the hand, a
// shank's radius about half the foot's half-length; both hold for a hand or foot seen end-on).
constexpr double kLimbRadiusPerHalfLength = 0.6;
constexpr double kLimbRadiusPerHalfWidth = 1.2;
// The head blob holds the neck too: the head's centre is the middle of the rows where the blob is
// nearly as wide as it gets (the neck is ~0.7 of the head's width, so it never counts).
constexpr float kHeadRowShare = 0.85f;
// A window grows to at most this many times its reference area in one frame (CamShift alone would take
// a whole neighbouring blob).
constexpr double kMaxGrow = 2.0;
// A prediction extrapolates the velocity over at most this many frames (limbs turn around).
constexpr int kPredictCap = 10;
// Two windows converge when they were apart at most kArrival frames ago and their distance shrinks by at
// least kClosing of their size in a frame.
constexpr double kClosing = 0.02;
constexpr int kArrival = 15;
// The confidence factor of a window whose centre is within ambiguous_near of another's.
constexpr double kNearConfidence = 0.3;  // frames since the two were apart (farther than ambiguous_far)
// The confidence of a window re-acquired from a blob its lost sibling could have been, until settled.
constexpr float kDoubtConfidence = 0.3f;
// Two touching windows split their blob's pixels (clear_others()) only while each holds at least this
// share of its reference mass: both parts are in view.
constexpr double kSideBySideMass = 0.7;
// A part waiting to join its sibling (join_siblings()) takes a free skin blob whose centre is within
// kJoinReach of the sibling window's size from the sibling's centre (the two parted a moment ago) and
// whose area is at least kJoinArea of the sibling's reference (learnt on the blob of both); looked for
// every kJoinEvery frames (a back-projection and a labelling around the sibling: feet that never part
// in a view would pay it every frame), so a part joins at most kJoinEvery - 1 frames late.
constexpr double kJoinReach = 2.5;
constexpr double kJoinArea = 0.15;
constexpr int kJoinEvery = 6;

}  // namespace

cv::Point2f CameraTracker::Track::predicted_uv(int frames) const {
  return pred_uv + float(std::clamp(frames, 0, kPredictCap)) * pred_velocity;
}
cv::Point2f CameraTracker::Track::predicted_centre(int frames) const {
  return pred_centre + float(std::clamp(frames, 0, kPredictCap)) * pred_velocity;
}

FeatureKind feature_kind(int feature) {
  return feature == 0 ? FeatureKind::head : feature <= 2 ? FeatureKind::hand : FeatureKind::foot;
}

bool TrackerOptions::valid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  std::string cw;
  if (!colour.valid(&cw)) return fail("colour: " + cw);
  if (init_frames < 1 || init_frames > 1000) return fail("init_frames must be 1..1000");
  if (!(seed_radius > 0 && seed_radius < 0.5)) return fail("seed_radius must be in (0, 0.5)");
  if (min_blob_px < 1) return fail("min_blob_px must be >= 1");
  if (prob_threshold < 1 || prob_threshold > 254) return fail("prob_threshold must be 1..254");
  if (!(min_mass_ratio > 0 && min_mass_ratio < 1)) return fail("min_mass_ratio must be in (0, 1)");
  if (!(min_area_ratio > 0 && min_area_ratio < 1)) return fail("min_area_ratio must be in (0, 1)");
  if (!(min_inside >= 0 && min_inside <= 1)) return fail("min_inside must be in [0, 1]");
  if (!(max_jump > 0)) return fail("max_jump must be > 0");
  if (!(merge_iou > 0 && merge_iou <= 1)) return fail("merge_iou must be in (0, 1]");
  if (recover_frames < 1) return fail("recover_frames must be >= 1");
  if (!(reach_px >= 0 && reach_grow >= 0)) return fail("reach_px and reach_grow must be >= 0");
  if (!(ambiguous_near > 0 && ambiguous_far > ambiguous_near))
    return fail("ambiguous_near must be > 0 and ambiguous_far > ambiguous_near");
  if (!(swap_ratio > 0 && swap_ratio <= 1)) return fail("swap_ratio must be in (0, 1]");
  if (ambiguous_max_frames < 1) return fail("ambiguous_max_frames must be >= 1");
  if (predict_frames < 0 || predict_frames > 100) return fail("predict_frames must be 0..100");
  if (!(predicted_confidence >= 0 && predicted_confidence <= 1))
    return fail("predicted_confidence must be in [0, 1]");
  return true;
}

bool extremity_seeds(const cv::Mat1b& mask, Seeds* seeds, std::string* why) {
  *seeds = Seeds{};
  auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (mask.empty()) return fail("no silhouette");
  const cv::Rect box = cv::boundingRect(mask);
  if (box.height < 24 || box.width < 4) return fail("silhouette too small to segment");
  const double H = box.height;
  // Head: the centroid column of the top rows, its centre ~6.6 % of the height below the top (a head's
  // vertical radius against a body's height).
  {
    const int rows = std::max(2, int(0.05 * H));
    double sx = 0, n = 0;
    for (int y = box.y; y < box.y + rows; ++y)
      for (int x = box.x; x < box.x + box.width; ++x)
        if (mask(y, x)) sx += x, n++;
    if (n > 0) (*seeds)[0] = {true, {float(sx / n), float(box.y + 0.066 * H)}};
  }
  // Hands: only when the arms are spread (the silhouette is about as wide as tall); the extreme columns'
  // pixels above the hips, moved inwards by half a hand. The performer's left is the image's right.
  if (box.width > 0.6 * H) {
    const int cols = std::max(2, int(0.03 * H));
    for (int side = 0; side < 2; ++side) {
      const int x0 = side == 0 ? box.x + box.width - cols : box.x;
      double sx = 0, sy = 0, n = 0;
      for (int y = box.y; y < box.y + int(0.6 * H); ++y)
        for (int x = x0; x < x0 + cols; ++x)
          if (mask(y, x)) sx += x, sy += y, n++;
      if (n == 0) continue;
      const float inward = float((side == 0 ? -1 : 1) * 0.05 * H);
      (*seeds)[side == 0 ? 1u : 2u] = {true, {float(sx / n) + inward, float(sy / n)}};
    }
  }
  // Feet: the lowest rows, split at their median column.
  {
    const int rows = std::max(2, int(0.04 * H));
    std::vector<int> xs;
    for (int y = box.y + box.height - rows; y < box.y + box.height; ++y)
      for (int x = box.x; x < box.x + box.width; ++x)
        if (mask(y, x)) xs.push_back(x);
    if (xs.size() >= 4) {
      std::nth_element(xs.begin(), xs.begin() + long(xs.size() / 2), xs.end());
      const int mid = xs[xs.size() / 2];
      double s[2] = {0, 0}, n[2] = {0, 0};
      for (int x : xs) {
        const int side = x > mid ? 0 : 1;  // image right: the performer's left foot
        s[side] += x, n[side]++;
      }
      for (int side = 0; side < 2; ++side)
        if (n[side] > 0)
          (*seeds)[side == 0 ? 3u : 4u] = {true,
                                           {float(s[side] / n[side]), float(box.y + box.height - 0.03 * H)}};
    }
  }
  if (!(*seeds)[0].found) return fail("no head at the top of the silhouette");
  return true;
}

bool segment_seeds(const cv::Mat1b& mask, Seeds* seeds, std::string* why) {
  const segment::Segmentation s = segment::segment(mask);
  if (!s.ok) {
    std::string mine;
    if (extremity_seeds(mask, seeds, &mine)) return true;
    if (why) *why = "segmentation: " + s.why + "; extremities: " + mine;
    return false;
  }
  *seeds = Seeds{};
  for (std::size_t f = 0; f < static_cast<std::size_t>(kFeatures); ++f)
    (*seeds)[f] = {s.terminal[f] >= 0, s.point[f]};
  return true;
}

CameraTracker::CameraTracker(const TrackerOptions& options, Seeder seeder)
    : opt_(options), seeder_(std::move(seeder)) {
  std::string why;
  if (!opt_.valid(&why)) throw std::invalid_argument("tracker options: " + why);
  if (!seeder_) seeder_ = segment_seeds;
  for (auto& m : models_) m = ColourModel(opt_.colour);
  pooled_ = ColourModel(opt_.colour);
}

void CameraTracker::reset() {
  phase_ = Phase::init;
  init_done_ = 0;
  seed_why_.clear();
  last_seeds_ = Seeds{};
  for (auto& m : models_) m.reset();
  pooled_.reset();
  tracks_ = {};
  join_tick_ = 0;
  for (auto& row : since_apart_) row.fill(1000);
}

void CameraTracker::prepare(const cv::Mat3b& rgb, const cv::Mat1b& mask, const cv::Rect& roi,
                            const ColourModel& model) {
  cv::Mat3b hsv = hsv_(roi);
  cv::cvtColor(rgb(roi), hsv, cv::COLOR_RGB2HSV);
  cv::Mat1b prob = prob_(roi);
  model.back_project(hsv, mask(roi), prob);
}

void CameraTracker::learn_frame(const cv::Mat3b& rgb, const cv::Mat1b& mask, const Seeds& seeds) {
  const cv::Rect box = cv::boundingRect(mask);
  const int radius = std::max(3, int(opt_.seed_radius * box.height));
  const cv::Rect image(0, 0, rgb.cols, rgb.rows);
  for (int f = 0; f < kFeatures; ++f) {
    const Seed& s = seeds[static_cast<std::size_t>(f)];
    if (!s.found) continue;
    const cv::Rect roi =
        cv::Rect(int(s.point.x) - radius, int(s.point.y) - radius, 2 * radius + 1, 2 * radius + 1) & image;
    if (roi.empty()) continue;
    cv::Mat3b hsv = hsv_(roi);
    cv::cvtColor(rgb(roi), hsv, cv::COLOR_RGB2HSV);
    cv::Mat1b region = region_(roi);
    region.setTo(0);
    cv::circle(region, cv::Point(int(s.point.x) - roi.x, int(s.point.y) - roi.y), radius, 255, cv::FILLED);
    cv::bitwise_and(region, mask(roi), region);
    models_[static_cast<std::size_t>(f)].learn(hsv, region);
  }
}

void CameraTracker::adopt(int f, const cv::Rect& box, const cv::Rect& valid, const cv::Mat1b& mask,
                          bool recovered) {
  Track& t = tracks_[static_cast<std::size_t>(f)];
  t.window = box;
  t.centre = centre_of(box);
  t.velocity = {0, 0};
  t.ref_mass = std::max(1.0, cv::sum(prob_(box))[0] / 255.0);
  t.ref_area = std::max(1, box.area());
  t.active = t.seen = true;
  t.lost_frames = 0;
  t.partner = -1;
  t.amb_frames = 0;
  t.since_recovery = recovered ? 0 : opt_.recover_frames;
  t.mass_ratio = 1;
  t.uv = t.centre;  // the joint is not known yet: the new blob's centre stands for it (clear_others())
  cv::Point2f uv;
  t.uv = estimate_point(f, box, valid, mask, &uv) ? uv : t.centre;
  t.confidence = recovered ? 1.0f / float(opt_.recover_frames + 1) : 1.0f;
}

void CameraTracker::start_tracking(const cv::Mat3b& rgb, const cv::Mat1b& mask, const Seeds& seeds) {
  pooled_.reset();
  for (auto& m : models_) {
    pooled_.merge(m);
    m.finish();
  }
  if (!pooled_.finish()) {  // no skin seen at any seed: learn again from the next frames
    for (auto& m : models_) m.reset();
    init_done_ = 0;
    seed_why_ = "no skin-coloured pixels at the seeds";
    return;
  }
  for (auto& m : models_)
    if (!m.ready()) m = pooled_;
  const cv::Rect box = cv::boundingRect(mask);
  const int radius = std::max(3, int(opt_.seed_radius * box.height));
  const cv::Rect image(0, 0, rgb.cols, rgb.rows);
  for (int f = 0; f < kFeatures; ++f) {
    const Seed& s = seeds[static_cast<std::size_t>(f)];
    if (!s.found) continue;
    const cv::Rect roi =
        cv::Rect(int(s.point.x) - 2 * radius, int(s.point.y) - 2 * radius, 4 * radius + 1, 4 * radius + 1) &
        image;
    if (roi.empty()) continue;
    prepare(rgb, mask, roi, models_[static_cast<std::size_t>(f)]);
    cv::Mat1b blobs = blobs_(roi);
    cv::compare(prob_(roi), opt_.prob_threshold, blobs, cv::CMP_GT);
    const int n = cv::connectedComponentsWithStats(blobs, labels_, stats_, centroids_, 8, CV_32S);
    // The blob nearest to the seed (distance from the seed to the blob's box), within the seed radius.
    int best = -1;
    double best_d = radius;
    const cv::Point2f p(s.point.x - float(roi.x), s.point.y - float(roi.y));
    for (int k = 1; k < n; ++k) {
      if (stats_(k, cv::CC_STAT_AREA) < opt_.min_blob_px) continue;
      const cv::Rect b(stats_(k, cv::CC_STAT_LEFT), stats_(k, cv::CC_STAT_TOP), stats_(k, cv::CC_STAT_WIDTH),
                       stats_(k, cv::CC_STAT_HEIGHT));
      const double dx = std::max({double(b.x) - p.x, 0.0, double(p.x) - double(b.x + b.width)});
      const double dy = std::max({double(b.y) - p.y, 0.0, double(p.y) - double(b.y + b.height)});
      const double d = std::hypot(dx, dy);
      if (d < best_d || (d == 0 && best_d == 0 && best >= 0 &&
                         stats_(k, cv::CC_STAT_AREA) > stats_(best, cv::CC_STAT_AREA))) {
        best_d = d;
        best = k;
      }
    }
    if (best < 0) continue;
    const cv::Rect b(stats_(best, cv::CC_STAT_LEFT) + roi.x, stats_(best, cv::CC_STAT_TOP) + roi.y,
                     stats_(best, cv::CC_STAT_WIDTH), stats_(best, cv::CC_STAT_HEIGHT));
    adopt(f, b, roi, mask, false);
  }
  // Two seeds on one blob (e.g. feet together seen from the side): the blob is one feature's only. Of
  // two alike parts (the feet, the hands) the other joins once its part is seen apart (join_siblings()).
  for (int a = 0; a < kFeatures; ++a)
    for (int b = a + 1; b < kFeatures; ++b) {
      Track& ta = tracks_[static_cast<std::size_t>(a)];
      Track& tb = tracks_[static_cast<std::size_t>(b)];
      if (ta.active && tb.active && iou(ta.window, tb.window) > opt_.merge_iou) {
        tb = Track{};
        tb.joins = feature_kind(a) == feature_kind(b);
      }
    }
  phase_ = Phase::tracking;
}

void CameraTracker::lose(int f) {
  Track& t = tracks_[static_cast<std::size_t>(f)];
  if (!t.active) return;
  // What the prediction starts from: before an ambiguity, where it began; else the last measurement.
  if (t.partner >= 0) {
    t.pred_uv = t.predicted_uv(t.amb_frames);
    t.pred_centre = t.predicted_centre(t.amb_frames);
    Track& o = tracks_[static_cast<std::size_t>(t.partner)];
    // Which of the two the other holds is not known: its confidence ramps up again; of two alike (the
    // hands, the feet) it is in doubt until f's re-acquisition settles which is which (settle_doubt()).
    if (feature_kind(f) == feature_kind(t.partner)) {
      o.doubt = true;
      o.doubt_pred = o.predicted_centre(o.amb_frames);
    }
    o.partner = -1;
    o.amb_frames = 0;
    o.since_recovery = 0;
  } else {
    t.pred_uv = t.uv;
    t.pred_centre = t.centre;
    t.pred_velocity = t.velocity;
  }
  t.partner = -1;
  t.amb_frames = 0;
  t.doubt = false;
  t.active = false;
  t.lost_frames = 0;
  t.confidence = 0;
  losses_++;
}

// Skin pixels around feature f's window that belong to another tracked window are not f's: feet
// standing together in a front view are one skin blob with the shadowed floor between them (inside the
// edge's mask, of a skin-like hue on a wooden floor), and the other foot's pixels within reach of f's
// joint estimate pulled its centroid, axes and junction to the middle of the pair (both ankles
// reported between the feet, ~11 px off and below). A pixel belongs to the window it is nearest to (the
// distance to the window's box, 0 inside); where two windows overlap, to the one whose joint at the
// last frame is nearer relative to the window's size (the ankles of two feet are apart where their
// windows are not, in an oblique view; a small hand window does not take the face from the head's).
// Only while both windows hold about their own mass (kSideBySideMass): when one part hides the other
// (a hand in front of the other in a side view) the windows share what is visible and no split is
// right. Pixels f does not own are cleared in the back-projection over `region`, where only f's joint
// estimate reads it afterwards; other windows that do not reach into the region own nothing in it.
void CameraTracker::clear_others(int f, const cv::Rect& window, const cv::Rect& region) {
  struct Other {
    cv::Rect window;
    cv::Point2f joint;
    float inv_size;
  };
  std::array<Other, kFeatures> others{};
  int n = 0;
  const Track& t = tracks_[static_cast<std::size_t>(f)];
  for (int g = 0; g < kFeatures; ++g) {
    const Track& o = tracks_[static_cast<std::size_t>(g)];
    const int reach = std::max(o.window.width, o.window.height);
    const cv::Rect near(o.window.x - reach, o.window.y - reach, o.window.width + 2 * reach,
                        o.window.height + 2 * reach);
    if (g == f || !o.active || o.partner == f || (near & region).area() == 0) continue;
    // Only when both windows hold about their own mass (both parts in view, side by side): when one
    // part hides the other, the two windows share what is visible and no split is right.
    if (o.mass_ratio < kSideBySideMass || t.mass_ratio < kSideBySideMass) continue;
    others[static_cast<std::size_t>(n++)] = {o.window, o.uv, 1.0f / float(std::max({reach, 2}))};
  }
  if (n == 0) return;
  auto box_distance = [](const cv::Rect& r, int x, int y) {
    const int dx = std::max({r.x - x, 0, x - (r.x + r.width - 1)});
    const int dy = std::max({r.y - y, 0, y - (r.y + r.height - 1)});
    return dx * dx + dy * dy;
  };
  // In the windows' overlap: the distance to the feature's joint at the last frame (a foot's window
  // reaches over the other foot's heel in an oblique view; the two ankles do not), per window size.
  const cv::Point2f mine_joint = t.uv;
  const float mine_inv = 1.0f / float(std::max({window.width, window.height, 2}));
  auto joint_distance = [](cv::Point2f j, float inv, int x, int y) {
    return std::hypot(float(x) - j.x, float(y) - j.y) * inv;
  };
  for (int y = region.y; y < region.y + region.height; ++y) {
    std::uint8_t* p = prob_[y];
    for (int x = region.x; x < region.x + region.width; ++x) {
      if (!p[x]) continue;
      const int mine = box_distance(window, x, y);
      for (int k = 0; k < n; ++k) {
        const Other& o = others[static_cast<std::size_t>(k)];
        const int theirs = box_distance(o.window, x, y);
        if (theirs < mine ||
            (theirs == 0 && mine == 0 &&
             joint_distance(o.joint, o.inv_size, x, y) < joint_distance(mine_joint, mine_inv, x, y))) {
          p[x] = 0;
          break;
        }
      }
    }
  }
}

bool CameraTracker::estimate_point(int f, const cv::Rect& window, const cv::Rect& valid,
                                   const cv::Mat1b& mask, cv::Point2f* uv) {
  // Only where this frame's HSV and back-projection were computed, one pixel in from the image's edge
  // (the 4-neighbour tests below).
  const cv::Rect inner = valid & cv::Rect(1, 1, prob_.cols - 2, prob_.rows - 2);
  {
    const int m = std::max(window.width, window.height), grow = m / 2 + 3;
    clear_others(
        f, window,
        cv::Rect(window.x - grow, window.y - grow, window.width + 2 * grow, window.height + 2 * grow) &
            inner);
  }
  const int gx = window.width / 4 + 1, gy = window.height / 4 + 1;
  const cv::Rect e =
      cv::Rect(window.x - gx, window.y - gy, window.width + 2 * gx, window.height + 2 * gy) & inner;
  if (e.empty()) return false;
  const int thr = opt_.prob_threshold;
  const FeatureKind kind = feature_kind(f);
  double cx = 0, cy = 0, n = 0;
  int max_row = 0;
  for (int y = e.y; y < e.y + e.height; ++y) {
    const std::uint8_t* p = prob_[y];
    int row = 0;
    for (int x = e.x; x < e.x + e.width; ++x)
      if (p[x] > thr) row++, cx += x, cy += y, n++;
    max_row = std::max(max_row, row);
  }
  if (n < 0.5 * opt_.min_blob_px + 1) return false;
  const cv::Point2f c(float(cx / n), float(cy / n));
  if (kind == FeatureKind::head) {
    const int need = int(std::ceil(kHeadRowShare * float(max_row)));
    double hx = 0, hy = 0, hn = 0;
    for (int y = e.y; y < e.y + e.height; ++y) {
      const std::uint8_t* p = prob_[y];
      int row = 0;
      double rx = 0;
      for (int x = e.x; x < e.x + e.width; ++x)
        if (p[x] > thr) row++, rx += x;
      if (row >= need && row > 0) hx += rx, hy += double(y) * row, hn += row;
    }
    *uv = hn > 0 ? cv::Point2f(float(hx / hn), float(hy / hn)) : c;
    return true;
  }
  *uv = joint_beyond_blob(window, inner, mask, c);
  return true;
}

// The wrist or the ankle next to a hand's or a foot's skin blob (centroid c). Both joints are the end
// of a limb that the clothes cover: the sleeve or the trouser leg ends in a rounded cap centred on the
// joint (a limb of radius r is a capsule), and the skin blob begins where that cap's outline crosses
// it (the junction). In the clothes-only part of the silhouette (silhouette pixels that are skin
// neither by this feature's model nor by the pooled one), the distance to the nearest non-cloth pixel D
// grows from 0 at the junction to r at the cap's centre and stays r along the limb's axis behind it;
// so along the limb, from the junction J, D(p) - kJointSlope |p - J| rises until the cap's centre and
// falls after it: its maximum over the cloth pixels near J, on the side away from the blob, is the
// joint — wherever the limb points and whatever its width in this view (no body proportions, no
// appearance). J is the centroid of the blob's pixels that touch cloth two pixels deep (a few non-skin
// pixels of noise inside the blob are no junction).
// A blob seen over clothes (a hand hanging in front of the trousers, on the hip, across the chest) has
// cloth all around it: the junction gives no direction. The limb then leaves the blob at one end of
// its long axis, the end towards the body: the end nearer the head (the head's window when it is
// tracked, else the image's top) — the wrist is nearer the shoulder than the fingertips, the ankle
// nearer the hip than the toes. J is then the junction at that end.
// D is capped at the limb's largest radius for the blob's size (kLimbRadiusPer*): the clothes around
// (the torso behind a hand, the other trouser leg touching) are wider than the limb.
// Without a junction (nothing of the limb covered, or the limb hidden behind the blob) the blob's
// centroid is reported. Cost: a chamfer distance transform of a window about twice the blob's size.
cv::Point2f CameraTracker::joint_beyond_blob(const cv::Rect& window, const cv::Rect& inner,
                                             const cv::Mat1b& mask, cv::Point2f c) {
  const int m = std::max(window.width, window.height);
  const int grow = m / 2 + 3;
  const cv::Rect g =
      cv::Rect(window.x - grow, window.y - grow, window.width + 2 * grow, window.height + 2 * grow) & inner;
  if (g.width < 5 || g.height < 5) return c;
  const int thr = opt_.prob_threshold, low = opt_.prob_threshold / 2;
  for (int y = g.y; y < g.y + g.height; ++y) {
    const std::uint8_t* mk = mask[y];
    const cv::Vec3b* h = hsv_[y];
    const std::uint8_t* pr = prob_[y];
    std::uint8_t* out = cloth_[y];
    for (int x = g.x; x < g.x + g.width; ++x)
      out[x] = mk[x] && pr[x] <= low && pooled_.probability(h[x]) <= thr ? 255 : 0;
  }
  cv::Mat1f dist = dist_(g);
  chamfer_distance(cloth_(g), dist);
  // The blob's axes (second moments of its pixels in the window) and the junction.
  const int gx = window.width / 4 + 1, gy = window.height / 4 + 1;
  const cv::Rect w = cv::Rect(window.x - gx, window.y - gy, window.width + 2 * gx, window.height + 2 * gy) &
                     cv::Rect(g.x + 2, g.y + 2, g.width - 4, g.height - 4);
  double sxx = 0, syy = 0, sxy = 0, n = 0, jx = 0, jy = 0, jn = 0;
  auto touches = [&](int x, int y) {
    const int lx = x - g.x, ly = y - g.y;
    return (cloth_(y, x - 1) && dist(ly, lx - 2) >= 1.3f) || (cloth_(y, x + 1) && dist(ly, lx + 2) >= 1.3f) ||
           (cloth_(y - 1, x) && dist(ly - 2, lx) >= 1.3f) || (cloth_(y + 1, x) && dist(ly + 2, lx) >= 1.3f);
  };
  for (int y = w.y; y < w.y + w.height; ++y) {
    const std::uint8_t* p = prob_[y];
    for (int x = w.x; x < w.x + w.width; ++x) {
      if (p[x] <= thr) continue;
      const double dx = x - c.x, dy = y - c.y;
      sxx += dx * dx, syy += dy * dy, sxy += dx * dy, n++;
      if (touches(x, y)) jx += x, jy += y, jn++;
    }
  }
  if (jn < 2 || n < 2) return c;
  sxx /= n, syy /= n, sxy /= n;
  // Principal axis e and the half-length / half-width of a uniform bar with those moments.
  const double tr = 0.5 * (sxx + syy), det = std::sqrt(0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy);
  const double half_len = std::sqrt(3.0 * (tr + det)), half_wid = std::sqrt(3.0 * std::max(0.0, tr - det));
  const double ang = 0.5 * std::atan2(2 * sxy, sxx - syy);
  cv::Point2f e(float(std::cos(ang)), float(std::sin(ang)));
  cv::Point2f j(float(jx / jn), float(jy / jn));
  // The limb behind the junction is about as wide as the blob (a forearm's radius is a hand's
  // half-width, a shank's a foot's half-length or less); clothes around it that are wider (the other
  // trouser leg touching, the torso behind a hand) must not pull the maximum away.
  const auto cap =
      float(std::max({kLimbRadiusPerHalfLength * half_len, kLimbRadiusPerHalfWidth * half_wid, 1.5}));
  if (cv::norm(j - c) < 0.3 * half_len && half_len > 1.5 * half_wid) {
    // Cloth all around: the end of the long axis towards the head.
    const Track& head = tracks_[0];
    const cv::Point2f to_head = head.active ? head.uv - c : cv::Point2f(0, -1);
    if (e.dot(to_head) < 0) e = -e;
    jx = jy = jn = 0;
    for (int y = w.y; y < w.y + w.height; ++y) {
      const std::uint8_t* p = prob_[y];
      for (int x = w.x; x < w.x + w.width; ++x)
        if (p[x] > thr && e.dot(cv::Point2f(float(x), float(y)) - c) > 0.5 * half_len && touches(x, y))
          jx += x, jy += y, jn++;
    }
    if (jn < 1) return c + float(half_len) * e;
    j = cv::Point2f(float(jx / jn), float(jy / jn));
  }
  // The maximum of min(D, cap) - slope |p - J| over the cloth within reach of J (the blob's size: a
  // cap's centre is never farther from the junction than the blob is long), away from the blob.
  const float reach = float(m) * 0.75f + 2.0f;
  cv::Point2f toward = j - c;
  const float tl = float(cv::norm(toward));
  toward = tl > 0.5f ? toward / tl : cv::Point2f(0, 0);
  // One pass scores every cloth pixel in place of its clearance (no longer needed), the second takes
  // the pixels near the best.
  const float reach2 = reach * reach;
  float best = 0;
  for (int y = g.y; y < g.y + g.height; ++y) {
    float* d = dist[y - g.y];
    const float qy = float(y) - j.y;
    for (int x = g.x; x < g.x + g.width; ++x) {
      float& v = d[x - g.x];
      if (v <= 0) {  // not cloth
        v = -1;
        continue;
      }
      const float qx = float(x) - j.x, r2 = qx * qx + qy * qy;
      if (r2 > reach2) {
        v = -1;
        continue;
      }
      const float r = std::sqrt(r2);
      v = qx * toward.x + qy * toward.y < -0.5f * r ? -1.0f : std::min(v, cap) - kJointSlope * r;
      best = std::max(best, v);
    }
  }
  if (best <= 0) return j;
  // Sub-pixel: the centroid of the pixels within a pixel of the maximum, weighted by how close.
  double sx = 0, sy = 0, sw = 0;
  for (int y = g.y; y < g.y + g.height; ++y) {
    const float* d = dist[y - g.y];
    for (int x = g.x; x < g.x + g.width; ++x) {
      const float v = d[x - g.x] - (best - 1.0f);
      if (v > 0) sx += double(v) * x, sy += double(v) * y, sw += v;
    }
  }
  return sw > 0 ? cv::Point2f(float(sx / sw), float(sy / sw)) : j;
}

void CameraTracker::track_one(int f, const cv::Mat3b& rgb, const cv::Mat1b& mask) {
  Track& t = tracks_[static_cast<std::size_t>(f)];
  t.prev_uv = t.uv;
  t.prev_centre = t.centre;
  t.prev_velocity = t.velocity;
  const cv::Rect image(0, 0, rgb.cols, rgb.rows);
  const cv::Point2f pred = t.centre + t.velocity;
  const int w = std::max(2, t.window.width), h = std::max(2, t.window.height);
  const int m = std::max(w, h);
  const cv::Rect win =
      cv::Rect(int(std::lround(pred.x - 0.5f * float(w))), int(std::lround(pred.y - 0.5f * float(h))), w, h);
  const cv::Rect roi = cv::Rect(win.x - m, win.y - m, w + 2 * m, h + 2 * m) & image;
  cv::Rect local = (win & image) - roi.tl();
  if (roi.empty() || local.empty()) return lose(f);
  prepare(rgb, mask, roi, models_[static_cast<std::size_t>(f)]);
  // The other features' blobs are not this one's to take: touching feet or a hand by the face would
  // otherwise pull both windows onto the union. The core of every other active window (its last one,
  // or this frame's when already tracked) is blanked in this feature's back-projection.
  for (int g = 0; g < kFeatures; ++g) {
    const Track& o = tracks_[static_cast<std::size_t>(g)];
    if (g == f || !o.active) continue;
    const int sx = o.window.width / 6, sy = o.window.height / 6;
    const cv::Rect core =
        cv::Rect(o.window.x + sx, o.window.y + sy, o.window.width - 2 * sx, o.window.height - 2 * sy) & roi;
    if (!core.empty()) prob_(core).setTo(0);
  }
  cv::CamShift(prob_(roi), local, cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 10, 1));
  cv::Rect next = (local + roi.tl()) & image;
  // A window may grow with the blob (closer, less foreshortened) but not swallow a neighbour at once.
  const double grow = double(next.area()) / t.ref_area;
  if (grow > kMaxGrow) {
    const double s = std::sqrt(kMaxGrow / grow);
    const cv::Point2f cc = centre_of(next);
    const int nw = std::max(2, int(next.width * s)), nh = std::max(2, int(next.height * s));
    next = cv::Rect(int(cc.x) - nw / 2, int(cc.y) - nh / 2, nw, nh) & image;
  }
  if (next.area() < 2) return lose(f);
  const double mass = cv::sum(prob_(next))[0] / 255.0;
  const double mass_ratio = mass / t.ref_mass;
  const double area_ratio = double(next.area()) / t.ref_area;
  const cv::Point2f c = centre_of(next);
  const float moved = float(cv::norm(c - pred));
  const double inside = double(cv::countNonZero(mask(next))) / double(next.area());
  if (mass_ratio < opt_.min_mass_ratio || area_ratio < opt_.min_area_ratio ||
      area_ratio > 1.0 / opt_.min_area_ratio || inside < opt_.min_inside * 0.5 ||
      moved > float(opt_.max_jump * m + 4.0))
    return lose(f);
  t.mass_ratio = mass_ratio;
  cv::Point2f uv;
  if (!estimate_point(f, next, roi, mask, &uv)) return lose(f);
  t.velocity = 0.5f * t.velocity + 0.5f * (c - t.centre);
  t.centre = c;
  t.window = next;
  t.uv = uv;
  t.moved = moved;
  // The reference follows slow changes of size (distance, foreshortening), not a fast drop (occlusion).
  if (mass_ratio > 0.6 && mass_ratio < 1.6) {
    t.ref_mass = 0.95 * t.ref_mass + 0.05 * mass;
    t.ref_area = 0.95 * t.ref_area + 0.05 * double(next.area());
  }
  t.since_recovery = std::min(t.since_recovery + 1, opt_.recover_frames);
  const float ramp = float(t.since_recovery + 1) / float(opt_.recover_frames + 1);
  t.confidence = float(std::clamp(mass_ratio, 0.0, 1.0)) * std::min(1.0f, ramp);
}

void CameraTracker::resolve_merges() {
  for (int a = 0; a < kFeatures; ++a)
    for (int b = a + 1; b < kFeatures; ++b) {
      Track& ta = tracks_[static_cast<std::size_t>(a)];
      Track& tb = tracks_[static_cast<std::size_t>(b)];
      if (!ta.active || !tb.active || ta.partner == b || iou(ta.window, tb.window) <= opt_.merge_iou)
        continue;
      lose(ta.moved > tb.moved ? a : b);
    }
}

void CameraTracker::update_ambiguity() {
  for (int a = 0; a < kFeatures; ++a)
    for (int b = a + 1; b < kFeatures; ++b) {
      Track& ta = tracks_[static_cast<std::size_t>(a)];
      Track& tb = tracks_[static_cast<std::size_t>(b)];
      if (!ta.active || !tb.active) continue;
      const double size =
          0.5 * (std::max(ta.window.width, ta.window.height) + std::max(tb.window.width, tb.window.height));
      const double d = cv::norm(ta.centre - tb.centre);
      int& apart = since_apart_[static_cast<std::size_t>(a)][static_cast<std::size_t>(b)];
      apart = d > opt_.ambiguous_far * size ? 0 : std::min(apart + 1, 1000);
      if (ta.partner == b) {
        if (d > opt_.ambiguous_far * size) {
          part(a, b);
          continue;
        }
        ta.amb_frames++, tb.amb_frames++;
        if (ta.amb_frames > opt_.ambiguous_max_frames) part(a, b);  // together for long: decide now
        continue;
      }
      if (ta.partner >= 0 || tb.partner >= 0 || d >= opt_.ambiguous_near * size) continue;
      // Only windows that arrive: apart a moment ago and closing in. Feet standing together or a hand
      // resting by the face are near for long and stay who they are.
      const double closing = cv::norm(ta.prev_centre - tb.prev_centre) - d;
      if (apart > kArrival || closing < kClosing * size) continue;
      // They meet: predict each from where it was before this frame.
      for (auto [t, o] : {std::pair<Track*, int>{&ta, b}, std::pair<Track*, int>{&tb, a}}) {
        t->partner = o;
        t->amb_frames = 1;
        t->pred_uv = t->prev_uv;
        t->pred_centre = t->prev_centre;
        t->pred_velocity = t->prev_velocity;
      }
    }
}

// How sure feature f's window is its own, from its nearest other window: two windows closer than
// ambiguous_far of their mean size may hold each other's part (the tracker cannot tell two hands apart
// by colour), so the confidence falls linearly to kNearConfidence at ambiguous_near and below.
float CameraTracker::proximity(int f) const {
  const Track& t = tracks_[static_cast<std::size_t>(f)];
  double r = opt_.ambiguous_far;
  for (int g = 0; g < kFeatures; ++g) {
    const Track& o = tracks_[static_cast<std::size_t>(g)];
    if (g == f || !o.active) continue;
    const double size =
        0.5 * (std::max(t.window.width, t.window.height) + std::max(o.window.width, o.window.height));
    if (size > 0) r = std::min(r, cv::norm(t.centre - o.centre) / size);
  }
  const double k = (r - opt_.ambiguous_near) / (opt_.ambiguous_far - opt_.ambiguous_near);
  return float(kNearConfidence + (1.0 - kNearConfidence) * std::clamp(k, 0.0, 1.0));
}

// Two ambiguous windows have parted: each feature takes the window nearer its prediction.
void CameraTracker::part(int a, int b) {
  Track& ta = tracks_[static_cast<std::size_t>(a)];
  Track& tb = tracks_[static_cast<std::size_t>(b)];
  const cv::Point2f pa = ta.predicted_centre(ta.amb_frames), pb = tb.predicted_centre(tb.amb_frames);
  const double keep = cv::norm(ta.centre - pa) + cv::norm(tb.centre - pb);
  const double swap = cv::norm(ta.centre - pb) + cv::norm(tb.centre - pa);
  if (swap < opt_.swap_ratio * keep) {
    swap_windows(a, b);
  } else if (!(keep < opt_.swap_ratio * swap)) {
    // Neither fits clearly: which holds which is not known. Of two different parts (a hand by the head)
    // weigh both low for a while; of two alike (the hands, the feet) both are in doubt until a
    // re-acquisition settles it (settle_doubt()).
    ta.since_recovery = tb.since_recovery = 0;
    if (feature_kind(a) == feature_kind(b)) {
      ta.doubt = tb.doubt = true;
      ta.doubt_pred = pa;
      tb.doubt_pred = pb;
    }
  }
  // Each moves on as it moved before they met.
  ta.velocity = ta.pred_velocity;
  tb.velocity = tb.pred_velocity;
  ta.partner = tb.partner = -1;
  ta.amb_frames = tb.amb_frames = 0;
}

void CameraTracker::swap_windows(int a, int b) {
  Track& ta = tracks_[static_cast<std::size_t>(a)];
  Track& tb = tracks_[static_cast<std::size_t>(b)];
  std::swap(ta.window, tb.window);
  std::swap(ta.centre, tb.centre);
  std::swap(ta.uv, tb.uv);
  std::swap(ta.ref_mass, tb.ref_mass);
  std::swap(ta.ref_area, tb.ref_area);
  std::swap(ta.confidence, tb.confidence);
  std::swap(ta.velocity, tb.velocity);
  swaps_++;
}

// Feature a holds a window in doubt (re-acquired while its sibling b was lost, from a blob b could have
// been, or left alone when its ambiguous partner b was lost) and b has just been re-acquired, expected
// at pb: the doubt is settled only when the windows clearly fit the features they are with (each near
// where it was expected, as two hands parting in part()). Any other verdict, a clear swap included,
// leaves both in doubt: the expectations are those of windows whose identity was already unsure (on
// walk and cross a swap here was wrong more often than right).
void CameraTracker::settle_doubt(int a, int b, cv::Point2f pb) {
  Track& ta = tracks_[static_cast<std::size_t>(a)];
  Track& tb = tracks_[static_cast<std::size_t>(b)];
  const cv::Point2f pa = ta.doubt_pred;
  const double keep = cv::norm(ta.centre - pa) + cv::norm(tb.centre - pb);
  const double swap = cv::norm(ta.centre - pb) + cv::norm(tb.centre - pa);
  if (keep < opt_.swap_ratio * swap) {
    ta.doubt = tb.doubt = false;
    return;
  }
  tb.doubt = true;
  tb.doubt_pred = pb;
}

void CameraTracker::reacquire(const cv::Mat3b& rgb, const cv::Mat1b& mask) {
  const cv::Rect image(0, 0, rgb.cols, rgb.rows);
  const cv::Rect box = cv::boundingRect(mask);
  const cv::Rect roi = cv::Rect(box.x - 2, box.y - 2, box.width + 4, box.height + 4) & image;
  if (roi.area() < opt_.min_blob_px) return;
  prepare(rgb, mask, roi, pooled_);
  cv::Mat1b blobs = blobs_(roi);
  cv::compare(prob_(roi), opt_.prob_threshold, blobs, cv::CMP_GT);
  const int n = cv::connectedComponentsWithStats(blobs, labels_, stats_, centroids_, 8, CV_32S);
  // Every lost feature's candidate blobs (not held by an active window, within its reach of its
  // prediction); each feature in turn takes its nearest blob not taken yet.
  struct Candidate {
    double d;
    int f, k;
  };
  std::vector<Candidate> cands;
  auto reach_of = [&](const Track& t) {
    return std::min(opt_.reach_px + opt_.reach_grow * t.lost_frames, 0.5 * double(image.width)) +
           std::max(t.window.width, t.window.height);
  };
  auto blob_box = [&](int k) {
    return cv::Rect(stats_(k, cv::CC_STAT_LEFT) + roi.x, stats_(k, cv::CC_STAT_TOP) + roi.y,
                    stats_(k, cv::CC_STAT_WIDTH), stats_(k, cv::CC_STAT_HEIGHT));
  };
  std::array<bool, 64> held{};
  for (int k = 1; k < n && k < int(held.size()); ++k) {
    const cv::Rect b = blob_box(k);
    for (const Track& o : tracks_)
      if (o.active && ((o.window & b).area() > 0)) held[static_cast<std::size_t>(k)] = true;
  }
  for (int f = 0; f < kFeatures; ++f) {
    const Track& t = tracks_[static_cast<std::size_t>(f)];
    if (!t.seen || t.active) continue;
    const double reach = reach_of(t);
    for (int k = 1; k < n && k < int(held.size()); ++k) {
      if (held[static_cast<std::size_t>(k)]) continue;
      const int area = stats_(k, cv::CC_STAT_AREA);
      if (area < opt_.min_blob_px || double(area) < 0.15 * t.ref_area) continue;
      const double d = cv::norm(centre_of(blob_box(k)) - t.predicted_centre(t.lost_frames));
      if (d < reach) cands.push_back({d, f, k});
    }
  }
  std::sort(cands.begin(), cands.end(), [](const Candidate& a, const Candidate& b) {
    return a.f < b.f || (a.f == b.f && (a.d < b.d || (a.d == b.d && a.k < b.k)));
  });
  std::array<bool, 64> taken{};
  std::array<cv::Point2f, kFeatures> expected{};
  for (int f = 0; f < kFeatures; ++f) {
    const Track& t = tracks_[static_cast<std::size_t>(f)];
    expected[static_cast<std::size_t>(f)] = t.predicted_centre(t.lost_frames);
  }
  std::array<bool, kFeatures> done{};
  for (const Candidate& c : cands) {
    if (taken[static_cast<std::size_t>(c.k)] || done[static_cast<std::size_t>(c.f)]) continue;
    Track& t = tracks_[static_cast<std::size_t>(c.f)];
    if (t.active) continue;
    taken[static_cast<std::size_t>(c.k)] = done[static_cast<std::size_t>(c.f)] = true;
    const cv::Rect b = blob_box(c.k);
    adopt(c.f, b, roi, mask, true);
    reacquired_++;
    // The other hand or foot (same colour, same shape): when it is lost too and this blob was within its
    // reach, the blob may be its part; when it holds a window in doubt, the two are settled now.
    for (int g = 0; g < kFeatures; ++g) {
      if (g == c.f || feature_kind(g) != feature_kind(c.f)) continue;
      Track& o = tracks_[static_cast<std::size_t>(g)];
      if (o.active && o.doubt) {
        settle_doubt(g, c.f, expected[static_cast<std::size_t>(c.f)]);
      } else if (o.seen && !o.active &&
                 cv::norm(centre_of(b) - expected[static_cast<std::size_t>(g)]) < reach_of(o)) {
        t.doubt = true;
        t.doubt_pred = expected[static_cast<std::size_t>(c.f)];
      }
    }
  }
}

// A foot (or hand) whose seed fell on its sibling's blob at init (the feet together seen from the side,
// one behind the other: one blob, which the sibling took) was never tracked in this camera, and the
// sibling's single window followed whichever of the two parts it happened to keep once they parted —
// in walking, the front foot or the back one, step after step (a confident window on the wrong foot
// half the time; the other foot never reported). It joins at the first frame a skin blob no window
// holds lies beside the sibling's window (its centre within kJoinReach of the window's size, at least
// kJoinArea of the sibling's reference: a part, not a crumb of floor), while the sibling is tracked
// and not ambiguous. The two are then named by the seeder's rule, the rule that could not be applied
// at init: by image side as if the camera faced the performer (the performer's left part on the
// image's right), and both restart their confidence ramp (the sibling's window may just have changed
// its name). Looked for every kJoinEvery frames, around the sibling only (feet that never part, as
// in a squat seen from the side, cost a small labelling every few frames).
void CameraTracker::join_siblings(const cv::Mat3b& rgb, const cv::Mat1b& mask) {
  if (++join_tick_ % kJoinEvery != 0) return;
  const cv::Rect image(0, 0, rgb.cols, rgb.rows);
  for (int f = 0; f < kFeatures; ++f) {
    if (!tracks_[static_cast<std::size_t>(f)].joins || tracks_[static_cast<std::size_t>(f)].seen) continue;
    int g = -1;
    for (int k = 0; k < kFeatures; ++k)
      if (k != f && feature_kind(k) == feature_kind(f)) g = k;
    const Track& s = tracks_[static_cast<std::size_t>(g)];
    if (!s.active || s.partner >= 0 || s.doubt) continue;
    const int size = std::max(s.window.width, s.window.height);
    const int r = int(std::ceil(kJoinReach * size)) + 2;
    const cv::Point2f sc = s.centre;
    const cv::Rect roi = cv::Rect(int(sc.x) - r, int(sc.y) - r, 2 * r + 1, 2 * r + 1) & image;
    if (roi.area() < opt_.min_blob_px) continue;
    prepare(rgb, mask, roi, pooled_);
    cv::Mat1b blobs = blobs_(roi);
    cv::compare(prob_(roi), opt_.prob_threshold, blobs, cv::CMP_GT);
    const int n = cv::connectedComponentsWithStats(blobs, labels_, stats_, centroids_, 8, CV_32S);
    auto blob_box = [&](int k) {
      return cv::Rect(stats_(k, cv::CC_STAT_LEFT) + roi.x, stats_(k, cv::CC_STAT_TOP) + roi.y,
                      stats_(k, cv::CC_STAT_WIDTH), stats_(k, cv::CC_STAT_HEIGHT));
    };
    int best = -1;
    double best_d = kJoinReach * size;
    for (int k = 1; k < n; ++k) {
      const int area = stats_(k, cv::CC_STAT_AREA);
      if (area < opt_.min_blob_px || double(area) < kJoinArea * s.ref_area) continue;
      const cv::Rect b = blob_box(k);
      bool held = false;
      for (const Track& o : tracks_) held |= o.active && (o.window & b).area() > 0;
      const double d = cv::norm(centre_of(b) - sc);
      if (!held && d < best_d) best_d = d, best = k;
    }
    if (best < 0) continue;
    {  // the sibling's reference was learnt on the blob of both parts
      Track& sib = tracks_[static_cast<std::size_t>(g)];
      sib.ref_mass = std::max(1.0, cv::sum(prob_(sib.window & roi))[0] / 255.0);
      sib.ref_area = std::max(1, sib.window.area());
    }
    adopt(f, blob_box(best), roi, mask, true);
    tracks_[static_cast<std::size_t>(f)].joins = false;
    reacquired_++;
    // Features 1 and 3 are the performer's left hand and foot: the image's right.
    const int left = std::min(f, g), right = std::max(f, g);
    if (tracks_[static_cast<std::size_t>(left)].uv.x < tracks_[static_cast<std::size_t>(right)].uv.x)
      std::swap(tracks_[static_cast<std::size_t>(left)], tracks_[static_cast<std::size_t>(right)]);
    for (int k : {f, g}) {
      Track& t = tracks_[static_cast<std::size_t>(k)];
      t.since_recovery = 0;
      t.confidence = std::min(t.confidence, 1.0f / float(opt_.recover_frames + 1));
    }
  }
}

void CameraTracker::process(const cv::Mat3b& rgb, const cv::Mat1b& mask, FrameReport* out) {
  *out = FrameReport{};
  if (rgb.empty() || mask.size() != rgb.size()) return;
  if (rgb.size() != size_) {
    size_ = rgb.size();
    hsv_.create(size_);
    prob_.create(size_);
    region_.create(size_);
    blobs_.create(size_);
    cloth_.create(size_);
    dist_.create(size_);
    prob_.setTo(0);
    reset();
  }
  if (phase_ == Phase::init) {
    Seeds seeds;
    std::string why;
    if (seeder_(mask, &seeds, &why)) {
      learn_frame(rgb, mask, seeds);
      last_seeds_ = seeds;
      if (++init_done_ >= opt_.init_frames) start_tracking(rgb, mask, seeds);
    } else {
      seed_why_ = why;
    }
    if (phase_ == Phase::init) return;
  } else {
    for (int f = 0; f < kFeatures; ++f)
      if (tracks_[static_cast<std::size_t>(f)].active) track_one(f, rgb, mask);
    update_ambiguity();
    resolve_merges();
    bool any_lost = false, any_joins = false;
    for (const Track& t : tracks_) any_lost |= t.seen && !t.active, any_joins |= t.joins;
    if (any_lost) reacquire(rgb, mask);
    if (any_joins) join_siblings(rgb, mask);
    for (Track& t : tracks_)
      if (t.seen && !t.active) t.lost_frames++;
  }
  for (int f = 0; f < kFeatures; ++f) {
    const Track& t = tracks_[static_cast<std::size_t>(f)];
    FeatureReport& r = (*out)[static_cast<std::size_t>(f)];
    if (!t.seen) continue;  // never seen in this camera: not_visible
    if (t.active && t.partner >= 0) {
      r.state = FeatureState::predicted;
      r.uv = t.predicted_uv(t.amb_frames);
      r.confidence =
          opt_.predicted_confidence * (1.0f - float(t.amb_frames) / float(opt_.ambiguous_max_frames + 1));
    } else if (t.active) {
      r.state = FeatureState::tracking;
      r.uv = t.uv;
      r.confidence = std::clamp(t.confidence, 0.0f, 1.0f) * proximity(f);
      if (t.doubt) r.confidence = std::min(r.confidence, kDoubtConfidence);
    } else if (t.lost_frames <= opt_.predict_frames) {
      r.state = FeatureState::predicted;
      r.uv = t.predicted_uv(t.lost_frames);
      r.confidence =
          opt_.predicted_confidence * (1.0f - float(t.lost_frames) / float(opt_.predict_frames + 1));
    } else {
      r.state = FeatureState::lost;
      r.uv = t.uv;
      r.confidence = 0.0f;
    }
    r.confidence = std::clamp(r.confidence, 0.0f, 1.0f);
  }
}

}  // namespace vc::track
