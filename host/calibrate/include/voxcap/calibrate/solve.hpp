// Calibrating a rig from board views: intrinsics per camera (cv::calibrateCamera, k1 k2 p1 p2 k3), initial
// extrinsics chained through shared board views along a maximum spanning tree of the cameras (weighted by
// the views they share, so no view has to see every camera), one joint bundle adjustment (Ceres, Huber
// loss) over every camera's intrinsics and extrinsics and every board pose, then the world frame from the
// board lying on the floor: origin at the board's origin, x along its first row, z up (DESIGN.md's frame:
// lay the board with its origin where the volume's centre shall be).
//
// A capture that cannot determine the rig (too few views, a camera that never sees the board, one that
// sees it only edge-on or shares no view with the others, no floor view) is refused with a
// DegenerateCapture whose message is one line naming the camera and what is missing.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "voxcap/calibrate/board.hpp"
#include "voxcap/rig/calibration.hpp"

namespace vc::calibrate {

struct DegenerateCapture : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// What the cameras saw: detections[cam][frame] (empty where the board was not found). Frames are matched
// across cameras by index; frame_names[f] names them in messages; floor_frame is the board on the floor.
struct Capture {
  BoardSpec board;
  std::vector<std::string> camera_names;
  std::vector<cv::Size> image_sizes;
  std::vector<std::string> frame_names;
  std::vector<std::vector<Detection>> detections;
  int floor_frame = -1;
};

struct SolveOptions {
  int min_views = 4;           // board views a camera needs
  int min_corners = 6;         // corners a view needs
  double edge_on_deg = 80;     // a view whose board normal is further than this from the line of sight
  double huber_px = 1.0;       // robust loss scale
  int warn_views = 8;          // fewer: "poorly constrained"
  double warn_coverage = 0.4;  // fraction of a 6x6 image grid holding corners, below: "poorly constrained"
  int max_iterations = 200;
  std::optional<rig::VoxelGrid> grid;  // kept in the result and checked against every view
  bool valid(std::string* why) const;
};

struct CameraReport {
  std::string name;
  int views = 0;      // board views used
  int edge_on = 0;    // views dropped as edge-on
  double rms_px = 0;  // reprojection RMS after the adjustment
  double max_px = 0;
  double coverage = 0;                     // fraction of the 6x6 image grid cells holding a corner
  std::vector<std::string> coverage_rows;  // the grid, '#' covered, '.' not, one string per row
  double grid_in_view = 0;                 // fraction of the voxel grid's boundary points inside the image
  std::vector<std::string> warnings;
};

struct Solution {
  rig::Calibration calibration;
  std::vector<CameraReport> cameras;
  double rms_px = 0;  // over every corner
  int frames_used = 0;
  int residuals = 0;
  int iterations = 0;
  std::vector<std::string> warnings;  // every camera's warnings, "name: ..."
};

Solution solve(const Capture& capture, const SolveOptions& options);

// The fraction of sample points on the grid's boundary (its faces, 9x9 per face) that project inside the
// camera's image (in front of it).
double grid_in_view(const rig::Camera& camera, const rig::VoxelGrid& grid);

}  // namespace vc::calibrate
