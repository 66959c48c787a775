#include "voxcap/calibrate/board.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numeric>
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
    // The refinement window must hold the corner and no marker: the marker's inset from the square's
    // corner, in pixels, from the markers' mean side.
    double side = 0;
    for (const auto& m : marker_px) side += cv::norm(m[0] - m[1]) + cv::norm(m[1] - m[2]);
    side /= 2.0 * static_cast<double>(marker_px.size());
    const double inset_px = side * (board.square_m - board.marker_m) / (2 * board.marker_m);
    const int half = std::clamp(static_cast<int>(inset_px * 1.2), 2, 6);
    cv::cornerSubPix(grey, pts, cv::Size(half, half), cv::Size(-1, -1), crit);
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
