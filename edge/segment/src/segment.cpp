// GVD segmentation of the initialization silhouette (paper section 5; shared/paper-notes.md).
//
// The Generalized Voronoi Diagram of a silhouette is the set of its points equidistant to at least
// two boundary points: the medial axis. Along it, the clearance (distance to the background) is
// small where the body narrows (neck, wrists, ankles) and large inside the head, torso and hands,
// so its local minima, the critical points, are where body parts meet; the line through the two
// boundary points nearest a critical point cuts them apart. The pieces and the cuts between them
// form a graph whose leaves, in the initialization pose, are head, hands and feet.
//
// Discretely: cv::distanceTransform with DIST_LABEL_PIXEL gives every silhouette pixel its nearest
// background pixel z(p) (5x5 chamfer propagation: nearly, not exactly, the Euclidean nearest). A
// pixel is on the GVD when a 4-neighbour's nearest background pixel is more than gvd_ratio x the
// clearance away from its own, i.e. its two nearest boundary points subtend an angle of more than
// 2 asin(gvd_ratio / 2) (74 degrees at 1.2): bumps of a ragged outline subtend less and leave no
// spur (the "theta-medial axis"). Of each such pair the pixel with the larger clearance is kept,
// so the GVD is about one pixel wide. A critical point is a GVD pixel whose clearance is the
// smallest (ties by position) of the GVD within window_ratio x clearance along the GVD and from
// which the clearance rises by rise_ratio on at least two of the GVD's branches leaving it.
//
// Limits: a part hidden inside the silhouette (an arm in front of the torso) has no terminal; two
// parts that touch (feet of legs held together) make one, which is split by the image's column
// through the middle of the cut; a camera looking along the arms sees no constriction at the wrist
// (the near hand is then the arm's extremity, the far one beside the head or hidden: not_visible).
// Then segment() says what it found instead of guessing.
#include "voxcap/edge/segment.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <queue>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace vc::segment {

const char* feature_name(int f) {
  static const char* const names[kFeatures] = {"head", "left_hand", "right_hand", "left_foot", "right_foot"};
  return f >= 0 && f < kFeatures ? names[f] : "?";
}

bool Options::valid(std::string* why) const {
  auto bad = [why](const char* what) {
    if (why) *why = what;
    return false;
  };
  if (max_width < 8 || max_width > 16384 || max_height < 8 || max_height > 16384)
    return bad("max_width and max_height must be 8..16384");
  if (min_area_px < 16) return bad("min_area_px must be >= 16");
  if (min_height_px < 8) return bad("min_height_px must be >= 8");
  if (!(smooth_ratio >= 0 && smooth_ratio <= 0.05)) return bad("smooth_ratio must be 0..0.05");
  if (!(gvd_ratio >= 0.5 && gvd_ratio <= 1.9)) return bad("gvd_ratio must be 0.5..1.9");
  if (!(window_ratio >= 1 && window_ratio <= 10)) return bad("window_ratio must be 1..10");
  if (!(min_ratio >= 0.5 && min_ratio <= window_ratio)) return bad("min_ratio must be 0.5..window_ratio");
  if (!(min_window_px >= 1 && min_window_px <= 100)) return bad("min_window_px must be 1..100");
  if (!(rise_ratio > 0 && rise_ratio <= 2)) return bad("rise_ratio must be in (0, 2]");
  if (!(min_region_ratio >= 0 && min_region_ratio <= 0.1)) return bad("min_region_ratio must be 0..0.1");
  if (!(foot_band_ratio > 0 && foot_band_ratio <= 0.5)) return bad("foot_band_ratio must be in (0, 0.5]");
  if (!(head_band_ratio > 0 && head_band_ratio <= 0.6)) return bad("head_band_ratio must be in (0, 0.6]");
  if (!(head_top_ratio > 0 && head_top_ratio <= 0.3)) return bad("head_top_ratio must be in (0, 0.3]");
  if (!(head_disc_ratio >= 0 && head_disc_ratio <= 0.1)) return bad("head_disc_ratio must be 0..0.1");
  if (!(max_head_ratio > head_disc_ratio && max_head_ratio <= 0.5))
    return bad("max_head_ratio must be in (head_disc_ratio, 0.5]");
  if (!(wrist_shift >= 0 && wrist_shift <= 5)) return bad("wrist_shift must be 0..5");
  if (!(hand_ratio > 0 && hand_ratio <= 0.3)) return bad("hand_ratio must be in (0, 0.3]");
  if (!(ankle_ratio >= 0 && ankle_ratio <= 0.2)) return bad("ankle_ratio must be 0..0.2");
  if (why) why->clear();
  return true;
}

namespace {

const cv::Point kN8[8] = {{-1, -1}, {0, -1}, {1, -1}, {-1, 0}, {1, 0}, {-1, 1}, {0, 1}, {1, 1}};
const cv::Point kN4[4] = {{0, -1}, {-1, 0}, {1, 0}, {0, 1}};

// The largest 8-connected component of a 0/255 image (255 in *out), its box and area; false if none.
bool largest_component(const cv::Mat1b& m, cv::Mat1b* out, cv::Rect* box, int* area) {
  cv::Mat1i lab;
  cv::Mat stats, centroids;
  const int n = cv::connectedComponentsWithStats(m, lab, stats, centroids, 8, CV_32S);
  int best = -1, best_area = 0;
  for (int i = 1; i < n; i++) {
    const int a = stats.at<int>(i, cv::CC_STAT_AREA);
    if (a > best_area) best = i, best_area = a;
  }
  if (best < 0) return false;
  *out = lab == best;
  *box = cv::Rect(stats.at<int>(best, cv::CC_STAT_LEFT), stats.at<int>(best, cv::CC_STAT_TOP),
                  stats.at<int>(best, cv::CC_STAT_WIDTH), stats.at<int>(best, cv::CC_STAT_HEIGHT));
  *area = best_area;
  return true;
}

// Fills the holes of a 0/255 image whose border is background.
void fill_holes(cv::Mat1b& m) {
  cv::Mat1b outside = m.clone();
  cv::floodFill(outside, cv::Point(0, 0), cv::Scalar(128), nullptr, cv::Scalar(0), cv::Scalar(0), 4);
  m.setTo(255, outside == 0);
}

struct UnionFind {
  std::vector<int> parent;
  explicit UnionFind(int n) : parent(static_cast<size_t>(n)) { std::iota(parent.begin(), parent.end(), 0); }
  int find(int i) {
    while (parent[static_cast<size_t>(i)] != i) {
      parent[static_cast<size_t>(i)] = parent[static_cast<size_t>(parent[static_cast<size_t>(i)])];
      i = parent[static_cast<size_t>(i)];
    }
    return i;
  }
};

// The work of one segmentation, on the silhouette's box padded with background (local coordinates;
// `origin` is the image position of local (0, 0)).
class Work {
 public:
  Work(const Options& opt, cv::Mat1b sil, cv::Point origin)
      : opt_(opt), sil_(std::move(sil)), origin_(origin) {}

