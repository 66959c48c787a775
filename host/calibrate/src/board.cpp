#include "voxcap/calibrate/board.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <utility>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "voxcap/rig/aruco_dictionary.hpp"

namespace vc::calibrate {
namespace {

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out(1);
  for (char c : s) {
    if (c == sep) {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  return out;
}

double parse_length(const std::string& s, const std::string& what) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || !std::isfinite(v)) {
    throw std::invalid_argument("board: " + what + " '" + s + "' is not a number");
  }
  return v;
}

// ChArUco corner refinement. Each inner corner is an X-junction of two black squares and two white ones, and
// each white square holds a marker inset by (square - marker) / 2 from the corner: only 1-4 px in a small or
// foreshortened view. cv::cornerSubPix's square window then takes in the markers' borders, whose gradients
// do not point at the corner, and pulls it by up to 3 px (OpenCV 4.6's interpolation alone is half a pixel
// off). So the corner is taken as the point the clean edges meet: Förstner's estimator (the point c
// minimising the sum over pixels q of (g_q . (q - c))^2, g the image gradient; W. Förstner, E. Gülch, 1987)
// over the pixels of the four squares around the corner, leaving out those within kClearPx of a marker (in
// the white squares) or of the squares' far edges. Where those lie comes from the board-to-image homography
// near the corner: in the first pass from the two adjacent markers' detected corners (their outlines come
// out ~0.6 px small, so the masks are only roughly placed and the window is kept small), in the later ones
// from the corner and its neighbours as refined so far. Lens distortion bends the edges a little over the
// window; kRadiusPx keeps that under the noise. A corner with too little clean edge of both directions, or
// one that lands more than kMaxShiftPx from where it was interpolated, is dropped.
// On the virtual rig (hw/sim, distortion and noise on) the corners come out 0.04 px RMS from their true
// projections, cornerSubPix's 0.32 px (host/calibrate/README.md).
constexpr double kClearPx = 2.0;         // Sobel's support (1 px) + the edges' blur and the masks' error
constexpr double kFirstRadiusPx = 10.0;  // the first pass's window: its masks are only roughly placed
constexpr double kRadiusPx = 16.0;       // later passes' window
constexpr int kPasses = 3;
constexpr double kMaxShiftPx = 2.0;  // from the interpolated corner

// A corner's quadrant (board x, y relative to it positive or not), 0..3.
std::size_t quadrant(bool x_positive, bool y_positive) {
  return (x_positive ? 1u : 0u) + (y_positive ? 2u : 0u);
}

struct CharucoGeometry {
  double square = 0, inset = 0;
  int nx = 0, ny = 0;                      // inner corners per row, rows
  std::vector<std::array<bool, 4>> white;  // per corner id: quadrant (x > 0) + 2 (y > 0) holds a marker
};

CharucoGeometry charuco_geometry(const cv::aruco::CharucoBoard& cb) {
  CharucoGeometry g;
  g.square = cb.getSquareLength();
  g.inset = (cb.getSquareLength() - cb.getMarkerLength()) / 2;
  g.nx = cb.getChessboardSize().width - 1;
  g.ny = cb.getChessboardSize().height - 1;
  g.white.resize(cb.chessboardCorners.size());
  for (std::size_t id = 0; id < cb.chessboardCorners.size(); ++id) {
    const cv::Point3f& c = cb.chessboardCorners[id];
    for (const int m : cb.nearestMarkerIdx[id]) {
      const auto& obj = cb.objPoints[static_cast<std::size_t>(m)];
      const float cx = (obj[0].x + obj[1].x + obj[2].x + obj[3].x) / 4;
      const float cy = (obj[0].y + obj[1].y + obj[2].y + obj[3].y) / 4;
      g.white[id][quadrant(cx > c.x, cy > c.y)] = true;
    }
  }
  return g;
}

// The homography from board coordinates relative to corner `id` (metres) to the image, fitted to the corner
// and its up to 8 neighbours that have a position (px[n] where have[n]). None when the points leave it
// undetermined: fewer than 4, or all but one on a line (a row, a column or a diagonal of the 3x3 block).
std::optional<cv::Matx33d> local_homography(const CharucoGeometry& g, int id,
                                            const std::vector<cv::Point2f>& px,
                                            const std::vector<bool>& have) {
  std::vector<cv::Point2f> src, dst;
  std::vector<cv::Point> cell;
  const int cx = id % g.nx, cy = id / g.nx;
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      const int x = cx + dx, y = cy + dy;
      if (x < 0 || y < 0 || x >= g.nx || y >= g.ny) continue;
      const std::size_t n =
          static_cast<std::size_t>(y) * static_cast<std::size_t>(g.nx) + static_cast<std::size_t>(x);
      if (!have[n]) continue;
      src.emplace_back(static_cast<float>(dx * g.square), static_cast<float>(dy * g.square));
      dst.push_back(px[n]);
      cell.emplace_back(dx, dy);
    }
  }
  const int n = static_cast<int>(src.size());
  if (n < 4) return std::nullopt;
  for (int k = -1; k <= 1; ++k) {
    const auto on = [&](auto pred) {
      return static_cast<int>(std::count_if(cell.begin(), cell.end(), pred));
    };
    if (on([&](const cv::Point& p) { return p.y == k; }) >= n - 1) return std::nullopt;
    if (on([&](const cv::Point& p) { return p.x == k; }) >= n - 1) return std::nullopt;
  }
  const auto on_diag = [&](int sign) {
    return static_cast<int>(
        std::count_if(cell.begin(), cell.end(), [&](const cv::Point& p) { return p.y == sign * p.x; }));
  };
  if (on_diag(1) >= n - 1 || on_diag(-1) >= n - 1) return std::nullopt;
  const cv::Mat H = cv::findHomography(src, dst);
  if (H.empty()) return std::nullopt;
  return cv::Matx33d(H);
}

