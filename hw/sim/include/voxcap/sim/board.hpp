// The virtual rig's calibration board: a printed ChArUco board (OpenCV's aruco module) held in varied
// poses through the capture volume, then laid on the floor, seen by the rig's cameras (their lens
// distortion included) over the empty room, with sensor noise. The truth is the cameras and the board
// poses. This is what `voxcap calibrate capture --emulated` records and what host/calibrate's tests
// solve against; nothing of the performer scene changes (its images stay bit-identical).
//
// Board frame (OpenCV 4.6's CharucoBoard): origin at the outer corner of square (0,0), the top-left of
// the printed image; x along the first row, y down the printed image, z = x × y, into the board (away
// from the printed face). Lying face up on the floor, R_world_from_board = diag(1, -1, -1).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "voxcap/rig/calibration.hpp"
#include "voxcap/sim/rig_layout.hpp"

namespace vc::sim {

struct CharucoSpec {
  int squares_x = 5;  // chessboard squares along the board's x
  int squares_y = 4;
  double square_m = 0.2;
  double marker_m = 0.15;
  std::string dictionary = "DICT_4X4_50";  // an OpenCV predefined dictionary name
  double margin_m = 0.03;                  // white paper around the squares
  bool valid(std::string* why) const;
};

struct BoardCaptureOptions {
  RigLayout rig;                                // used when calibration is empty
  std::optional<rig::Calibration> calibration;  // the rig's cameras (their distortion is rendered)
  CharucoSpec board;
  int held_poses = 80;                // poses in the volume; then one frame with the board on the floor
  cv::Vec3d floor_origin_m{0, 0, 0};  // where the floor board's origin lies (its axes: world x, -y, -z)
  std::string room = "default";       // room_presets()
  double noise_sigma = 2.0;           // Gaussian sensor noise, 8-bit levels
  std::uint64_t seed = 1;
  bool valid(std::string* why) const;
};

// The board sequence: frames 0..held_poses-1 are held in the volume, frame held_poses lies on the floor.
// Thread-safe const members; the same options give the same pixels.
class BoardScene {
 public:
  // Throws std::invalid_argument on bad options.
  explicit BoardScene(const BoardCaptureOptions& options);
  ~BoardScene();
  BoardScene(const BoardScene&) = delete;
  BoardScene& operator=(const BoardScene&) = delete;

  const BoardCaptureOptions& options() const;
  const rig::Calibration& calibration() const;
  int camera_count() const;
  int frame_count() const;  // held_poses + 1
  int floor_frame() const;  // held_poses

  // Board pose: p_world = R_world_from_board · p_board + t_world_from_board.
  cv::Matx33d R_world_from_board(int frame) const;
  cv::Vec3d t_world_from_board(int frame) const;
  // The ChArUco inner corners in the board frame (index = OpenCV's charuco id).
  const std::vector<cv::Vec3d>& corners_board() const;
  // The printed texture (CV_8UC1, the paper margin included) and its pixels per metre.
  const cv::Mat& texture() const;
  double texture_px_per_m() const;

  // One camera image (CV_8UC3 RGB): the room, the board (anti-aliased, its back a plain grey card),
  // noise. `frame` in [0, frame_count()).
  void render(int frame, int cam, cv::Mat& rgb_out) const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace vc::sim
