// Carving against a straightforward float reference: every voxel centre projected with
// cv::projectPoints (OpenCV's own implementation of the model), rounded to the nearest pixel and
// looked up in both masks. The carver must agree voxel for voxel.
#include "voxcap/edge/carver.h"

#include <gtest/gtest.h>

#include <cerrno>
#include <cmath>
#include <memory>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <ostream>
#include <random>
#include <string>
#include <vector>

#include "synth.hpp"

namespace {

using vc::edge_test::look_at;

struct CarverDeleter {
  void operator()(vc_carver* c) const { vc_carver_free(c); }
};
using CarverPtr = std::unique_ptr<vc_carver, CarverDeleter>;

// A new carver (null, with the reason reported, when vc_carver_new fails).
CarverPtr new_carver(const vc_voxel_grid& g, const vc_camera& cam0, const vc_camera& cam1) {
  vc_carver* c = nullptr;
  char why[200];
  EXPECT_EQ(vc_carver_new(&g, &cam0, &cam1, VC_CARVE_CENTRE, &c, why, sizeof why), 0) << why;
  return CarverPtr(c);
}

// Pixel of every voxel centre in one camera via cv::projectPoints, or -1 when unseen.
std::vector<int> reference_pixels(const vc_voxel_grid& g, const vc_camera& cam) {
  std::vector<cv::Point3d> pts;
  pts.reserve(static_cast<size_t>(g.nx) * g.ny * g.nz);
  for (uint32_t k = 0; k < g.nz; k++)
    for (uint32_t j = 0; j < g.ny; j++)
      for (uint32_t i = 0; i < g.nx; i++)
        pts.emplace_back(g.min_m[0] + (i + 0.5) * g.voxel_m, g.min_m[1] + (j + 0.5) * g.voxel_m,
                         g.min_m[2] + (k + 0.5) * g.voxel_m);
  cv::Matx33d R(cam.R_cam_from_world), K(cam.K);
  cv::Vec3d rvec, tvec(cam.t_cam_from_world[0], cam.t_cam_from_world[1], cam.t_cam_from_world[2]);
  cv::Rodrigues(R, rvec);
  std::vector<double> dist(cam.dist, cam.dist + 5);
  std::vector<cv::Point2d> uv;
  cv::projectPoints(pts, rvec, tvec, K, dist, uv);
  std::vector<int> pix(pts.size(), -1);
  for (size_t n = 0; n < pts.size(); n++) {
    cv::Vec3d pc = R * cv::Vec3d(pts[n].x, pts[n].y, pts[n].z) + tvec;
    if (!(pc[2] > 0)) continue;
    double x = std::floor(uv[n].x + 0.5), y = std::floor(uv[n].y + 0.5);
    if (x < 0 || y < 0 || x >= cam.width || y >= cam.height) continue;
    pix[n] = static_cast<int>(y) * cam.width + static_cast<int>(x);
  }
  return pix;
}

std::vector<uint8_t> reference_carve(const std::vector<int>& pix0, const std::vector<int>& pix1,
                                     const std::vector<uint8_t>& m0, const std::vector<uint8_t>& m1) {
  std::vector<uint8_t> bits((pix0.size() + 7) / 8, 0);
  for (size_t n = 0; n < pix0.size(); n++)
    if (pix0[n] >= 0 && pix1[n] >= 0 && m0[pix0[n]] && m1[pix1[n]]) bits[n / 8] |= 1u << (n % 8);
  return bits;
}

struct Rig {
  vc_camera cam[2];
};

// Two cameras 3-4 m from the grid centre, 40-100 degrees apart, with barrel distortion.
Rig random_rig(std::mt19937& rng, int w, int h) {
  std::uniform_real_distribution<double> u(0, 1);
  Rig r;
  double a0 = u(rng) * 2 * M_PI;
  double a[2] = {a0, a0 + (40 + 60 * u(rng)) * M_PI / 180};
  for (int c = 0; c < 2; c++) {
    double d = 3 + u(rng);
    double eye[3] = {d * std::cos(a[c]), d * std::sin(a[c]), 1.2 + 0.8 * u(rng)};
    double target[3] = {0.1 * u(rng), -0.1 * u(rng), 0.9};
    double dist[5] = {-0.25 + 0.1 * u(rng), 0.08 * u(rng), 0.002 * (u(rng) - 0.5), 0.002 * (u(rng) - 0.5),
                      -0.01 * u(rng)};
    r.cam[c] = look_at(eye, target, w, h, 0.9 * w, dist);
  }
  return r;
}

// A mask of random ellipses (a person-sized cluster) plus speckle noise.
std::vector<uint8_t> random_mask(std::mt19937& rng, int w, int h, int blobs, double speckle) {
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<uint8_t> m(static_cast<size_t>(w) * h, 0);
  for (int b = 0; b < blobs; b++) {
    double cx = w * (0.3 + 0.4 * u(rng)), cy = h * (0.2 + 0.6 * u(rng));
    double rx = w * (0.03 + 0.12 * u(rng)), ry = h * (0.05 + 0.3 * u(rng));
    for (int y = 0; y < h; y++)
      for (int x = 0; x < w; x++) {
        double dx = (x - cx) / rx, dy = (y - cy) / ry;
        if (dx * dx + dy * dy <= 1) m[static_cast<size_t>(y) * w + x] = 255;
      }
  }
  for (auto& v : m)
    if (u(rng) < speckle) v = static_cast<uint8_t>(v ? 0 : 255);
  return m;
}

void expect_same_bits(const std::vector<uint8_t>& got, const std::vector<uint8_t>& ref, uint64_t nvox) {
  ASSERT_EQ(got.size(), ref.size());
  uint64_t diff = 0, first = UINT64_MAX;
  for (uint64_t n = 0; n < nvox; n++)
    if (((got[n / 8] ^ ref[n / 8]) >> (n % 8)) & 1) {
      diff++;
      if (first == UINT64_MAX) first = n;
    }
  EXPECT_EQ(diff, 0u) << "first differing voxel " << first;
  if (nvox % 8) {
    EXPECT_EQ(got.back() >> (nvox % 8), 0) << "bits past the last voxel must be 0";
  }
}

TEST(Camera, ProjectionMatchesOpenCV) {
  std::mt19937 rng(1);
  Rig rig = random_rig(rng, 640, 480);
  vc_voxel_grid g{57, 49, 53, {-1.1, -0.9, 0.02}, 0.0377};
  for (const auto& cam : rig.cam) {
    std::vector<int> ref = reference_pixels(g, cam);
    size_t n = 0, seen = 0;
    for (uint32_t k = 0; k < g.nz; k++)
      for (uint32_t j = 0; j < g.ny; j++)
        for (uint32_t i = 0; i < g.nx; i++, n++) {
          double p[3] = {g.min_m[0] + (i + 0.5) * g.voxel_m, g.min_m[1] + (j + 0.5) * g.voxel_m,
                         g.min_m[2] + (k + 0.5) * g.voxel_m};
          int x = -1, y = -1;
          int in = vc_camera_project(&cam, p, &x, &y);
          ASSERT_EQ(in, ref[n] >= 0) << n;
          if (in) {
            ASSERT_EQ(y * cam.width + x, ref[n]) << n;
            seen++;
          }
        }
    EXPECT_GT(seen, n / 2);
  }
}

TEST(Camera, ChecksRejectBadModels) {
  std::mt19937 rng(2);
  Rig rig = random_rig(rng, 64, 48);
  char why[160] = "unset";
  EXPECT_EQ(vc_camera_check(&rig.cam[0], why, sizeof why), 0);
  EXPECT_STREQ(why, "");
  vc_camera c = rig.cam[0];
  c.K[1] = 0.5;
  EXPECT_EQ(vc_camera_check(&c, why, sizeof why), -EINVAL);
  EXPECT_STRNE(why, "");
  EXPECT_NE(std::string(why).find("skew"), std::string::npos) << why;
  c = rig.cam[0];
  c.R_cam_from_world[0] *= 2;
  EXPECT_EQ(vc_camera_check(&c, why, sizeof why), -EINVAL);
  EXPECT_EQ(std::string(why).rfind("R must be a rotation matrix", 0), 0u) << why;
  c = rig.cam[0];
  c.width = 0;
  EXPECT_EQ(vc_camera_check(&c, nullptr, 0), -EINVAL);
  EXPECT_EQ(vc_camera_check(&c, why, sizeof why), -EINVAL);
  EXPECT_STREQ(why, "image size 0x48 must be 1..16384 each");
  vc_voxel_grid g{4, 4, 0, {0, 0, 0}, 0.1};
  EXPECT_EQ(vc_grid_check(&g, why, sizeof why), -EINVAL);
  EXPECT_STREQ(why, "grid dimensions must be 1..4096 each, not 4x4x0");
  g.nz = 4;
  EXPECT_EQ(vc_grid_check(&g, why, sizeof why), 0);
  EXPECT_STREQ(why, "");
  g.voxel_m = -1;
  EXPECT_EQ(vc_grid_check(&g, nullptr, 0), -EINVAL);
  vc_carver* failed = reinterpret_cast<vc_carver*>(why);  // must come back NULL
  EXPECT_EQ(vc_carver_new(&g, &rig.cam[0], &rig.cam[1], VC_CARVE_CENTRE, &failed, why, sizeof why), -EINVAL);
  EXPECT_EQ(failed, nullptr);
  EXPECT_STREQ(why, "carver: voxel size must be positive, not -1 m");
  g.voxel_m = 0.1;
  EXPECT_EQ(vc_carver_new(&g, &rig.cam[0], &c, VC_CARVE_CENTRE, &failed, why, sizeof why),
            -EINVAL);  // c: width 0
  EXPECT_EQ(failed, nullptr);
  EXPECT_STREQ(why, "carver: camera 1: image size 0x48 must be 1..16384 each");
  EXPECT_EQ(vc_carver_new(&g, &rig.cam[0], &rig.cam[1], VC_CARVE_CENTRE, nullptr, why, sizeof why), -EINVAL);
  EXPECT_EQ(vc_carver_new(&g, &rig.cam[0], &rig.cam[1], VC_CARVE_CENTRE, &failed, why, sizeof why), 0);
  EXPECT_STREQ(why, "");
  vc_carver_free(failed);
  vc_carver_free(nullptr);
}

struct GridCase {
  vc_voxel_grid grid;
  int width, height;
};

void PrintTo(const GridCase& c, std::ostream* os) {
  *os << c.grid.nx << "x" << c.grid.ny << "x" << c.grid.nz << " voxels of " << c.grid.voxel_m << " m, "
      << c.width << "x" << c.height << " px";
}

class CarverVsReference : public ::testing::TestWithParam<GridCase> {};

TEST_P(CarverVsReference, EqualsFloatReferenceVoxelForVoxel) {
  const GridCase& gc = GetParam();
  std::mt19937 rng(static_cast<unsigned>(gc.grid.nx * 131 + gc.grid.nz));
  for (int rep = 0; rep < 3; rep++) {
    Rig rig = random_rig(rng, gc.width, gc.height);
    CarverPtr cv = new_carver(gc.grid, rig.cam[0], rig.cam[1]);
    ASSERT_NE(cv, nullptr);
    const uint64_t nvox = vc_carver_voxels(cv.get());
    ASSERT_EQ(nvox, static_cast<uint64_t>(gc.grid.nx) * gc.grid.ny * gc.grid.nz);
    std::vector<int> pix0 = reference_pixels(gc.grid, rig.cam[0]);
    std::vector<int> pix1 = reference_pixels(gc.grid, rig.cam[1]);
    uint64_t unseen = 0;
    for (size_t n = 0; n < pix0.size(); n++) unseen += pix0[n] < 0 || pix1[n] < 0;
    EXPECT_DOUBLE_EQ(vc_carver_unseen_fraction(cv.get()), static_cast<double>(unseen) / nvox);

    const size_t npx0 = static_cast<size_t>(gc.width) * gc.height;
    std::vector<std::pair<std::vector<uint8_t>, std::vector<uint8_t>>> masks = {
        {std::vector<uint8_t>(npx0, 0), std::vector<uint8_t>(npx0, 255)},    // nothing in cam 0
        {std::vector<uint8_t>(npx0, 255), std::vector<uint8_t>(npx0, 255)},  // everything seen
        {random_mask(rng, gc.width, gc.height, 4, 0.0), random_mask(rng, gc.width, gc.height, 4, 0.0)},
        {random_mask(rng, gc.width, gc.height, 6, 0.02), random_mask(rng, gc.width, gc.height, 3, 0.3)},
    };
    for (const auto& [m0, m1] : masks) {
      std::vector<uint8_t> bits(vc_carver_bitset_bytes(cv.get()), 0xCD);
      vc_carve_stats st;
      ASSERT_EQ(vc_carver_run(cv.get(), m0.data(), m1.data(), bits.data(), &st), 0);
      std::vector<uint8_t> ref = reference_carve(pix0, pix1, m0, m1);
      expect_same_bits(bits, ref, nvox);
      uint64_t pop = 0;
      for (uint64_t n = 0; n < nvox; n++) pop += (ref[n / 8] >> (n % 8)) & 1;
      EXPECT_EQ(st.occupied, pop);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(
    Grids, CarverVsReference,
    ::testing::Values(GridCase{{64, 64, 64, {-1.0, -1.0, 0.0}, 2.0 / 64}, 320, 240},
                      GridCase{{37, 29, 45, {-1.3, -1.1, -0.2}, 0.061}, 320, 240},  // odd sizes
                      GridCase{{16, 16, 16, {-0.4, -0.4, 0.5}, 0.05}, 203, 157},    // odd image
                      GridCase{{60, 60, 20, {-3.0, -3.0, 0.0}, 0.1}, 320, 240},     // partly unseen
                      GridCase{{1, 1, 1, {0.0, 0.0, 1.0}, 0.1}, 64, 48},
                      GridCase{{100, 3, 70, {-1.0, -0.1, 0.3}, 0.02}, 320, 240}),
    [](const auto& p) {
      const auto& g = p.param.grid;
      return std::to_string(g.nx) + "x" + std::to_string(g.ny) + "x" + std::to_string(g.nz) + "_" +
             std::to_string(p.param.width);
    });

TEST(Carver, CamerasBehindAndBesideTheGridSeeNothing) {
  std::mt19937 rng(9);
  Rig rig = random_rig(rng, 320, 240);
  // Move camera 1 to look away from the grid: every voxel is behind or beside it.
  double eye[3] = {0, 0, 1}, away[3] = {10, 0, 1};
  const double dist[5] = {0, 0, 0, 0, 0};
  vc_camera c1 = look_at(eye, away, 320, 240, 200, dist);
  vc_voxel_grid g{20, 60, 20, {-3, -3, 0}, 0.1};  // x in [-3, -1]: behind the camera
  CarverPtr cv = new_carver(g, rig.cam[0], c1);
  ASSERT_NE(cv, nullptr);
  EXPECT_DOUBLE_EQ(vc_carver_unseen_fraction(cv.get()), 1.0);
  std::vector<uint8_t> full(320 * 240, 255), bits(vc_carver_bitset_bytes(cv.get()), 0xFF);
  ASSERT_EQ(vc_carver_run(cv.get(), full.data(), full.data(), bits.data(), nullptr), 0);
  for (uint8_t b : bits) ASSERT_EQ(b, 0);
}

TEST(Carver, RunRejectsNullArguments) {
  std::mt19937 rng(4);
  Rig rig = random_rig(rng, 64, 48);
  vc_voxel_grid g{8, 8, 8, {-1, -1, 0}, 0.25};
  CarverPtr cv = new_carver(g, rig.cam[0], rig.cam[1]);
  ASSERT_NE(cv, nullptr);
  EXPECT_GT(vc_carver_memory_bytes(cv.get()), 0u);
  std::vector<uint8_t> m(64 * 48), bits(vc_carver_bitset_bytes(cv.get()));
  EXPECT_EQ(vc_carver_run(cv.get(), nullptr, m.data(), bits.data(), nullptr), -EINVAL);
  EXPECT_EQ(vc_carver_run(cv.get(), m.data(), m.data(), nullptr, nullptr), -EINVAL);
  EXPECT_EQ(vc_carver_run(nullptr, m.data(), m.data(), bits.data(), nullptr), -EINVAL);
}

}  // namespace