// The same from the two markers next to corner `id` (their 8 detected corners), for the first pass.
std::optional<cv::Matx33d> marker_homography(const cv::aruco::CharucoBoard& cb, int id,
                                             const std::vector<std::vector<cv::Point2f>>& marker_px,
                                             const std::vector<int>& marker_ids) {
  std::vector<cv::Point2f> src, dst;
  const cv::Point3f& c = cb.chessboardCorners[static_cast<std::size_t>(id)];
  for (const int m : cb.nearestMarkerIdx[static_cast<std::size_t>(id)]) {
    const auto it = std::find(marker_ids.begin(), marker_ids.end(), cb.ids[static_cast<std::size_t>(m)]);
    if (it == marker_ids.end()) continue;
    const auto& img = marker_px[static_cast<std::size_t>(it - marker_ids.begin())];
    const auto& obj = cb.objPoints[static_cast<std::size_t>(m)];
    for (std::size_t k = 0; k < 4; ++k) {
      src.emplace_back(obj[k].x - c.x, obj[k].y - c.y);
      dst.push_back(img[k]);
    }
  }
  if (src.size() < 4) return std::nullopt;
  const cv::Mat H = cv::findHomography(src, dst);
  if (H.empty()) return std::nullopt;
  return cv::Matx33d(H);
}