  void run(Segmentation* s);

 private:
  bool fg(int x, int y) const {
    return x >= 0 && y >= 0 && x < sil_.cols && y < sil_.rows && sil_(y, x) != 0;
  }
  cv::Point nearest(int x, int y) const { return zero_at_[static_cast<size_t>(near_(y, x))]; }
  float clear(int x, int y) const { return dist_(y, x); }

  void distance();
  void medial_axis();
  void critical_points();
  bool is_critical(int g, std::vector<int>* seen, int stamp, int* steps_to_rise);
  void cut(cv::Point c, Cut* out, cv::Point* far_pixel) const;
  void regions(Segmentation* s);
  void terminals(Segmentation* s);
  bool find_feet(Segmentation* s, float axis_x);  // axis_x: local column
  void geodesic(cv::Point from);
  cv::Point region_tip(int id) const;
  std::vector<cv::Point> extremities(double height) const;
  cv::Point2f wrist_from_tip(cv::Point tip, double len, float max_arm) const;
  double protrusion(cv::Point tip, float max_arm, float* thickest) const;
  void export_images(Segmentation* s) const;

  const Options& opt_;
  cv::Mat1b sil_;
  cv::Point origin_;
  cv::Mat1f dist_;                  // |p - z(p)| per silhouette pixel
  cv::Mat1i near_;                  // label of z(p)
  std::vector<cv::Point> zero_at_;  // label -> background pixel
  cv::Mat1b gvd_;
  cv::Mat1i gvd_index_;  // index into gvd_pts_, -1 elsewhere
  std::vector<cv::Point> gvd_pts_;
  std::vector<cv::Point> critical_;
  std::vector<Cut> cuts_;  // local coordinates until exported
  cv::Mat1i labels_;       // region id, -1 background
  cv::Mat1f geo_;          // geodesic distance from the head's centre, -1 outside
  float head_radius_ = 0;  // the head's clearance at its centre
  std::vector<Region> regions_;
  std::vector<std::pair<int, int>> cut_sides_;  // per cut: the two regions
  std::vector<std::pair<int, int>> queue_;      // is_critical's scratch
  std::vector<int> stack_;
};

void Work::distance() {
  cv::distanceTransform(sil_, dist_, near_, cv::DIST_L2, cv::DIST_MASK_5, cv::DIST_LABEL_PIXEL);
  double lo = 0, hi = 0;
  cv::minMaxLoc(near_, &lo, &hi);
  zero_at_.assign(static_cast<size_t>(std::max(0.0, hi)) + 1, cv::Point(0, 0));
  for (int y = 0; y < sil_.rows; y++)
    for (int x = 0; x < sil_.cols; x++)
      if (!sil_(y, x)) {
        const int l = near_(y, x);
        if (l >= 0 && static_cast<size_t>(l) < zero_at_.size()) zero_at_[static_cast<size_t>(l)] = {x, y};
      }
  for (int y = 0; y < sil_.rows; y++)
    for (int x = 0; x < sil_.cols; x++) {
      if (!sil_(y, x)) {
        dist_(y, x) = 0;
        continue;
      }
      int l = near_(y, x);
      if (l < 0 || static_cast<size_t>(l) >= zero_at_.size()) near_(y, x) = l = 0;
      const cv::Point z = zero_at_[static_cast<size_t>(l)];
      dist_(y, x) = static_cast<float>(std::hypot(x - z.x, y - z.y));
    }
}

void Work::medial_axis() {
  gvd_ = cv::Mat1b::zeros(sil_.size());
  const double r2 = opt_.gvd_ratio * opt_.gvd_ratio;
  for (int y = 0; y < sil_.rows; y++)
    for (int x = 0; x < sil_.cols; x++) {
      if (!sil_(y, x)) continue;
      const cv::Point zp = nearest(x, y);
      const cv::Point qs[2] = {{x + 1, y}, {x, y + 1}};
      for (const cv::Point& q : qs) {
        if (!fg(q.x, q.y)) continue;
        const cv::Point zq = nearest(q.x, q.y);
        const double dx = zp.x - zq.x, dy = zp.y - zq.y, sep2 = dx * dx + dy * dy;
        const bool keep_p = clear(x, y) >= clear(q.x, q.y);
        const double d = keep_p ? clear(x, y) : clear(q.x, q.y);
        if (sep2 >= 4 && sep2 > r2 * d * d) {
          if (keep_p)
            gvd_(y, x) = 255;
          else
            gvd_(q) = 255;
        }
      }
    }
  gvd_index_ = cv::Mat1i(sil_.size(), -1);
  gvd_pts_.clear();
  for (int y = 0; y < sil_.rows; y++)
    for (int x = 0; x < sil_.cols; x++)
      if (gvd_(y, x)) {
        gvd_index_(y, x) = static_cast<int>(gvd_pts_.size());
        gvd_pts_.emplace_back(x, y);
      }
}

// Whether GVD pixel g is a candidate critical point: no GVD pixel within its window (along the GVD)
// has a clearly smaller clearance, the GVD leaves it on at least two branches, and on at least one
// of them the clearance rises by rise_ratio within the window (on a limb of even width ending in a
// wider hand the wrist rises on the hand's side only). *steps_to_rise: how far along the GVD the
// nearest such rise is (on a plateau, the pixel next to the rise wins). `seen` holds a stamp per
// GVD pixel (visited in this call when equal to `stamp`).
bool Work::is_critical(int g, std::vector<int>* seen, int stamp, int* steps_to_rise) {
  const cv::Point p = gvd_pts_[static_cast<size_t>(g)];
  const float dp = clear(p.x, p.y);
  if (dp < 1.0F) return false;
  const int reach = static_cast<int>(std::ceil(std::max(opt_.min_window_px, opt_.window_ratio * dp)));
  const float tol = std::max(0.3F, 0.04F * dp);
  const int min_reach = static_cast<int>(std::ceil(std::max(opt_.min_window_px, opt_.min_ratio * dp)));
  // Breadth-first along the GVD (8-connected), `reach` steps.
  std::vector<std::pair<int, int>>& q = queue_;  // (gvd index, steps)
  q.clear();
  q.emplace_back(g, 0);
  (*seen)[static_cast<size_t>(g)] = stamp;
  for (size_t h = 0; h < q.size(); h++) {
    const auto [i, steps] = q[h];
    const cv::Point a = gvd_pts_[static_cast<size_t>(i)];
    // A minimum near p only: farther away the window may reach into a thinner branch (an arm
    // beside the neck), which is another constriction.
    if (clear(a.x, a.y) < dp - tol && steps <= min_reach) return false;
    if (steps == reach) continue;
    for (const cv::Point& o : kN8) {
      const cv::Point b = a + o;
      if (b.x < 0 || b.y < 0 || b.x >= sil_.cols || b.y >= sil_.rows) continue;
      const int j = gvd_index_(b);
      if (j < 0 || (*seen)[static_cast<size_t>(j)] == stamp) continue;
      (*seen)[static_cast<size_t>(j)] = stamp;
      q.emplace_back(j, steps + 1);
    }
  }
  // Branches: the window without p's 3x3, in 8-connected pieces (their pixels in BFS order, so the
  // first pixel of a branch reaching the rise is its nearest).
  const float want = dp * static_cast<float>(1.0 + opt_.rise_ratio);
  const int branch_stamp = -stamp;  // marks a pixel already given a branch
  int branches = 0, nearest_rise = -1;
  std::vector<int>& stack = stack_;
  for (const auto& [i0, steps0] : q) {
    const cv::Point a0 = gvd_pts_[static_cast<size_t>(i0)];
    if (std::abs(a0.x - p.x) <= 1 && std::abs(a0.y - p.y) <= 1) continue;
    if ((*seen)[static_cast<size_t>(i0)] != stamp) continue;  // already in a branch
    branches++;
    stack.assign(1, i0);
    (*seen)[static_cast<size_t>(i0)] = branch_stamp;
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      const cv::Point a = gvd_pts_[static_cast<size_t>(i)];
      if (clear(a.x, a.y) >= want) {
        const int steps = std::max(std::abs(a.x - p.x), std::abs(a.y - p.y));
        if (nearest_rise < 0 || steps < nearest_rise) nearest_rise = steps;
      }
      for (const cv::Point& o : kN8) {
        const cv::Point b = a + o;
        if (b.x < 0 || b.y < 0 || b.x >= sil_.cols || b.y >= sil_.rows) continue;
        if (std::abs(b.x - p.x) <= 1 && std::abs(b.y - p.y) <= 1) continue;
        const int j = gvd_index_(b);
        if (j < 0 || (*seen)[static_cast<size_t>(j)] != stamp) continue;
        (*seen)[static_cast<size_t>(j)] = branch_stamp;
        stack.push_back(j);
      }
    }
  }
  *steps_to_rise = nearest_rise;
  return branches >= 2 && nearest_rise >= 0;
}

