// Recording a capture for solve, one synchronized set of images at a time, from the virtual rig or a
// real one: the board is detected in each camera's image, a set is kept when two or more cameras see it
// well (the floor view: when any does), and a kept set is written as <out>/<camera>/<name>.png — the
// layout load_capture (folders.hpp) reads. Progress for the terminal: views per camera, a coarse
// coverage grid per image (cells holding detected corners), and what is still missing.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "voxcap/calibrate/board.hpp"

namespace vc::calibrate {

struct CaptureCamera {
  std::string name;  // its folder
  int width = 0, height = 0;
};

struct CaptureOptions {
  int min_corners = 6;  // corners for a camera to count as seeing the board
  int cells = 4;        // the coverage grid is cells x cells per image
  bool valid(std::string* why) const;
};

class CaptureRecorder {
 public:
  // Creates <out>/<camera>/ for every camera; throws std::runtime_error when it cannot, and
  // std::invalid_argument on bad options or no cameras.
  CaptureRecorder(std::filesystem::path out, std::vector<CaptureCamera> cameras, BoardSpec board,
                  CaptureOptions options = {});

  // One synchronized set: images[c] for cameras[c] (CV_8UC1, or CV_8UC3 in RGB order; empty: that
  // camera's image did not arrive). Detects the board in each; keeps the set when at least two cameras
  // see it (floor: one), writing every image it has. Returns whether it was kept.
  bool add(const std::string& name, const std::vector<cv::Mat>& images, bool floor = false);

  int offered() const { return offered_; }
  int kept() const { return kept_; }
  const std::vector<int>& views() const { return views_; }  // held views per camera (floor excluded)
  int floor_views() const { return floor_views_; }          // cameras that saw the floor board
  // Cameras that saw the board in the last set offered.
  const std::vector<int>& last_seen() const { return last_seen_; }
  // "views: 12 9 14 ..." for the progress line.
  std::string views_line() const;
  // The coverage grids side by side, per camera its views and cells, and "still missing: ..." lines
  // (or that nothing is missing and the solve command to run), as printed at the end of a capture.
  std::string summary() const;
  // What is still missing, one line each (empty: nothing).
  std::vector<std::string> missing() const;

 private:
  std::filesystem::path out_;
  std::vector<CaptureCamera> cams_;
  BoardSpec board_;
  CaptureOptions opt_;
  int offered_ = 0, kept_ = 0, floor_views_ = 0;
  std::vector<int> views_, last_seen_;
  std::vector<std::vector<bool>> cover_;  // per camera, cells x cells, row-major
};

}  // namespace vc::calibrate