// One corner by Förstner's estimator over its clean pixels (see above); false if it cannot be refined.
bool refine_corner(const cv::Mat& gx, const cv::Mat& gy, const CharucoGeometry& geo,
                   const std::array<bool, 4>& white, const cv::Matx33d& H, cv::Point2d start,
                   double radius_px, cv::Point2d* out) {
  const cv::Matx33d Hinv = H.inv();
  auto to_img = [&](double x, double y) {
    const cv::Vec3d p = H * cv::Vec3d(x, y, 1);
    return cv::Point2d(p[0] / p[2], p[1] / p[2]);
  };
  // The local scale: the distance in pixels between lines of board x (or y) one metre apart is
  // 1 / |grad of board x (or y) in the image| = |det J| / |the other column of J|.
  const double eps = geo.square * 0.01;
  const cv::Point2d ex = (to_img(eps, 0) - to_img(-eps, 0)) / (2 * eps);
  const cv::Point2d ey = (to_img(0, eps) - to_img(0, -eps)) / (2 * eps);
  const double det = std::abs(ex.x * ey.y - ex.y * ey.x);
  if (!(det > 1e-9)) return false;
  const double clear_x = kClearPx * std::hypot(ey.x, ey.y) / det;
  const double clear_y = kClearPx * std::hypot(ex.x, ex.y) / det;
  const double s = geo.square, inset = geo.inset;
  // The window: the four squares' bounding box in the image, within radius_px of the start.
  double u0 = 1e30, v0 = 1e30, u1 = -1e30, v1 = -1e30;
  for (const double sx : {-s, s}) {
    for (const double sy : {-s, s}) {
      const cv::Point2d q = to_img(sx, sy);
      u0 = std::min(u0, q.x), u1 = std::max(u1, q.x), v0 = std::min(v0, q.y), v1 = std::max(v1, q.y);
    }
  }
  const int iu0 = std::max(1, static_cast<int>(std::floor(std::max(u0, start.x - radius_px))));
  const int iu1 = std::min(gx.cols - 2, static_cast<int>(std::ceil(std::min(u1, start.x + radius_px))));
  const int iv0 = std::max(1, static_cast<int>(std::floor(std::max(v0, start.y - radius_px))));
  const int iv1 = std::min(gx.rows - 2, static_cast<int>(std::ceil(std::min(v1, start.y + radius_px))));
  cv::Matx22d A = cv::Matx22d::zeros();
  cv::Vec2d rhs(0, 0);
  for (int v = iv0; v <= iv1; ++v) {
    const float* rx = gx.ptr<float>(v);
    const float* ry = gy.ptr<float>(v);
    for (int u = iu0; u <= iu1; ++u) {
      if (std::hypot(u - start.x, v - start.y) > radius_px) continue;
      const cv::Vec3d b = Hinv * cv::Vec3d(u, v, 1);
      if (!(b[2] != 0)) continue;
      const double x = b[0] / b[2], y = b[1] / b[2];
      const double ax = std::abs(x), ay = std::abs(y);
      if (ax > s - clear_x || ay > s - clear_y) continue;  // the squares' far edges
      if (white[quadrant(x > 0, y > 0)] && ax > inset - clear_x && ay > inset - clear_y) {
        continue;  // a marker
      }
      const cv::Vec2d g(rx[u], ry[u]);
      const cv::Matx22d ggt = g * g.t();
      A += ggt;
      rhs += ggt * cv::Vec2d(u, v);
    }
  }
  // Both edge directions must be seen: the smaller eigenvalue against the larger.
  const double tr = A(0, 0) + A(1, 1), dt = A(0, 0) * A(1, 1) - A(0, 1) * A(1, 0);
  const double disc = std::sqrt(std::max(0.0, tr * tr / 4 - dt));
  if (!(tr / 2 - disc > 0.05 * (tr / 2 + disc))) return false;
  const cv::Vec2d c = A.inv() * rhs;
  *out = cv::Point2d(c[0], c[1]);
  return std::isfinite(c[0]) && std::isfinite(c[1]);
}