// Candidates by increasing clearance (then nearest rise first); a candidate within the window of
// one already taken is the same constriction.
void Work::critical_points() {
  critical_.clear();
  struct Cand {
    cv::Point p;
    float d;
    int rise;
  };
  std::vector<Cand> cands;
  std::vector<int> seen(gvd_pts_.size(), 0);
  for (size_t g = 0; g < gvd_pts_.size(); g++) {
    int rise = 0;
    if (is_critical(static_cast<int>(g), &seen, static_cast<int>(g) + 1, &rise))
      cands.push_back({gvd_pts_[g], clear(gvd_pts_[g].x, gvd_pts_[g].y), rise});
  }
  std::sort(cands.begin(), cands.end(), [](const Cand& a, const Cand& b) {
    const float qa = std::floor(a.d * 2), qb = std::floor(b.d * 2);  // half-pixel classes
    if (qa != qb) return qa < qb;
    if (a.rise != b.rise) return a.rise < b.rise;
    return a.d < b.d;
  });
  std::vector<float> reach;
  for (const Cand& c : cands) {
    bool near = false;
    for (size_t k = 0; k < critical_.size() && !near; k++) {
      const cv::Point v = c.p - critical_[k];
      near = std::hypot(v.x, v.y) < reach[k];
    }
    if (near) continue;
    critical_.push_back(c.p);
    reach.push_back(static_cast<float>(std::max(opt_.min_window_px, opt_.window_ratio * c.d)));
  }
}

// The cut through critical point c: its nearest background pixel a, and the nearest background
// pixel of a pixel near c that lies farthest from a (the other side of the constriction); both
// moved half a pixel towards c, onto the outline.
void Work::cut(cv::Point c, Cut* out, cv::Point* far_pixel) const {
  const cv::Point a = nearest(c.x, c.y);
  const float dc = clear(c.x, c.y);
  cv::Point b = a;
  double far2 = -1;
  for (int dy = -2; dy <= 2; dy++)
    for (int dx = -2; dx <= 2; dx++) {
      if (!fg(c.x + dx, c.y + dy)) continue;
      const cv::Point z = nearest(c.x + dx, c.y + dy);
      if (std::hypot(z.x - c.x, z.y - c.y) > dc + 1.5) continue;
      const double d2 =
          static_cast<double>(z.x - a.x) * (z.x - a.x) + static_cast<double>(z.y - a.y) * (z.y - a.y);
      if (d2 > far2) far2 = d2, b = z;
    }
  auto onto_outline = [c](cv::Point z) {
    const cv::Point2f v(static_cast<float>(c.x - z.x), static_cast<float>(c.y - z.y));
    const float n = std::hypot(v.x, v.y);
    return n > 0 ? cv::Point2f(static_cast<float>(z.x), static_cast<float>(z.y)) + v * (0.5F / n)
                 : cv::Point2f(static_cast<float>(z.x), static_cast<float>(z.y));
  };
  out->critical = c;
  out->a = onto_outline(a);
  out->b = onto_outline(b);
  out->clearance = dc;
  *far_pixel = b;
}

