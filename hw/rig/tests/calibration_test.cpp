#include "voxcap/rig/calibration.hpp"

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

namespace vc::rig {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

fs::path temp_file(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / "vc_rig_calibration_test";
  fs::create_directories(dir);
  return dir / name;
}

Calibration sample() {
  Calibration c;
  for (int k = 0; k < 3; ++k) {
    const double a = k * 2.1;
    Camera cam = Camera::look_at("cam" + std::to_string(k), 640, 480, 512.25 + k,
                                 {3.7 * std::sin(a), -3.7 * std::cos(a), 2.3}, {0, 0, 0.9});
    cam.K(0, 2) = 321.125;
    cam.dist = {-0.1 * k, 0.03, 1e-4, -2e-4, 0.001 * k};
    c.cameras.push_back(cam);
  }
  c.grid = VoxelGrid::covering({-1.25, -1.25, 0}, {1.25, 1.25, 2.2}, 0.02);
  return c;
}

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream(p) << text;
}

std::string error_of(const fs::path& p) {
  try {
    (void)read_calibration(p.string());
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "no error";
}

TEST(RigCalibration, RoundTripIsExact) {
  const Calibration in = sample();
  const fs::path p = temp_file("rig.yaml");
  write_calibration(p.string(), in);
  const Calibration out = read_calibration(p.string());
  ASSERT_EQ(out.cameras.size(), in.cameras.size());
  for (std::size_t k = 0; k < in.cameras.size(); ++k) {
    const Camera& a = in.cameras[k];
    const Camera& b = out.cameras[k];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.height, b.height);
    EXPECT_EQ(cv::norm(a.K - b.K, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(a.dist - b.dist, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(a.R_cam_from_world - b.R_cam_from_world, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(a.t_cam_from_world - b.t_cam_from_world, cv::NORM_INF), 0.0);
  }
  ASSERT_TRUE(out.grid.has_value());
  EXPECT_EQ(out.grid->nx, in.grid->nx);
  EXPECT_EQ(out.grid->nz, in.grid->nz);
  EXPECT_EQ(out.grid->voxel_m, in.grid->voxel_m);
  EXPECT_EQ(out.grid->min_m, in.grid->min_m);
}

TEST(RigCalibration, ReadableByPlainFileStorage) {
  // Anyone with OpenCV can read the file without voxcap.
  const fs::path p = temp_file("plain.yaml");
  const Calibration in = sample();
  write_calibration(p.string(), in);
  cv::FileStorage f(p.string(), cv::FileStorage::READ);
  ASSERT_TRUE(f.isOpened());
  EXPECT_EQ(static_cast<int>(f["num_cameras"]), 3);
  cv::Mat K;
  f["cam1"]["K"] >> K;
  EXPECT_EQ(K.at<double>(0, 0), in.cameras[1].K(0, 0));
}

TEST(RigCalibration, AcceptsRvecAndFourDistortionCoefficientsWithoutGrid) {
  const fs::path p = temp_file("rvec.yaml");
  write_text(p, R"(%YAML:1.0
---
cam0:
   width: 320
   height: 240
   K: !!opencv-matrix
      rows: 3
      cols: 3
      dt: d
      data: [ 300., 0., 160., 0., 300., 120., 0., 0., 1. ]
   dist: [ -0.1, 0.01, 0., 0. ]
   rvec: [ 0.1, -0.2, 0.3 ]
   t: [ 0.0, 0.5, 4.0 ]
)");
  const Calibration c = read_calibration(p.string());
  ASSERT_EQ(c.cameras.size(), 1u);
  EXPECT_EQ(c.cameras[0].name, "cam0");
  EXPECT_DOUBLE_EQ(c.cameras[0].dist[0], -0.1);
  EXPECT_DOUBLE_EQ(c.cameras[0].dist[4], 0.0);
  cv::Matx33d R;
  cv::Rodrigues(cv::Vec3d(0.1, -0.2, 0.3), R);
  EXPECT_LT(cv::norm(R - c.cameras[0].R_cam_from_world), 1e-15);
  EXPECT_FALSE(c.grid.has_value());
}

TEST(RigCalibration, ErrorsNameTheFileAndTheNode) {
  EXPECT_THAT(error_of(temp_file("does-not-exist.yaml")), HasSubstr("no such file"));

  const fs::path p = temp_file("bad.yaml");
  write_calibration(p.string(), sample());
  std::ifstream in(p);
  const std::string good((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());

  // cam1 without K.
  std::string text = good;
  const auto cam1 = text.find("cam1:");
  const auto k_pos = text.find("   K:", cam1);
  text.replace(k_pos, 5, "   Q:");
  write_text(p, text);
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(p.string()), HasSubstr("cam1.K: missing")));

  // num_cameras larger than the cameras present.
  text = good;
  text.replace(text.find("num_cameras: 3"), 14, "num_cameras: 4");
  write_text(p, text);
  EXPECT_THAT(error_of(p), HasSubstr("cam3: missing"));

  // A grid with a zero voxel size.
  text = good;
  const auto vox = text.find("voxel_m:");
  text.replace(vox, text.find('\n', vox) - vox, "voxel_m: 0.");
  write_text(p, text);
  EXPECT_THAT(error_of(p), HasSubstr("grid: voxel_m must be"));

  // Not YAML at all.
  write_text(p, "this is : not [ a calibration\n");
  EXPECT_THAT(error_of(p), HasSubstr(p.string()));

  // A 2x2 K.
  write_text(p, "%YAML:1.0\n---\ncam0:\n   width: 10\n   height: 10\n   K: [1, 0, 0, 1]\n"
                "   R: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n   t: [0, 0, 1]\n");
  EXPECT_THAT(error_of(p), HasSubstr("cam0.K: expected 9 numbers, got 4"));

  // R that is not a rotation.
  write_text(p, "%YAML:1.0\n---\ncam0:\n   width: 10\n   height: 10\n"
                "   K: [5, 0, 5, 0, 5, 5, 0, 0, 1]\n   R: [2, 0, 0, 0, 1, 0, 0, 0, 1]\n"
                "   t: [0, 0, 1]\n");
  EXPECT_THAT(error_of(p), HasSubstr("cam0: R must be a rotation"));

  // Rational-model coefficients are refused rather than silently dropped.
  write_text(p, "%YAML:1.0\n---\ncam0:\n   width: 10\n   height: 10\n"
                "   K: [5, 0, 5, 0, 5, 5, 0, 0, 1]\n   dist: [0, 0, 0, 0, 0, 0.5, 0, 0]\n"
                "   R: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n   t: [0, 0, 1]\n");
  EXPECT_THAT(error_of(p), HasSubstr("cam0.dist: only k1 k2 p1 p2 k3"));
}

TEST(RigCalibration, WriteRefusesInvalidCalibrations) {
  Calibration c = sample();
  c.cameras[2].K(1, 1) = 0;
  EXPECT_THROW(write_calibration(temp_file("x.yaml").string(), c), std::runtime_error);
  EXPECT_THROW(write_calibration(temp_file("y.yaml").string(), Calibration{}), std::runtime_error);
}

}  // namespace
}  // namespace vc::rig