void refine_charuco_corners(const cv::Mat& grey, const cv::aruco::CharucoBoard& cb,
                            const std::vector<std::vector<cv::Point2f>>& marker_px,
                            const std::vector<int>& marker_ids, std::vector<cv::Point2f>& pts,
                            std::vector<int>& ids) {
  cv::Mat gx, gy;
  cv::Sobel(grey, gx, CV_32F, 1, 0, 3, 1.0 / 8);
  cv::Sobel(grey, gy, CV_32F, 0, 1, 3, 1.0 / 8);
  const CharucoGeometry geo = charuco_geometry(cb);
  const std::size_t n_ids = geo.white.size();
  std::vector<cv::Point2f> px(n_ids), start(n_ids);
  std::vector<bool> have(n_ids, false);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (ids[i] < 0 || static_cast<std::size_t>(ids[i]) >= n_ids) continue;
    px[static_cast<std::size_t>(ids[i])] = pts[i];
    have[static_cast<std::size_t>(ids[i])] = true;
  }
  start = px;
  for (int pass = 0; pass < kPasses; ++pass) {
    std::vector<cv::Point2f> next(n_ids);
    std::vector<bool> got(n_ids, false);
    for (std::size_t id = 0; id < n_ids; ++id) {
      if (!have[id]) continue;
      // The first pass locates the masks from the markers; later ones from the corners refined so far, and
      // keep the previous estimate where they cannot do better.
      const auto H = pass == 0 ? marker_homography(cb, static_cast<int>(id), marker_px, marker_ids)
                               : local_homography(geo, static_cast<int>(id), px, have);
      cv::Point2d c;
      if (H &&
          refine_corner(gx, gy, geo, geo.white[id], *H, cv::Point2d(px[id]),
                        pass == 0 ? kFirstRadiusPx : kRadiusPx, &c) &&
          cv::norm(c - cv::Point2d(start[id])) <= kMaxShiftPx) {
        next[id] = cv::Point2f(static_cast<float>(c.x), static_cast<float>(c.y));
        got[id] = true;
      } else if (pass > 0) {
        next[id] = px[id];
        got[id] = true;
      }
    }
    px = std::move(next);
    have = std::move(got);
  }
  pts.clear();
  ids.clear();
  for (std::size_t id = 0; id < n_ids; ++id) {
    if (!have[id]) continue;
    pts.push_back(px[id]);
    ids.push_back(static_cast<int>(id));
  }
}

}  // namespace

bool BoardSpec::valid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "board: " + m;
    return false;
  };
  if (squares_x < 2 || squares_y < 2 || squares_x > 64 || squares_y > 64)
    return fail("squares must be 2..64 a side");
  if (kind == Kind::chessboard && (squares_x < 3 || squares_y < 3))
    return fail("a chessboard needs 3 squares a side");
  if (!(square_m >= 0.001 && square_m <= 2.0)) return fail("square side must be 0.001..2 m");
  if (kind == Kind::charuco) {
    if (!(marker_m > 0 && marker_m < square_m)) return fail("marker side must be > 0 and < the square side");
    try {
      const int id = rig::aruco_dictionary_id(dictionary);
      const auto dict = cv::aruco::getPredefinedDictionary(id);
      const int markers = (squares_x * squares_y) / 2;
      if (dict->bytesList.rows < markers) {
        return fail(dictionary + " has " + std::to_string(dict->bytesList.rows) +
                    " markers, the board needs " + std::to_string(markers));
      }
    } catch (const std::invalid_argument& e) {
      return fail(std::string(e.what()).substr(0));
    }
  }
  return true;
}

std::vector<cv::Point3d> BoardSpec::corners_board() const {
  std::vector<cv::Point3d> out;
  // OpenCV 4.6's CharucoBoard numbers its inner corners row-major from the top-left; the chessboard
  // fallback uses the same numbering.
  for (int y = 1; y < squares_y; ++y) {
    for (int x = 1; x < squares_x; ++x) out.emplace_back(x * square_m, y * square_m, 0.0);
  }
  return out;
}

std::string BoardSpec::describe() const {
  char buf[160];
  if (kind == Kind::charuco) {
    std::snprintf(buf, sizeof buf, "charuco:%dx%d:%g:%g:%s", squares_x, squares_y, square_m, marker_m,
                  dictionary.c_str());
  } else {
    std::snprintf(buf, sizeof buf, "chessboard:%dx%d:%g", squares_x, squares_y, square_m);
  }
  return buf;
}