void Work::regions(Segmentation* s) {
  // Every critical point's cut, rasterised between the two background pixels (8-connected, so the
  // 4-connected pieces on either side do not touch).
  std::vector<Cut> cand;
  std::vector<std::pair<cv::Point, cv::Point>> ends;
  cv::Mat1b cuts = cv::Mat1b::zeros(sil_.size());
  for (const cv::Point& c : critical_) {
    Cut k;
    cv::Point b;
    cut(c, &k, &b);
    const cv::Point a = nearest(c.x, c.y);
    cand.push_back(k);
    ends.emplace_back(a, b);
    cv::line(cuts, a, b, cv::Scalar(255), 1, cv::LINE_8);
  }
  cv::Mat1b pieces = sil_ & ~cuts;
  cv::Mat1i lab;
  const int n = cv::connectedComponents(pieces, lab, 4, CV_32S);  // 0 = background or cut
  std::vector<int> area(static_cast<size_t>(n), 0);
  for (int y = 0; y < lab.rows; y++)
    for (int x = 0; x < lab.cols; x++) area[static_cast<size_t>(lab(y, x))]++;

  // Which pieces each cut separates: the pieces 4-adjacent to its own pixels.
  std::vector<std::vector<int>> sides(cand.size());
  for (size_t k = 0; k < cand.size(); k++) {
    cv::LineIterator it(cuts, ends[k].first, ends[k].second, 8);
    for (int i = 0; i < it.count; i++, ++it) {
      const cv::Point p = it.pos();
      for (const cv::Point& o : kN4) {
        const cv::Point b = p + o;
        if (!fg(b.x, b.y)) continue;
        const int l = lab(b);
        if (l > 0 && std::find(sides[k].begin(), sides[k].end(), l) == sides[k].end()) sides[k].push_back(l);
      }
    }
  }
  // Tiny pieces (slivers between crossing cuts, the tip beyond a spurious constriction) join their
  // largest neighbour, smallest first.
  UnionFind uf(n);
  int total = 0;
  for (int i = 1; i < n; i++) total += area[static_cast<size_t>(i)];
  const int min_area = std::max(4, static_cast<int>(opt_.min_region_ratio * total));
  std::vector<int> order(static_cast<size_t>(std::max(0, n - 1)));
  std::iota(order.begin(), order.end(), 1);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return area[static_cast<size_t>(a)] < area[static_cast<size_t>(b)]; });
  for (int piece : order) {
    const int r = uf.find(piece);
    if (area[static_cast<size_t>(r)] >= min_area) continue;
    int best = -1;
    for (const auto& sd : sides) {
      bool has = false;
      for (int l : sd) has = has || uf.find(l) == r;
      if (!has) continue;
      for (int l : sd) {
        const int o = uf.find(l);
        if (o != r && (best < 0 || area[static_cast<size_t>(o)] > area[static_cast<size_t>(best)])) best = o;
      }
    }
    if (best < 0) continue;
    uf.parent[static_cast<size_t>(r)] = best;
    area[static_cast<size_t>(best)] += area[static_cast<size_t>(r)];
  }
  // Compact ids: region i is the i-th distinct root in piece order.
  std::vector<int> id_of(static_cast<size_t>(n), -1);
  int regions = 0;
  for (int i = 1; i < n; i++) {
    const int r = uf.find(i);
    if (id_of[static_cast<size_t>(r)] < 0) id_of[static_cast<size_t>(r)] = regions++;
    id_of[static_cast<size_t>(i)] = id_of[static_cast<size_t>(r)];
  }
  labels_ = cv::Mat1i(sil_.size(), -1);
  for (int y = 0; y < lab.rows; y++)
    for (int x = 0; x < lab.cols; x++)
      if (lab(y, x) > 0) labels_(y, x) = id_of[static_cast<size_t>(lab(y, x))];
  // Cut pixels inside the silhouette join a 4-neighbour's region (a cut is at most a few pixels
  // thick where cuts cross, so a few passes settle them all).
  for (int pass = 0; pass < 4; pass++) {
    bool left = false;
    for (int y = 0; y < sil_.rows; y++)
      for (int x = 0; x < sil_.cols; x++) {
        if (!sil_(y, x) || labels_(y, x) >= 0) continue;
        for (const cv::Point& o : kN4)
          if (fg(x + o.x, y + o.y) && labels_(y + o.y, x + o.x) >= 0) {
            labels_(y, x) = labels_(y + o.y, x + o.x);
            break;
          }
        left = left || labels_(y, x) < 0;
      }
    if (!left) break;
  }
  // Keep the cuts that separate two regions; they are the graph's edges.
  regions_.assign(static_cast<size_t>(regions), Region{});
  cuts_.clear();
  cut_sides_.clear();
  for (size_t k = 0; k < cand.size(); k++) {
    std::vector<int> ids;
    for (int l : sides[k]) {
      const int id = id_of[static_cast<size_t>(l)];
      if (std::find(ids.begin(), ids.end(), id) == ids.end()) ids.push_back(id);
    }
    if (ids.size() != 2) continue;  // inside one region, or where cuts cross (ambiguous)
    cuts_.push_back(cand[k]);
    cut_sides_.emplace_back(ids[0], ids[1]);
    regions_[static_cast<size_t>(ids[0])].neighbours.push_back(ids[1]);
    regions_[static_cast<size_t>(ids[1])].neighbours.push_back(ids[0]);
  }
  std::vector<double> sx(static_cast<size_t>(regions), 0), sy(static_cast<size_t>(regions), 0);
  std::vector<cv::Point> lo(static_cast<size_t>(regions), cv::Point(sil_.cols, sil_.rows));
  std::vector<cv::Point> hi(static_cast<size_t>(regions), cv::Point(-1, -1));
  for (int y = 0; y < sil_.rows; y++)
    for (int x = 0; x < sil_.cols; x++) {
      const int id = labels_(y, x);
      if (id < 0) continue;
      Region& r = regions_[static_cast<size_t>(id)];
      r.area++;
      sx[static_cast<size_t>(id)] += x;
      sy[static_cast<size_t>(id)] += y;
      cv::Point& l = lo[static_cast<size_t>(id)];
      cv::Point& h = hi[static_cast<size_t>(id)];
      l.x = std::min(l.x, x), l.y = std::min(l.y, y), h.x = std::max(h.x, x), h.y = std::max(h.y, y);
    }
  for (int i = 0; i < regions; i++) {
    Region& r = regions_[static_cast<size_t>(i)];
    r.id = i;
    std::sort(r.neighbours.begin(), r.neighbours.end());
    r.neighbours.erase(std::unique(r.neighbours.begin(), r.neighbours.end()), r.neighbours.end());
    const cv::Point l = lo[static_cast<size_t>(i)], h = hi[static_cast<size_t>(i)];
    if (r.area > 0) {
      r.box = cv::Rect(l + origin_, h + origin_ + cv::Point(1, 1));
      r.centroid = cv::Point2f(static_cast<float>(sx[static_cast<size_t>(i)] / r.area + origin_.x),
                               static_cast<float>(sy[static_cast<size_t>(i)] / r.area + origin_.y));
    }
  }
  (void)s;
}

