// The solver on exact geometry: the virtual rig's cameras (distortion on) and the board sequence's poses,
// corners projected by the true cameras plus Gaussian noise, so the solve is checked against the truth
// without rendering. Also the refusals of degenerate captures, one line each naming the camera.
#include "voxcap/calibrate/solve.hpp"

#include <cmath>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "voxcap/sim/board.hpp"

namespace vc::calibrate {
namespace {

constexpr double kDeg = 180.0 / 3.14159265358979323846;

double angle_deg(const cv::Matx33d& a, const cv::Matx33d& b) {
  const cv::Matx33d d = a * b.t();
  return std::acos(std::clamp((cv::trace(d) - 1) / 2, -1.0, 1.0)) * kDeg;
}

// A capture of the sim's board poses: every corner on the printed face, in the image, board facing the
// camera within 75 degrees, with noise sigma_px.
Capture synthetic(const sim::BoardScene& scene, double sigma_px, std::uint64_t seed = 7) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, sigma_px);
  const sim::CharucoSpec& b = scene.options().board;
  Capture cap;
  cap.board.squares_x = b.squares_x;
  cap.board.squares_y = b.squares_y;
  cap.board.square_m = b.square_m;
  cap.board.marker_m = b.marker_m;
  cap.board.dictionary = b.dictionary;
  const auto corners = cap.board.corners_board();
  for (const rig::Camera& c : scene.calibration().cameras) {
    cap.camera_names.push_back(c.name);
    cap.image_sizes.emplace_back(c.width, c.height);
    cap.detections.emplace_back(static_cast<std::size_t>(scene.frame_count()));
  }
  for (int f = 0; f < scene.frame_count(); ++f) {
    cap.frame_names.push_back(f == scene.floor_frame() ? "floor" : std::to_string(f));
    const cv::Matx33d R = scene.R_world_from_board(f);
    const cv::Vec3d t = scene.t_world_from_board(f);
    for (std::size_t c = 0; c < cap.camera_names.size(); ++c) {
      const rig::Camera& cam = scene.calibration().cameras[c];
      const cv::Vec3d face = -(R * cv::Vec3d(0, 0, 1));
      const cv::Vec3d to_cam = cam.center_world() - (R * cv::Vec3d(0.5, 0.4, 0) + t);
      if (face.dot(to_cam) < std::cos(75 / kDeg) * cv::norm(to_cam)) continue;
      Detection d;
      for (std::size_t id = 0; id < corners.size(); ++id) {
        const cv::Vec3d p = R * cv::Vec3d(corners[id].x, corners[id].y, 0) + t;
        if (cam.to_cam(p)[2] <= 0) continue;
        const cv::Point2d px = cam.project(p) + cv::Point2d(noise(rng), noise(rng));
        if (!cam.in_image(px)) continue;
        d.ids.push_back(static_cast<int>(id));
        d.image_px.push_back(px);
      }
      cap.detections[c][static_cast<std::size_t>(f)] = d;
    }
  }
  cap.floor_frame = scene.floor_frame();
  return cap;
}

sim::BoardCaptureOptions rig_options(int held_poses = 80) {
  sim::BoardCaptureOptions o;
  o.rig.distortion = true;
  o.held_poses = held_poses;
  return o;
}

TEST(CalibrateSolve, RecoversTheVirtualRigFromExactCorners) {
  const sim::BoardScene scene(rig_options());
  const Capture cap = synthetic(scene, 0.1);
  SolveOptions opt;
  opt.grid = scene.calibration().grid;
  const Solution s = solve(cap, opt);
  ASSERT_EQ(s.calibration.cameras.size(), scene.calibration().cameras.size());
  EXPECT_LT(s.rms_px, 0.15);
  cv::Vec3d origin_sum(0, 0, 0);
  for (std::size_t c = 0; c < s.calibration.cameras.size(); ++c) {
    const rig::Camera& got = s.calibration.cameras[c];
    const rig::Camera& want = scene.calibration().cameras[c];
    SCOPED_TRACE(want.name);
    EXPECT_NEAR(got.K(0, 0) / want.K(0, 0), 1.0, 0.005);
    EXPECT_NEAR(got.K(1, 1) / want.K(1, 1), 1.0, 0.005);
    EXPECT_NEAR(got.K(0, 2), want.K(0, 2), 2.0);
    EXPECT_NEAR(got.K(1, 2), want.K(1, 2), 2.0);
    EXPECT_LT(cv::norm(got.center_world() - want.center_world()), 0.005);
    EXPECT_LT(angle_deg(got.R_cam_from_world, want.R_cam_from_world), 0.2);
    EXPECT_LT(s.cameras[c].rms_px, 0.15);
    EXPECT_EQ(s.cameras[c].grid_in_view, 1.0);
    origin_sum += got.center_world() - want.center_world();
  }
  // The world frame (the floor board's): the mean camera-centre offset is its origin's error.
  EXPECT_LT(cv::norm(origin_sum) / static_cast<double>(s.calibration.cameras.size()), 0.005);
  ASSERT_TRUE(s.calibration.grid.has_value());
}

TEST(CalibrateSolve, ACameraThatNeverSeesTheBoardIsRefusedByName) {
  const sim::BoardScene scene(rig_options(24));  // enough views for every camera
  Capture cap = synthetic(scene, 0.1);
  for (Detection& d : cap.detections[3]) d = Detection{};
  EXPECT_THAT([&] { (void)solve(cap, SolveOptions{}); },
              testing::ThrowsMessage<DegenerateCapture>(
                  testing::HasSubstr("ring3 never sees the board (0 of 25 frames)")));
}

