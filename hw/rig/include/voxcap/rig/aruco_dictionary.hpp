// OpenCV's predefined ArUco dictionaries by name: one table for every part that names a calibration
// board (hw/sim renders it, host/calibrate detects it), so a board the virtual rig can print is a board
// the solver can find. Header-only: only code that includes it needs OpenCV's contrib headers (aruco),
// so hw/rig itself (and the edge) does not.
#pragma once

#include <array>
#include <stdexcept>
#include <string>
#include <utility>

#include <opencv2/aruco/dictionary.hpp>

namespace vc::rig {

// The cv::aruco::PREDEFINED_DICTIONARY_NAME of "DICT_4X4_50" ... "DICT_APRILTAG_36h11";
// throws std::invalid_argument for any other name.
inline int aruco_dictionary_id(const std::string& name) {
  static const std::array<std::pair<const char*, int>, 21> kNames{{
      {"DICT_4X4_50", cv::aruco::DICT_4X4_50},
      {"DICT_4X4_100", cv::aruco::DICT_4X4_100},
      {"DICT_4X4_250", cv::aruco::DICT_4X4_250},
      {"DICT_4X4_1000", cv::aruco::DICT_4X4_1000},
      {"DICT_5X5_50", cv::aruco::DICT_5X5_50},
      {"DICT_5X5_100", cv::aruco::DICT_5X5_100},
      {"DICT_5X5_250", cv::aruco::DICT_5X5_250},
      {"DICT_5X5_1000", cv::aruco::DICT_5X5_1000},
      {"DICT_6X6_50", cv::aruco::DICT_6X6_50},
      {"DICT_6X6_100", cv::aruco::DICT_6X6_100},
      {"DICT_6X6_250", cv::aruco::DICT_6X6_250},
      {"DICT_6X6_1000", cv::aruco::DICT_6X6_1000},
      {"DICT_7X7_50", cv::aruco::DICT_7X7_50},
      {"DICT_7X7_100", cv::aruco::DICT_7X7_100},
      {"DICT_7X7_250", cv::aruco::DICT_7X7_250},
      {"DICT_7X7_1000", cv::aruco::DICT_7X7_1000},
      {"DICT_ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL},
      {"DICT_APRILTAG_16h5", cv::aruco::DICT_APRILTAG_16h5},
      {"DICT_APRILTAG_25h9", cv::aruco::DICT_APRILTAG_25h9},
      {"DICT_APRILTAG_36h10", cv::aruco::DICT_APRILTAG_36h10},
      {"DICT_APRILTAG_36h11", cv::aruco::DICT_APRILTAG_36h11},
  }};
  for (const auto& [n, id] : kNames)
    if (name == n) return id;
  throw std::invalid_argument(
      "unknown aruco dictionary '" + name +
      "' (DICT_4X4_50 ... DICT_7X7_1000, DICT_ARUCO_ORIGINAL, DICT_APRILTAG_36h11 ...)");
}

}  // namespace vc::rig