void Work::export_images(Segmentation* s) const {
  // Local -> image: the part of the padded box inside the image.
  const cv::Rect img(0, 0, s->distance.cols, s->distance.rows);
  const cv::Rect local(origin_, sil_.size());
  const cv::Rect both = local & img;
  if (both.empty()) return;
  const cv::Rect src(both.tl() - origin_, both.size());
  if (!dist_.empty()) dist_(src).copyTo(s->distance(both));
  if (!gvd_.empty()) gvd_(src).copyTo(s->gvd(both));
  if (!labels_.empty()) labels_(src).copyTo(s->labels(both));
  s->critical.clear();
  for (const cv::Point& c : critical_) s->critical.push_back(c + origin_);
  s->cuts = cuts_;
  const cv::Point2f o(static_cast<float>(origin_.x), static_cast<float>(origin_.y));
  for (Cut& k : s->cuts) {
    k.critical += origin_;
    k.a += o;
    k.b += o;
  }
  s->regions = regions_;
}

void Work::terminals(Segmentation* s) {
  // Image coordinates from here on (regions_ are already there).
  std::vector<int> leaves;
  for (const Region& r : regions_)
    if (r.neighbours.size() == 1) leaves.push_back(r.id);
  cv::Rect box = cv::boundingRect(sil_);
  box += origin_;
  const double top = box.y, height = box.height, bottom = box.y + box.height - 1;
  // The body's axis: the median column of the silhouette over the hips (below the arms, above the
  // feet in the initialization pose).
  std::vector<int> xs;
  const int y0 = static_cast<int>(top + 0.45 * height) - origin_.y;
  const int y1 = static_cast<int>(top + 0.65 * height) - origin_.y;
  for (int y = std::max(0, y0); y <= std::min(sil_.rows - 1, y1); y++)
    for (int x = 0; x < sil_.cols; x++)
      if (sil_(y, x)) xs.push_back(x + origin_.x);
  if (xs.empty()) {
    s->why = "no silhouette at the hips";
    return;
  }
  std::nth_element(xs.begin(), xs.begin() + static_cast<std::ptrdiff_t>(xs.size() / 2), xs.end());
  const double axis_x = xs[xs.size() / 2];

  // The cut joining a leaf to the rest (the narrowest if several).
  auto leaf_cut = [&](int id) -> const Cut* {
    const Cut* best = nullptr;
    for (size_t k = 0; k < cuts_.size(); k++)
      if ((cut_sides_[k].first == id || cut_sides_[k].second == id) &&
          (!best || cuts_[k].clearance < best->clearance))
        best = &cuts_[k];
    return best;
  };
  const cv::Point2f o(static_cast<float>(origin_.x), static_cast<float>(origin_.y));

  std::vector<int> feet, rest;
  for (int id : leaves) {
    const Region& r = regions_[static_cast<size_t>(id)];
    if (r.box.y + r.box.height - 1 >= bottom - opt_.foot_band_ratio * height)
      feet.push_back(id);
    else
      rest.push_back(id);
  }
  int head = -1;
  for (int id : rest) {
    const Region& r = regions_[static_cast<size_t>(id)];
    if (r.centroid.y > top + opt_.head_band_ratio * height) continue;
    if (std::abs(r.centroid.x - axis_x) > 0.15 * height) continue;  // a raised hand, not the head
    if (r.box.y > top + 0.08 * height) continue;  // the head is the top (a notch below is not it)
    float disc = 0;  // ... and round (a sliver cut off the top of a ragged head is not it)
    for (int y = r.box.y; y < r.box.y + r.box.height; y++)
      for (int x = r.box.x; x < r.box.x + r.box.width; x++)
        if (labels_(y - origin_.y, x - origin_.x) == id)
          disc = std::max(disc, dist_(y - origin_.y, x - origin_.x));
    if (disc < opt_.head_disc_ratio * height) continue;
    if (head < 0 ||
        std::abs(r.centroid.x - axis_x) < std::abs(regions_[static_cast<size_t>(head)].centroid.x - axis_x))
      head = id;
  }
  std::vector<int> hands;
  // Arms spread horizontally: a hand's leaf lies in the upper half (a notch of a ragged mask makes
  // leaves elsewhere too).
  for (int id : rest)
    if (id != head && regions_[static_cast<size_t>(id)].centroid.y <= top + 0.5 * height) hands.push_back(id);
  std::sort(hands.begin(), hands.end(), [&](int a, int b) {
    return std::abs(regions_[static_cast<size_t>(a)].centroid.x - axis_x) >
           std::abs(regions_[static_cast<size_t>(b)].centroid.x - axis_x);
  });
  // Head: the centre of the largest disc inside the head region. Without a head leaf (no neck cut:
  // the head joined to an arm seen above the shoulder, or a mask that lost the chest so that the
  // shoulders are a bridge with the head on it) the largest disc in the silhouette's top
  // head_top_ratio near the axis, if the silhouette is head-wide there (not shoulders).
  {
    const bool leaf = head >= 0;
    const int ytop = static_cast<int>(top) - origin_.y;
    const int yend = leaf ? sil_.rows - 1 : ytop + static_cast<int>(opt_.head_top_ratio * height);
    const int xlo = leaf ? 0 : static_cast<int>(axis_x - 0.12 * height) - origin_.x;
    const int xhi = leaf ? sil_.cols - 1 : static_cast<int>(axis_x + 0.12 * height) - origin_.x;
    auto in = [&](int x, int y) { return leaf ? labels_(y, x) == head : sil_(y, x) != 0; };
    float best = 0;
    cv::Point at(-1, -1);
    for (int y = std::max(0, ytop); y <= std::min(sil_.rows - 1, yend); y++)
      for (int x = std::max(0, xlo); x <= std::min(sil_.cols - 1, xhi); x++)
        if (in(x, y) && dist_(y, x) > best) best = dist_(y, x), at = {x, y};
    if (!leaf && at.x >= 0) {
      // A head is at most ~0.17 x the height wide (shoulders are wider, arms spread much wider)...
      int x0 = at.x, x1 = at.x;
      while (fg(x0 - 1, at.y)) x0--;
      while (fg(x1 + 1, at.y)) x1++;
      // ... and round: its disc is at least 0.03 x the height (a neck or a forearm is thinner).
      if (x1 - x0 + 1 <= 0.17 * height && best >= opt_.head_disc_ratio * height) head = labels_(at);
    }
    if (head < 0) {
      s->why =
          "5 terminals expected, found no head (no leaf of the graph or round blob near the top, near the "
          "body's axis)";
      return;
    }
    double wx = 0, wy = 0, n = 0;
    for (int y = std::max(0, ytop); y <= std::min(sil_.rows - 1, yend); y++)
      for (int x = std::max(0, xlo); x <= std::min(sil_.cols - 1, xhi); x++)
        if (in(x, y) && dist_(y, x) >= best - 0.75F && std::hypot(x - at.x, y - at.y) <= best)
          wx += x, wy += y, n++;
    s->terminal[kHead] = head;
    s->point[kHead] = cv::Point2f(static_cast<float>(wx / n), static_cast<float>(wy / n)) + o;
    head_radius_ = best;
  }
  // A silhouette too short for its head lost the legs (a mask that missed the trousers): what is
  // at its bottom is no foot, and the feet are not_visible (a head's radius is ~0.055 x the height).
  const bool legs = head_radius_ <= opt_.max_head_ratio * height;
  if (legs && !find_feet(s, static_cast<float>(axis_x - origin_.x))) return;
  // Hands and feet: the middle of the terminal's cut. Left is the image's right.
  // The cut of a hand's leaf is where the hand widens; the wrist joint lies a little inside the arm.
  auto cut_mid = [&](int id) {
    const Cut* k = leaf_cut(id);
    const Region& r = regions_[static_cast<size_t>(id)];
    if (!k) return r.centroid;
    const cv::Point2f mid = (k->a + k->b) * 0.5F + o;
    cv::Point2f away = mid - r.centroid;
    const float n = std::hypot(away.x, away.y);
    return n > 0 ? mid + away * (static_cast<float>(opt_.wrist_shift) * k->clearance / n) : mid;
  };
  // A hand's leaf whose cut is far from its tip holds the forearm too (a cut at the elbow or the
  // shoulder): its wrist is found from the tip, like that of a hand without a leaf.
  geodesic(s->point[kHead] - o);
  const double hand_len = opt_.hand_ratio * height;
  // An upper arm's radius is ~0.03 x the height, a head's or a torso's 0.05 or more.
  const float max_arm = static_cast<float>(0.04 * height);
  std::vector<std::pair<int, cv::Point2f>> found;  // (region, wrist)
  // A spur of a ragged head or a sliver of a broken mask is no hand: arms spread, a hand's tip lies
  // beside the head (even a hand seen above the shoulder), beyond its outline, at the end of an
  // arm-thin part at least half a hand long that is somewhere as thick as a forearm (~0.023 x the
  // height; a hand seen edge-on is thinner, a sliver much thinner).
  const cv::Point2f head_local = s->point[kHead] - o;
  auto hand_like = [&](cv::Point tip) {
    if (std::abs(static_cast<float>(tip.x) - head_local.x) < 1.5F * head_radius_ ||
        geo_(tip) <= 1.6F * head_radius_)
      return false;
    float thickest = 0;
    return protrusion(tip, max_arm, &thickest) >= 0.5 * hand_len && thickest >= 0.015 * height;
  };
  for (int id : hands) {
    if (found.size() == 2) break;
    const cv::Point tip = region_tip(id);
    if (!hand_like(tip)) continue;
    const Cut* k = leaf_cut(id);
    const cv::Point2f mid = k ? (k->a + k->b) * 0.5F : cv::Point2f(-1e6F, -1e6F);
    if (k &&
        std::hypot(mid.x - static_cast<float>(tip.x), mid.y - static_cast<float>(tip.y)) < 1.3 * hand_len)
      found.emplace_back(id, cut_mid(id));
    else
      found.emplace_back(id, wrist_from_tip(tip, hand_len, max_arm) + o);
  }
  if (found.size() < 2) {
    // Hands without a leaf (an arm of even width, a hand seen edge-on): the silhouette's
    // extremities farthest from the head along the silhouette, other than the head, the feet and
    // the hands already found.
    const double foot_top = bottom - opt_.foot_band_ratio * height;
    for (const cv::Point& t : extremities(height)) {
      if (found.size() >= 2) break;
      const cv::Point ti = t + origin_;
      const int id = labels_(t);
      // Arms spread horizontally: hands are in the upper half (notches of a ragged mask elsewhere
      // make extremities too).
      // The head's own top is no hand, but a hand seen above the shoulder may lie in the head's
      // region (no neck between them): what is farther from the head's centre than its radius is.
      if (ti.y >= foot_top || ti.y > top + 0.5 * height || !hand_like(t)) continue;
      bool taken = false;
      for (const auto& f : found) taken = taken || f.first == id;
      if (taken) continue;
      const cv::Point2f w = wrist_from_tip(t, hand_len, max_arm);
      const cv::Point wi(cvRound(w.x), cvRound(w.y));
      found.emplace_back(fg(wi.x, wi.y) ? labels_(wi) : id, w + o);
    }
  }
  if (found.empty() || (found.size() == 1 && !legs)) {
    s->why = "5 terminals expected, found " + std::to_string(1 + found.size()) +
             " above the feet (head 1, hands " + std::to_string(found.size()) + ")" +
             (legs ? "" : " and no legs (the silhouette is too short for its head)");
    s->terminal.fill(-1);
    return;
  }
  if (found.size() == 1) {
    // One hand seen (the other hidden behind the body by a camera looking along the arms): it is
    // labelled by its side of the head, the other not_visible.
    const bool left = found[0].second.x > s->point[kHead].x;
    s->terminal[left ? kLeftHand : kRightHand] = found[0].first;
    s->point[left ? kLeftHand : kRightHand] = found[0].second;
  } else {
    const bool first_is_left = found[0].second.x > found[1].second.x;
    const auto& l = first_is_left ? found[0] : found[1];
    const auto& r = first_is_left ? found[1] : found[0];
    s->terminal[kLeftHand] = l.first;
    s->terminal[kRightHand] = r.first;
    s->point[kLeftHand] = l.second;
    s->point[kRightHand] = r.second;
  }
  s->ok = true;
  s->why.clear();
}