BoardSpec parse_board_spec(const std::string& spec) {
  const std::vector<std::string> f = split(spec, ':');
  BoardSpec b;
  if (f[0] == "charuco") {
    if (f.size() != 5)
      throw std::invalid_argument("board: expected charuco:SXxSY:SQUARE_M:MARKER_M:DICT, got '" + spec + "'");
  } else if (f[0] == "chessboard") {
    b.kind = BoardSpec::Kind::chessboard;
    if (f.size() != 3)
      throw std::invalid_argument("board: expected chessboard:SXxSY:SQUARE_M, got '" + spec + "'");
  } else {
    throw std::invalid_argument("board: '" + spec + "' is neither charuco:... nor chessboard:...");
  }
  char tail = 0;
  if (f[1].size() > 16 || std::sscanf(f[1].c_str(), "%dx%d%c", &b.squares_x, &b.squares_y, &tail) != 2) {
    throw std::invalid_argument("board: squares '" + f[1] + "' is not SXxSY (e.g. 5x4)");
  }
  b.square_m = parse_length(f[2], "square side");
  if (b.kind == BoardSpec::Kind::charuco) {
    b.marker_m = parse_length(f[3], "marker side");
    b.dictionary = f[4];
  }
  std::string why;
  if (!b.valid(&why)) throw std::invalid_argument(why);
  return b;
}

Detection detect_board(const cv::Mat& image, const BoardSpec& board) {
  cv::Mat grey;
  if (image.channels() == 3) {
    cv::cvtColor(image, grey, cv::COLOR_RGB2GRAY);
  } else if (image.channels() == 1) {
    grey = image;
  } else {
    throw std::invalid_argument("detect_board: expected a 1- or 3-channel 8-bit image");
  }
  if (grey.depth() != CV_8U) throw std::invalid_argument("detect_board: expected an 8-bit image");
  const cv::TermCriteria crit(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 50, 1e-3);
  std::vector<cv::Point2f> pts;
  std::vector<int> ids;
  if (board.kind == BoardSpec::Kind::charuco) {
    const auto dict = cv::aruco::getPredefinedDictionary(rig::aruco_dictionary_id(board.dictionary));
    const auto cb =
        cv::aruco::CharucoBoard::create(board.squares_x, board.squares_y, static_cast<float>(board.square_m),
                                        static_cast<float>(board.marker_m), dict);
    std::vector<std::vector<cv::Point2f>> marker_px;
    std::vector<int> marker_ids;
    cv::aruco::detectMarkers(grey, dict, marker_px, marker_ids);
    if (marker_ids.empty()) return {};
    cv::aruco::interpolateCornersCharuco(marker_px, marker_ids, grey, cb, pts, ids);
    if (pts.empty()) return {};
    refine_charuco_corners(grey, *cb, marker_px, marker_ids, pts, ids);
  } else {
    const cv::Size inner(board.squares_x - 1, board.squares_y - 1);
    if (!cv::findChessboardCorners(grey, inner, pts,
                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)) {
      return {};
    }
    cv::cornerSubPix(grey, pts, cv::Size(4, 4), cv::Size(-1, -1), crit);
    ids.resize(pts.size());
    std::iota(ids.begin(), ids.end(), 0);
  }
  std::vector<std::size_t> order(ids.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return ids[a] < ids[b]; });
  Detection d;
  const int n_corners = (board.squares_x - 1) * (board.squares_y - 1);
  for (std::size_t i : order) {
    if (ids[i] < 0 || ids[i] >= n_corners) continue;
    if (!d.ids.empty() && d.ids.back() == ids[i]) continue;
    d.ids.push_back(ids[i]);
    d.image_px.emplace_back(pts[i].x, pts[i].y);
  }
  return d;
}

}  // namespace vc::calibrate
