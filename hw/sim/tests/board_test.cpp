// The calibration board against its own truth: OpenCV's ChArUco detector finds the rendered corners
// where the true cameras project the true board corners (lens distortion on), the floor frame lies on
// the floor, a board turned away shows no marker, and the same options give the same pixels.
#include "voxcap/sim/board.hpp"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/imgproc.hpp>

#include "voxcap/rig/aruco_dictionary.hpp"

namespace vc::sim {
namespace {

BoardCaptureOptions small_capture() {
  BoardCaptureOptions o;
  o.rig.distortion = true;
  o.held_poses = 12;
  o.noise_sigma = 2.0;
  return o;
}

struct Found {
  std::vector<int> ids;
  std::vector<cv::Point2f> corners;
};

Found detect(const BoardScene& scene, const cv::Mat& rgb) {
  const CharucoSpec& b = scene.options().board;
  auto dict = cv::aruco::getPredefinedDictionary(rig::aruco_dictionary_id(b.dictionary));
  auto board = cv::aruco::CharucoBoard::create(b.squares_x, b.squares_y, static_cast<float>(b.square_m),
                                               static_cast<float>(b.marker_m), dict);
  cv::Mat grey;
  cv::cvtColor(rgb, grey, cv::COLOR_RGB2GRAY);
  std::vector<std::vector<cv::Point2f>> mc;
  std::vector<int> mid;
  cv::aruco::detectMarkers(grey, dict, mc, mid);
  Found f;
  if (!mid.empty()) cv::aruco::interpolateCornersCharuco(mc, mid, grey, board, f.corners, f.ids);
  // OpenCV 4.6's interpolation leaves its corners half a pixel off (+0.5, +0.5: a resampled printed board
  // shows it too); cv::cornerSubPix itself is unbiased, so the corners are refined once more.
  if (!f.corners.empty()) {
    cv::cornerSubPix(grey, f.corners, cv::Size(2, 2), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 50, 1e-3));
  }
  return f;
}

TEST(SimBoard, DetectedCornersAreTheTrueProjectionsWithDistortion) {
  const BoardScene scene(small_capture());
  ASSERT_EQ(scene.frame_count(), 13);
  std::vector<double> err;
  std::vector<int> views(static_cast<std::size_t>(scene.camera_count()), 0);
  cv::Mat rgb;
  for (int f = 0; f < scene.frame_count(); ++f) {
    for (int c = 0; c < scene.camera_count(); ++c) {
      scene.render(f, c, rgb);
      ASSERT_EQ(rgb.type(), CV_8UC3);
      const Found found = detect(scene, rgb);
      if (found.ids.size() >= 6) ++views[static_cast<std::size_t>(c)];
      const rig::Camera& cam = scene.calibration().cameras[static_cast<std::size_t>(c)];
      for (std::size_t i = 0; i < found.ids.size(); ++i) {
        const cv::Vec3d p_board = scene.corners_board()[static_cast<std::size_t>(found.ids[i])];
        const cv::Point2d truth =
            cam.project(scene.R_world_from_board(f) * p_board + scene.t_world_from_board(f));
        err.push_back(cv::norm(cv::Point2d(found.corners[i]) - truth));
      }
    }
  }
  ASSERT_GT(err.size(), 300u);
  for (int v : views) EXPECT_GE(v, 2) << "every camera sees the board in some held pose";
  std::sort(err.begin(), err.end());
  const double median = err[err.size() / 2], p95 = err[err.size() * 95 / 100];
  EXPECT_LT(median, 0.15);
  EXPECT_LT(p95, 0.5);
}

TEST(SimBoard, FloorFrameLiesOnTheFloorAndIsSeen) {
  const BoardScene scene(small_capture());
  const int f = scene.floor_frame();
  for (const cv::Vec3d& p : scene.corners_board()) {
    const cv::Vec3d w = scene.R_world_from_board(f) * p + scene.t_world_from_board(f);
    EXPECT_NEAR(w[2], 0.0, 1e-12);
  }
  // The printed face is up: the board's z (into the board) points down.
  EXPECT_NEAR((scene.R_world_from_board(f) * cv::Vec3d(0, 0, 1))[2], -1.0, 1e-12);
  int seen = 0;
  cv::Mat rgb;
  for (int c = 0; c < scene.camera_count(); ++c) {
    scene.render(f, c, rgb);
    if (detect(scene, rgb).ids.size() >= 6) ++seen;
  }
  EXPECT_GE(seen, 2);
}

TEST(SimBoard, BoardTurnedAwayShowsNoMarker) {
  BoardCaptureOptions o = small_capture();
  const BoardScene scene(o);
  cv::Mat rgb;
  // Each camera sees the back of some held board (the printed face looking away): no corner there.
  int backs = 0;
  for (int f = 0; f < scene.floor_frame(); ++f) {
    for (int c = 0; c < scene.camera_count(); ++c) {
      const rig::Camera& cam = scene.calibration().cameras[static_cast<std::size_t>(c)];
      const cv::Vec3d centre = scene.t_world_from_board(f);
      const cv::Vec3d face = -(scene.R_world_from_board(f) * cv::Vec3d(0, 0, 1));
      if (face.dot(cam.center_world() - centre) >= 0) continue;
      scene.render(f, c, rgb);
      EXPECT_TRUE(detect(scene, rgb).ids.empty()) << "frame " << f << " cam " << c;
      ++backs;
    }
  }
  EXPECT_GT(backs, 0);
}

TEST(SimBoard, SameOptionsSamePixels) {
  const BoardScene a(small_capture());
  const BoardScene b(small_capture());
  cv::Mat ia, ib;
  a.render(3, 1, ia);
  b.render(3, 1, ib);
  EXPECT_EQ(cv::norm(ia, ib, cv::NORM_INF), 0.0);
  BoardCaptureOptions o = small_capture();
  o.board.marker_m = 0.2;  // larger than the square
  EXPECT_THROW(BoardScene{o}, std::invalid_argument);
  o = small_capture();
  o.board.dictionary = "DICT_9X9_1";
  EXPECT_THROW(BoardScene{o}, std::invalid_argument);
}

}  // namespace
}  // namespace vc::sim