// The feet: from the front or the side the ankle is no constriction (a foot is no wider than its
// ankle from the front, and legs held together touch), so the feet are found at the bottom of the
// silhouette instead: the pieces of its lowest foot_band_ratio x height. Each foot's ankle is
// ankle_ratio x height above the piece's lowest pixel, in the middle of the piece's row there; one
// piece for both feet is split into the row's two widest runs, or its two halves when the row is
// one run (shanks touching). Left is the image's right.
bool Work::find_feet(Segmentation* s, float axis_x) {
  const cv::Rect box = cv::boundingRect(sil_);
  const int bottom = box.y + box.height - 1;
  const int band_top = std::max(box.y, bottom - static_cast<int>(opt_.foot_band_ratio * box.height));
  cv::Mat1b band = cv::Mat1b::zeros(sil_.size());
  sil_.rowRange(band_top, bottom + 1).copyTo(band.rowRange(band_top, bottom + 1));
  cv::Mat1i lab;
  cv::Mat stats, centroids;
  const int n = cv::connectedComponentsWithStats(band, lab, stats, centroids, 8, CV_32S);
  int total = 0;
  for (int i = 1; i < n; i++) total += stats.at<int>(i, cv::CC_STAT_AREA);
  std::vector<int> pieces;
  for (int i = 1; i < n; i++)
    if (stats.at<int>(i, cv::CC_STAT_AREA) >= std::max(4, total / 20)) pieces.push_back(i);
  std::sort(pieces.begin(), pieces.end(), [&](int a, int b) {
    return stats.at<int>(a, cv::CC_STAT_AREA) > stats.at<int>(b, cv::CC_STAT_AREA);
  });
  if (pieces.empty()) {
    s->why = "no feet at the bottom of the silhouette";
    return false;
  }
  if (pieces.size() > 2) pieces.resize(2);
  const int lift = std::max(1, static_cast<int>(std::lround(opt_.ankle_ratio * box.height)));
  // The runs of piece `l` on row y: [x0, x1] pairs.
  auto runs = [&](int l, int y) {
    std::vector<std::pair<int, int>> r;
    for (int x = 0; x < lab.cols; x++) {
      if (lab(y, x) != l) continue;
      const int x0 = x;
      while (x + 1 < lab.cols && lab(y, x + 1) == l) x++;
      r.emplace_back(x0, x);
    }
    std::sort(r.begin(), r.end(), [](auto a, auto b) { return a.second - a.first > b.second - b.first; });
    return r;
  };
  auto ankle_row = [&](int l) {
    const int low = stats.at<int>(l, cv::CC_STAT_TOP) + stats.at<int>(l, cv::CC_STAT_HEIGHT) - 1;
    return std::max(stats.at<int>(l, cv::CC_STAT_TOP), low - lift);
  };
  std::vector<cv::Point2f> ankles;
  for (int l : pieces) {
    const int y = ankle_row(l);
    auto r = runs(l, y);
    if (r.empty()) continue;
    if (pieces.size() == 1 && r.size() >= 2) {
      for (int k = 0; k < 2; k++)
        ankles.emplace_back(
            static_cast<float>(r[static_cast<size_t>(k)].first + r[static_cast<size_t>(k)].second) / 2.0F,
            static_cast<float>(y));
    } else if (pieces.size() == 1) {
      // Legs together: the ankles a quarter of the run's width either side of the body's axis
      // (a mask that grew on one side of the feet does not move both).
      const float x0 = static_cast<float>(r[0].first), w = static_cast<float>(r[0].second - r[0].first + 1);
      const float mid = std::clamp(axis_x, x0 + 0.25F * w - 0.5F, x0 + 0.75F * w - 0.5F);
      ankles.emplace_back(mid - 0.25F * w, static_cast<float>(y));
      ankles.emplace_back(mid + 0.25F * w, static_cast<float>(y));
    } else {
      ankles.emplace_back(static_cast<float>(r[0].first + r[0].second) / 2.0F, static_cast<float>(y));
    }
  }
  if (ankles.size() != 2) {
    s->why = "2 feet expected, found " + std::to_string(ankles.size());
    return false;
  }
  if (ankles[0].x < ankles[1].x) std::swap(ankles[0], ankles[1]);
  const cv::Point2f o(static_cast<float>(origin_.x), static_cast<float>(origin_.y));
  for (int k = 0; k < 2; k++) {
    const int f = k == 0 ? kLeftFoot : kRightFoot;
    const cv::Point a(cvRound(ankles[static_cast<size_t>(k)].x), cvRound(ankles[static_cast<size_t>(k)].y));
    int id = fg(a.x, a.y) ? labels_(a) : -1;
    for (int rr = 1; id < 0 && rr < 4; rr++)  // between two runs: the nearest region
      for (int dy = -rr; dy <= rr && id < 0; dy++)
        for (int dx = -rr; dx <= rr && id < 0; dx++)
          if (fg(a.x + dx, a.y + dy)) id = labels_(a.y + dy, a.x + dx);
    s->terminal[static_cast<size_t>(f)] = id;
    s->point[static_cast<size_t>(f)] = ankles[static_cast<size_t>(k)] + o;
  }
  return true;
}