TEST(CalibrateSolve, TooFewViewsAreRefusedByName) {
  const sim::BoardScene scene(rig_options(24));  // enough views for every camera
  Capture cap = synthetic(scene, 0.1);
  int kept = 0;
  for (Detection& d : cap.detections[2]) {
    if (!d.empty() && ++kept > 2) d = Detection{};
  }
  try {
    (void)solve(cap, SolveOptions{});
    FAIL() << "a camera with 2 views was accepted";
  } catch (const DegenerateCapture& e) {
    const std::string m = e.what();
    EXPECT_THAT(m, testing::HasSubstr("ring2: 2 usable board views"));
    EXPECT_THAT(m, testing::HasSubstr("at least 4 needed"));
    EXPECT_EQ(m.find('\n'), std::string::npos);
  }
}

TEST(CalibrateSolve, ABoardSeenOnlyEdgeOnIsRefusedByName) {
  const sim::BoardScene scene(rig_options(24));  // enough views for every camera
  Capture cap = synthetic(scene, 0.1);
  // cam4's views replaced by a board turned 86 degrees away from facing it, at several places.
  const rig::Camera& cam = scene.calibration().cameras[4];
  const auto corners = cap.board.corners_board();
  for (Detection& d : cap.detections[4]) d = Detection{};
  for (int f = 0; f < 8; ++f) {
    const cv::Vec3d centre(-0.5 + 0.15 * f, 0.2 * (f % 3), 1.0);
    const cv::Vec3d view = (cam.center_world() - centre) / cv::norm(cam.center_world() - centre);
    const cv::Vec3d side = view.cross(cv::Vec3d(0, 0, 1)) / cv::norm(view.cross(cv::Vec3d(0, 0, 1)));
    const double a = 86 / kDeg;
    const cv::Vec3d face = std::cos(a) * view + std::sin(a) * side;  // the printed face's normal
    const cv::Vec3d z = -face, x = cv::Vec3d(0, 0, 1).cross(z) / cv::norm(cv::Vec3d(0, 0, 1).cross(z));
    const cv::Vec3d y = z.cross(x);
    Detection d;
    for (std::size_t id = 0; id < corners.size(); ++id) {
      const cv::Vec3d p = centre + (corners[id].x - 0.5) * x + (corners[id].y - 0.4) * y;
      d.ids.push_back(static_cast<int>(id));
      d.image_px.push_back(cam.project(p));
    }
    cap.detections[4][static_cast<std::size_t>(f)] = d;
  }
  EXPECT_THAT([&] { (void)solve(cap, SolveOptions{}); },
              testing::ThrowsMessage<DegenerateCapture>(
                  testing::HasSubstr("ring4 sees the board only edge-on (8 views")));
}

TEST(CalibrateSolve, ACameraSharingNoViewAndAMissingFloorAreRefused) {
  const sim::BoardScene scene(rig_options(24));  // enough views for every camera
  Capture cap = synthetic(scene, 0.1);
  // cam5 keeps only frames no other camera sees: shift them to new frames of their own.
  const std::size_t n = cap.frame_names.size();
  for (std::size_t c = 0; c < cap.detections.size(); ++c) cap.detections[c].resize(2 * n);
  for (std::size_t f = 0; f < n; ++f) {
    cap.frame_names.push_back("solo" + std::to_string(f));
    cap.detections[5][n + f] = cap.detections[5][f];
    cap.detections[5][f] = Detection{};
  }
  EXPECT_THAT([&] { (void)solve(cap, SolveOptions{}); },
              testing::ThrowsMessage<DegenerateCapture>(testing::HasSubstr("ring5 shares no board view")));

  Capture no_floor = synthetic(scene, 0.1);
  no_floor.floor_frame = -1;
  EXPECT_THAT(
      [&] { (void)solve(no_floor, SolveOptions{}); },
      testing::ThrowsMessage<DegenerateCapture>(testing::HasSubstr("no camera sees the board on the floor")));
}

TEST(CalibrateBoard, SpecsParseAndBadOnesAreRefused) {
  const BoardSpec b = parse_board_spec("charuco:7x5:0.1:0.075:DICT_5X5_100");
  EXPECT_EQ(b.squares_x, 7);
  EXPECT_EQ(b.squares_y, 5);
  EXPECT_DOUBLE_EQ(b.square_m, 0.1);
  EXPECT_DOUBLE_EQ(b.marker_m, 0.075);
  EXPECT_EQ(parse_board_spec(b.describe()).describe(), b.describe());
  EXPECT_EQ(b.corners_board().size(), 24u);
  EXPECT_EQ(parse_board_spec("chessboard:9x7:0.05").kind, BoardSpec::Kind::chessboard);
  for (const char* bad :
       {"charuco:7x5:0.1:0.2:DICT_5X5_100", "charuco:7x5:0.1:0.05:DICT_9X9", "charuco:7x5:x:0.05:DICT_4X4_50",
        "chessboard:2x2:0.05", "grid:3x3:1", "charuco:7x5:0.1:0.05", "charuco:99x5:0.1:0.05:DICT_4X4_50",
        "charuco:12x12:0.1:0.05:DICT_4X4_50"}) {
    EXPECT_THROW(parse_board_spec(bad), std::invalid_argument) << bad;
  }
}

}  // namespace
}  // namespace vc::calibrate
