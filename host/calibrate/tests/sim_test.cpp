// The whole calibration on the virtual rig's images: the board sequence rendered with lens distortion and
// noise, the board detected in every image, the rig solved, and the result against the true cameras, then
// the performer's hull carved by edge/core's carver with the solved and the true calibration from the same
// true silhouettes at 128^3.
//
// The bounds are issue 14's: focal lengths within 0.5 %, principal points within 2 px, centres within 5 mm,
// orientations within 0.2 degrees, reprojection RMS < 0.3 px, the world frame within 5 mm and 0.2 degrees,
// hull IoU >= 0.98. Measured on this rig (host/calibrate/README.md): RMS 0.032 px, focal 0.05 %, principal
// point 0.63 px, centre 1.9 mm, orientation 0.08 degrees, world 0.6 mm / 0.03 degrees, IoU 0.994.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <thread>

#include <gtest/gtest.h>

#include "voxcap/calibrate/solve.hpp"
#include "voxcap/edge/carver.h"
#include "voxcap/rig/c_models.hpp"
#include "voxcap/sim/board.hpp"
#include "voxcap/sim/scene.hpp"

namespace vc::calibrate {
namespace {

constexpr double kDeg = 180.0 / 3.14159265358979323846;

double angle_deg(const cv::Matx33d& a, const cv::Matx33d& b) {
  return std::acos(std::clamp((cv::trace(a * b.t()) - 1) / 2, -1.0, 1.0)) * kDeg;
}

// Renders and detects every (frame, camera) on two threads.
Capture capture_of(const sim::BoardScene& scene) {
  Capture cap;
  const sim::CharucoSpec& b = scene.options().board;
  cap.board =
      parse_board_spec("charuco:" + std::to_string(b.squares_x) + "x" + std::to_string(b.squares_y) + ":" +
                       std::to_string(b.square_m) + ":" + std::to_string(b.marker_m) + ":" + b.dictionary);
  const int n_cam = scene.camera_count(), n_f = scene.frame_count();
  for (const rig::Camera& c : scene.calibration().cameras) {
    cap.camera_names.push_back(c.name);
    cap.image_sizes.emplace_back(c.width, c.height);
  }
  for (int f = 0; f < n_f; ++f)
    cap.frame_names.push_back(f == scene.floor_frame() ? "floor" : std::to_string(f));
  cap.floor_frame = scene.floor_frame();
  cap.detections.assign(static_cast<std::size_t>(n_cam),
                        std::vector<Detection>(static_cast<std::size_t>(n_f)));
  auto work = [&](int part) {
    cv::Mat rgb;
    for (int i = part; i < n_cam * n_f; i += 2) {
      const int c = i % n_cam, f = i / n_cam;
      scene.render(f, c, rgb);
      cap.detections[static_cast<std::size_t>(c)][static_cast<std::size_t>(f)] = detect_board(rgb, cap.board);
    }
  };
  std::thread t(work, 1);
  work(0);
  t.join();
  return cap;
}

std::vector<std::uint8_t> carve(const rig::Calibration& cal, const rig::VoxelGrid& grid,
                                const std::vector<cv::Mat>& masks) {
  const vc_voxel_grid g = rig::to_c_grid(grid);
  std::vector<std::uint8_t> all;
  for (std::size_t k = 0; k + 1 < cal.cameras.size(); k += 2) {
    const vc_camera a = rig::to_c_camera(cal.cameras[k]), b = rig::to_c_camera(cal.cameras[k + 1]);
    vc_carver* c = nullptr;
    char why[200];
    EXPECT_EQ(vc_carver_new(&g, &a, &b, VC_CARVE_CENTRE, &c, why, sizeof why), 0) << why;
    if (!c) return {};
    std::vector<std::uint8_t> bits(vc_carver_bitset_bytes(c));
    EXPECT_EQ(vc_carver_run(c, masks[k].data, masks[k + 1].data, bits.data(), nullptr), 0);
    vc_carver_free(c);
    if (all.empty()) {
      all = bits;
    } else {
      for (std::size_t i = 0; i < all.size(); ++i) all[i] &= bits[i];
    }
  }
  return all;
}

TEST(CalibrateSim, SolvesTheRenderedVirtualRigAndCarvesItsHull) {
  sim::BoardCaptureOptions o;
  o.rig.distortion = true;  // k1 ~ -0.1, k2 ~ 0.03 per camera
  o.noise_sigma = 2.0;
  const sim::BoardScene scene(o);
  const Capture cap = capture_of(scene);
  SolveOptions opt;
  opt.grid = scene.calibration().grid;
  const Solution s = solve(cap, opt);
  ASSERT_EQ(s.calibration.cameras.size(), scene.calibration().cameras.size());
  EXPECT_LT(s.rms_px, 0.3);
  cv::Vec3d origin_sum(0, 0, 0);
  double worst_f = 0, worst_pp = 0, worst_c = 0, worst_r = 0, worst_rms = 0;
  double tilt_sum = 0;
  for (std::size_t c = 0; c < s.calibration.cameras.size(); ++c) {
    const rig::Camera& got = s.calibration.cameras[c];
    const rig::Camera& want = scene.calibration().cameras[c];
    SCOPED_TRACE(want.name);
    worst_f = std::max(
        {worst_f, std::abs(got.K(0, 0) / want.K(0, 0) - 1), std::abs(got.K(1, 1) / want.K(1, 1) - 1)});
    worst_pp =
        std::max(worst_pp, cv::norm(cv::Vec2d(got.K(0, 2) - want.K(0, 2), got.K(1, 2) - want.K(1, 2))));
    worst_c = std::max(worst_c, cv::norm(got.center_world() - want.center_world()));
    worst_r = std::max(worst_r, angle_deg(got.R_cam_from_world, want.R_cam_from_world));
    worst_rms = std::max(worst_rms, s.cameras[c].rms_px);
    EXPECT_NEAR(got.K(0, 0) / want.K(0, 0), 1.0, 0.005);
    EXPECT_NEAR(got.K(1, 1) / want.K(1, 1), 1.0, 0.005);
    EXPECT_LT(cv::norm(cv::Vec2d(got.K(0, 2) - want.K(0, 2), got.K(1, 2) - want.K(1, 2))), 2.0);
    EXPECT_LT(cv::norm(got.center_world() - want.center_world()), 0.005);
    EXPECT_LT(angle_deg(got.R_cam_from_world, want.R_cam_from_world), 0.2);
    EXPECT_LT(s.cameras[c].rms_px, 0.3);
    origin_sum += got.center_world() - want.center_world();
    // The world's z in the camera frame (the floor's normal): the world frame's tilt seen by this camera.
    const cv::Vec3d z_got(got.R_cam_from_world(0, 2), got.R_cam_from_world(1, 2), got.R_cam_from_world(2, 2));
    const cv::Vec3d z_want(want.R_cam_from_world(0, 2), want.R_cam_from_world(1, 2),
                           want.R_cam_from_world(2, 2));
    tilt_sum += std::acos(std::clamp(z_got.dot(z_want), -1.0, 1.0)) * kDeg;
  }
  const double n = static_cast<double>(s.calibration.cameras.size());
  std::printf(
      "rendered rig: RMS %.3f px (worst camera %.3f), worst focal %.3f %%, principal point %.2f px, centre "
      "%.1f "
      "mm, orientation %.3f deg; world origin %.1f mm, z %.3f deg\n",
      s.rms_px, worst_rms, 100 * worst_f, worst_pp, 1000 * worst_c, worst_r, 1000 * cv::norm(origin_sum) / n,
      tilt_sum / n);
  EXPECT_LT(cv::norm(origin_sum) / n, 0.005) << "world origin";
  EXPECT_LT(tilt_sum / n, 0.2) << "world z";

  // The hull from the same true silhouettes, carved with the solved and the true cameras, at 128^3.
  sim::SceneOptions so;
  so.motion.source = "wave";
  so.calibration = scene.calibration();
  so.noise_sigma = 0;
  const sim::Scene performer(so);
  rig::VoxelGrid grid;
  grid.voxel_m = 2.5 / 128;
  grid.min_m = cv::Vec3d(-1.25, -1.25, 0.0);
  grid.nx = grid.ny = grid.nz = 128;
  for (const int frame : {150, 330}) {
    std::vector<cv::Mat> masks(scene.calibration().cameras.size());
    cv::Mat rgb;
    for (std::size_t c = 0; c < masks.size(); ++c)
      performer.render_clean(frame, static_cast<int>(c), rgb, &masks[c]);
    const auto truth = carve(scene.calibration(), grid, masks);
    const auto solved = carve(s.calibration, grid, masks);
    ASSERT_EQ(truth.size(), solved.size());
    std::uint64_t inter = 0, uni = 0;
    for (std::size_t i = 0; i < truth.size(); ++i) {
      inter += static_cast<unsigned>(std::popcount(static_cast<unsigned>(truth[i] & solved[i])));
      uni += static_cast<unsigned>(std::popcount(static_cast<unsigned>(truth[i] | solved[i])));
    }
    ASSERT_GT(uni, 1000u);
    std::printf("frame %d: hull IoU solved vs true calibration %.4f (%llu voxels in the union)\n", frame,
                static_cast<double>(inter) / static_cast<double>(uni), static_cast<unsigned long long>(uni));
    EXPECT_GE(static_cast<double>(inter) / static_cast<double>(uni), 0.98) << "frame " << frame;
  }
}

}  // namespace
}  // namespace vc::calibrate