// Geodesic distance (8-connected, steps 1 and sqrt 2) inside the silhouette from `from` (local).
void Work::geodesic(cv::Point from) {
  geo_ = cv::Mat1f(sil_.size(), -1.0F);
  if (!fg(from.x, from.y)) {  // the head's centre is inside; be safe
    double best = -1;
    for (int y = 0; y < sil_.rows; y++)
      for (int x = 0; x < sil_.cols; x++)
        if (sil_(y, x) && (best < 0 || std::hypot(x - from.x, y - from.y) < best))
          best = std::hypot(x - from.x, y - from.y), from = {x, y};
  }
  using Item = std::pair<float, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> heap;
  geo_(from) = 0;
  heap.emplace(0.0F, from.y * sil_.cols + from.x);
  while (!heap.empty()) {
    const auto [g, i] = heap.top();
    heap.pop();
    const int x = i % sil_.cols, y = i / sil_.cols;
    if (g > geo_(y, x)) continue;
    for (const cv::Point& o : kN8) {
      const int nx = x + o.x, ny = y + o.y;
      if (!fg(nx, ny)) continue;
      const float ng = g + ((o.x != 0 && o.y != 0) ? 1.41421356F : 1.0F);
      if (geo_(ny, nx) < 0 || ng < geo_(ny, nx)) {
        geo_(ny, nx) = ng;
        heap.emplace(ng, ny * sil_.cols + nx);
      }
    }
  }
}

// The pixel of a region farthest (geodesically) from the head.
cv::Point Work::region_tip(int id) const {
  cv::Point tip(-1, -1);
  float best = -1;
  for (int y = 0; y < sil_.rows; y++)
    for (int x = 0; x < sil_.cols; x++)
      if (labels_(y, x) == id && geo_(y, x) > best) best = geo_(y, x), tip = {x, y};
  return tip;
}

