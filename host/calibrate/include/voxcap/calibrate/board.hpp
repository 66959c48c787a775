// The calibration target and its detection: a ChArUco board (OpenCV's aruco module) or, as a fallback,
// a plain chessboard. A detection is the board's inner corners seen in one image, each with its id and
// its position on the board (metres, the board frame of OpenCV 4.6's CharucoBoard: origin at the outer
// corner of square (0,0), the top-left of the printed image, x along the first row, y down the printed
// image, z into the board).
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace vc::calibrate {

struct BoardSpec {
  enum class Kind { charuco, chessboard };
  Kind kind = Kind::charuco;
  int squares_x = 5;  // squares along x (a chessboard: squares too, so inner corners are one fewer)
  int squares_y = 4;
  double square_m = 0.2;
  double marker_m = 0.15;                  // charuco only
  std::string dictionary = "DICT_4X4_50";  // charuco only
  bool valid(std::string* why) const;
  // The inner corners in the board frame, index = id (charuco: OpenCV's ids; chessboard: row-major).
  std::vector<cv::Point3d> corners_board() const;
  std::string describe() const;  // the SPEC that parses back to it
};

// "charuco:5x4:0.2:0.15:DICT_4X4_50" or "chessboard:9x7:0.05" (squares x, y; square and marker sides in
// metres). Throws std::invalid_argument naming what is wrong.
BoardSpec parse_board_spec(const std::string& spec);

struct Detection {
  std::vector<int> ids;               // corner ids, ascending
  std::vector<cv::Point2d> image_px;  // where each is seen (pixel (0,0) = centre of the top-left pixel)
  bool empty() const { return ids.empty(); }
};

// Finds the board in one image (CV_8UC1 or CV_8UC3; colour order does not matter). ChArUco: markers,
// corners interpolated, then each corner refined where its edges meet, the markers' borders left out
// (OpenCV 4.6's interpolation leaves them half a pixel off, and cv::cornerSubPix's window takes in the
// markers in small or slanted views); a corner that cannot be refined is left out. Chessboard:
// cv::findChessboardCorners + cornerSubPix, ids row-major (a square board may be found turned, so use one
// with an odd and an even side). An image without the board gives an empty detection.
Detection detect_board(const cv::Mat& image, const BoardSpec& board);

}  // namespace vc::calibrate