// Local maxima of the geodesic distance: pixels in decreasing distance, each kept unless it lies on
// the way to one already kept (no farther from it than their difference in distance, plus a slack).
std::vector<cv::Point> Work::extremities(double height) const {
  std::vector<std::pair<float, cv::Point>> px;
  for (int y = 0; y < sil_.rows; y++)
    for (int x = 0; x < sil_.cols; x++)
      if (geo_(y, x) > 0) px.emplace_back(geo_(y, x), cv::Point(x, y));
  std::sort(px.begin(), px.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  const float slack = static_cast<float>(0.06 * height);
  std::vector<cv::Point> tips;
  for (const auto& [g, p] : px) {
    if (tips.size() >= 16) break;
    bool on_way = false;
    for (const cv::Point& t : tips) {
      const float d = std::hypot(static_cast<float>(p.x - t.x), static_cast<float>(p.y - t.y));
      on_way = on_way || d <= geo_(t) - g + slack;
    }
    if (!on_way) tips.push_back(p);
  }
  return tips;
}

// How far the geodesic path from `tip` back towards the head runs through a part no thicker than
// max_arm (an arm, a hand) before it enters the head or the torso; *thickest: the largest clearance
// on the way. Local coordinates.
double Work::protrusion(cv::Point tip, float max_arm, float* thickest) const {
  cv::Point p = tip;
  double walked = 0;
  *thickest = dist_(p);
  for (;;) {
    cv::Point next = p;
    float best = geo_(p);
    for (const cv::Point& o : kN8) {
      const cv::Point q = p + o;
      if (fg(q.x, q.y) && geo_(q) >= 0 && geo_(q) < best) best = geo_(q), next = q;
    }
    if (next == p || dist_(next) > max_arm) return walked;
    walked += (next.x != p.x && next.y != p.y) ? 1.41421356 : 1.0;
    p = next;
    *thickest = std::max(*thickest, dist_(p));
  }
}

// The wrist from a hand's tip: `len` along the geodesic path back towards the head, then onto the
// nearest GVD pixel (the middle of the arm). Local coordinates.
cv::Point2f Work::wrist_from_tip(cv::Point tip, double len, float max_arm) const {
  cv::Point p = tip;
  double walked = 0;
  // A hand near the head (seen above the shoulder, the arm foreshortened): the wrist is at most
  // half way from the tip to the head's outline, never in the head.
  len = std::min(len, 0.5 * std::max(0.0, static_cast<double>(geo_(tip) - head_radius_)));
  while (walked < len) {
    cv::Point next = p;
    float best = geo_(p);
    for (const cv::Point& o : kN8) {
      const cv::Point q = p + o;
      if (fg(q.x, q.y) && geo_(q) >= 0 && geo_(q) < best) best = geo_(q), next = q;
    }
    // Into the head or the torso (wider than any arm: a hand seen above the shoulder, an arm
    // foreshortened by the view): the wrist is no farther.
    if (next == p || dist_(next) > max_arm) break;
    walked += (next.x != p.x && next.y != p.y) ? 1.41421356 : 1.0;
    p = next;
  }
  const int r = std::max(3, static_cast<int>(std::ceil(2 * dist_(p))));
  cv::Point axis = p;
  double best = -1;
  for (int dy = -r; dy <= r; dy++)
    for (int dx = -r; dx <= r; dx++) {
      const cv::Point q = p + cv::Point(dx, dy);
      if (q.x < 0 || q.y < 0 || q.x >= sil_.cols || q.y >= sil_.rows || !gvd_(q) || dist_(q) > max_arm)
        continue;
      const double d = std::hypot(dx, dy);
      if (best < 0 || d < best) best = d, axis = q;
    }
  return {static_cast<float>(axis.x), static_cast<float>(axis.y)};
}

void Work::run(Segmentation* s) {
  distance();
  medial_axis();
  critical_points();
  regions(s);
  // Regions are in image coordinates; cuts_ stay local for terminals(), which offsets them.
  terminals(s);
  export_images(s);
}

Segmentation fail(Segmentation s, std::string why) {
  s.ok = false;
  s.why = std::move(why);
  return s;
}

}  // namespace

Segmentation segment(const cv::Mat1b& mask, const Options& opt) {
  std::string bad;
  if (!opt.valid(&bad)) throw std::invalid_argument("segment: options: " + bad);
  Segmentation s;
  if (mask.empty()) return fail(std::move(s), "empty mask");
  if (mask.cols > opt.max_width || mask.rows > opt.max_height)
    return fail(std::move(s), "mask " + std::to_string(mask.cols) + "x" + std::to_string(mask.rows) +
                                  " is larger than " + std::to_string(opt.max_width) + "x" +
                                  std::to_string(opt.max_height));
  s.distance = cv::Mat1f::zeros(mask.size());
  s.gvd = cv::Mat1b::zeros(mask.size());
  s.labels = cv::Mat1i(mask.size(), -1);
  cv::Mat1b sil;
  cv::Rect box;
  int area = 0;
  if (!largest_component(mask != 0, &sil, &box, &area))
    return fail(std::move(s), "no silhouette in the mask");
  if (area < opt.min_area_px)
    return fail(std::move(s), "silhouette too small: " + std::to_string(area) + " px (at least " +
                                  std::to_string(opt.min_area_px) + ")");
  if (box.height < opt.min_height_px)
    return fail(std::move(s), "silhouette too short: " + std::to_string(box.height) + " px high (at least " +
                                  std::to_string(opt.min_height_px) + ")");
  if (box.x == 0 || box.y == 0 || box.x + box.width == mask.cols || box.y + box.height == mask.rows)
    return fail(std::move(s), "the silhouette touches the image border (the performer is partly outside)");

  // The silhouette on its box, padded with background so that the smoothing and the distance
  // transform never see the image's edge.
  const int r = static_cast<int>(std::lround(opt.smooth_ratio * box.height));
  const int pad = r + 3;
  cv::Mat1b local = cv::Mat1b::zeros(box.height + 2 * pad, box.width + 2 * pad);
  sil(box).copyTo(local(cv::Rect(pad, pad, box.width, box.height)));
  const cv::Point origin = box.tl() - cv::Point(pad, pad);
  fill_holes(local);
  if (r >= 1) {
    const cv::Mat k = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1));
    cv::morphologyEx(local, local, cv::MORPH_OPEN, k);
    cv::morphologyEx(local, local, cv::MORPH_CLOSE, k);
    cv::Rect b2;
    cv::Mat1b again;
    if (!largest_component(local, &again, &b2, &area) || area < opt.min_area_px)
      return fail(std::move(s), "silhouette too small after smoothing");
    local = again;
    fill_holes(local);
  }
  Work w(opt, local, origin);
  w.run(&s);
  return s;
}

}  // namespace vc::segment
