// Carving against a straightforward float reference: every voxel centre projected with
// cv::projectPoints (OpenCV's own implementation of the model), rounded to the nearest pixel and
// looked up in both masks. The carver must agree voxel for voxel.
// The footprint rule against a brute-force reference: the 8 corners of every voxel projected with
// cv::projectPoints, the pixels whose squares touch their bounding box; and its superset property
// on masks rendered exactly from point clouds. The subpixel rule against the centres' exact
// projections (the up to 2x2 pixels around them) and on masks ray-cast from spheres.
#include "voxcap/edge/carver.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
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
CarverPtr new_carver(const vc_voxel_grid& g, const vc_camera& cam0, const vc_camera& cam1,
                     vc_carve_rule rule = VC_CARVE_CENTRE) {
  vc_carver* c = nullptr;
  char why[200];
  EXPECT_EQ(vc_carver_new(&g, &cam0, &cam1, rule, &c, why, sizeof why), 0) << why;
  return CarverPtr(c);
}

// Every voxel centre (voxel order) projected into one camera with cv::projectPoints: uv, and whether
// the centre is in front of the camera.
struct CentreProjections {
  std::vector<cv::Point2d> uv;
  std::vector<bool> front;
};
CentreProjections project_centres(const vc_voxel_grid& g, const vc_camera& cam) {
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
  CentreProjections out;
  cv::projectPoints(pts, rvec, tvec, K, dist, out.uv);
  out.front.resize(pts.size());
  for (size_t n = 0; n < pts.size(); n++)
    out.front[n] = (R * cv::Vec3d(pts[n].x, pts[n].y, pts[n].z) + tvec)[2] > 0;
  return out;
}

// Pixel of every voxel centre in one camera via cv::projectPoints, or -1 when unseen.
std::vector<int> reference_pixels(const vc_voxel_grid& g, const vc_camera& cam) {
  const CentreProjections cp = project_centres(g, cam);
  const std::vector<cv::Point2d>& uv = cp.uv;
  std::vector<int> pix(uv.size(), -1);
  for (size_t n = 0; n < uv.size(); n++) {
    if (!cp.front[n]) continue;
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
  failed = reinterpret_cast<vc_carver*>(why);
  EXPECT_EQ(
      vc_carver_new(&g, &rig.cam[0], &rig.cam[1], static_cast<vc_carve_rule>(7), &failed, why, sizeof why),
      -EINVAL);
  EXPECT_EQ(failed, nullptr);
  EXPECT_STREQ(why, "carver: carve rule 7 is not centre (0), footprint (1) or subpixel (2)");
  EXPECT_EQ(vc_carver_new(&g, &rig.cam[0], &rig.cam[1], VC_CARVE_FOOTPRINT, &failed, why, sizeof why), 0);
  EXPECT_STREQ(why, "");
  vc_carver_free(failed);
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

// ---- the footprint rule ----------------------------------------------------------------------

// A pixel rectangle {x0, y0, x1, y1}, inclusive.
struct Rect {
  int x0, y0, x1, y1;
};

// The brute-force footprint of every voxel in one camera: its 8 corners through cv::projectPoints,
// the pixels whose squares touch their bounding box, clipped to the image; unseen (x1 < x0) when a
// corner is not in front of the camera or the rectangle misses the image. No curvature margin.
std::vector<Rect> reference_footprints(const vc_voxel_grid& g, const vc_camera& cam) {
  const uint32_t cx = g.nx + 1, cy = g.ny + 1, cz = g.nz + 1;
  std::vector<cv::Point3d> pts;
  pts.reserve(static_cast<size_t>(cx) * cy * cz);
  for (uint32_t k = 0; k < cz; k++)
    for (uint32_t j = 0; j < cy; j++)
      for (uint32_t i = 0; i < cx; i++)
        pts.emplace_back(g.min_m[0] + i * g.voxel_m, g.min_m[1] + j * g.voxel_m, g.min_m[2] + k * g.voxel_m);
  cv::Matx33d R(cam.R_cam_from_world), K(cam.K);
  cv::Vec3d rvec, tvec(cam.t_cam_from_world[0], cam.t_cam_from_world[1], cam.t_cam_from_world[2]);
  cv::Rodrigues(R, rvec);
  std::vector<double> dist(cam.dist, cam.dist + 5);
  std::vector<cv::Point2d> uv;
  cv::projectPoints(pts, rvec, tvec, K, dist, uv);
  std::vector<bool> front(pts.size());
  for (size_t n = 0; n < pts.size(); n++)
    front[n] = (R * cv::Vec3d(pts[n].x, pts[n].y, pts[n].z) + tvec)[2] > 0;
  std::vector<Rect> out;
  out.reserve(static_cast<size_t>(g.nx) * g.ny * g.nz);
  for (uint32_t k = 0; k < g.nz; k++)
    for (uint32_t j = 0; j < g.ny; j++)
      for (uint32_t i = 0; i < g.nx; i++) {
        double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
        bool ok = true;
        for (int q = 0; q < 8; q++) {
          size_t n = (i + (q & 1)) + cx * ((j + (q >> 1 & 1)) + static_cast<size_t>(cy) * (k + (q >> 2)));
          ok = ok && front[n];
          u0 = std::min(u0, uv[n].x);
          u1 = std::max(u1, uv[n].x);
          v0 = std::min(v0, uv[n].y);
          v1 = std::max(v1, uv[n].y);
        }
        double x0 = std::max(std::ceil(u0 - 0.5), 0.0), x1 = std::min(std::floor(u1 + 0.5), cam.width - 1.0);
        double y0 = std::max(std::ceil(v0 - 0.5), 0.0), y1 = std::min(std::floor(v1 + 0.5), cam.height - 1.0);
        if (!ok || !(x0 <= x1 && y0 <= y1))
          out.push_back({0, 0, -1, -1});
        else
          out.push_back(
              {static_cast<int>(x0), static_cast<int>(y0), static_cast<int>(x1), static_cast<int>(y1)});
      }
  return out;
}

// Summed-area table of "foreground" for rectangle queries.
struct PixelSat {
  int w, h;
  std::vector<uint32_t> s;
  PixelSat(const std::vector<uint8_t>& m, int width, int height)
      : w(width), h(height), s(static_cast<size_t>(width + 1) * (height + 1), 0) {
    for (int y = 0; y < h; y++)
      for (int x = 0; x < w; x++)
        s[(y + 1) * (w + 1) + x + 1] = s[y * (w + 1) + x + 1] + s[(y + 1) * (w + 1) + x] -
                                       s[y * (w + 1) + x] + (m[static_cast<size_t>(y) * w + x] != 0);
  }
  bool any(int x0, int y0, int x1, int y1) const {
    return s[(y1 + 1) * (w + 1) + x1 + 1] - s[y0 * (w + 1) + x1 + 1] - s[(y1 + 1) * (w + 1) + x0] +
               s[y0 * (w + 1) + x0] >
           0;
  }
};

bool contains(const uint32_t r[4], const Rect& q) {
  return static_cast<int>(r[0]) <= q.x0 && static_cast<int>(r[1]) <= q.y0 && static_cast<int>(r[2]) >= q.x1 &&
         static_cast<int>(r[3]) >= q.y1;
}

// A grid for the footprint rule, with how much more than the exact footprints its rectangles may read
// (pixels, summed over voxels and cameras; leaf-wide rectangles and at most 4 sizes per camera).
struct FootprintCase {
  GridCase gc;
  double max_area_ratio;
};

void PrintTo(const FootprintCase& c, std::ostream* os) {
  PrintTo(c.gc, os);
  *os << ", area ratio < " << c.max_area_ratio;
}

class FootprintVsReference : public ::testing::TestWithParam<FootprintCase> {};

// The carver's rectangles hold the brute-force footprints (and are not much larger), and its carve
// equals "some foreground pixel in each of the carver's rectangles" voxel for voxel, through a
// sequence of masks on one carver (the dilated masks' regions change from frame to frame).
TEST_P(FootprintVsReference, HoldsTheCornersFootprintAndCarvesItsRectanglesExactly) {
  const GridCase& gc = GetParam().gc;
  std::mt19937 rng(static_cast<unsigned>(gc.grid.nx * 71 + gc.grid.nz));
  for (int rep = 0; rep < 2; rep++) {
    Rig rig = random_rig(rng, gc.width, gc.height);
    CarverPtr cv = new_carver(gc.grid, rig.cam[0], rig.cam[1], VC_CARVE_FOOTPRINT);
    ASSERT_NE(cv, nullptr);
    const uint64_t nvox = vc_carver_voxels(cv.get());
    for (int c = 0; c < 2; c++) {
      EXPECT_GE(vc_carver_classes(cv.get(), c), 1);
      EXPECT_LE(vc_carver_classes(cv.get(), c), 4);
    }
    std::vector<Rect> ref[2] = {reference_footprints(gc.grid, rig.cam[0]),
                                reference_footprints(gc.grid, rig.cam[1])};
    std::vector<int> centre[2] = {reference_pixels(gc.grid, rig.cam[0]),
                                  reference_pixels(gc.grid, rig.cam[1])};
    std::vector<std::array<Rect, 2>> rects(nvox);
    std::vector<bool> seen(nvox, false);
    uint64_t n = 0, ref_seen = 0, extra_seen = 0, pairs = 0, loose = 0;
    double ref_area = 0, area = 0;
    for (uint32_t k = 0; k < gc.grid.nz; k++)
      for (uint32_t j = 0; j < gc.grid.ny; j++)
        for (uint32_t i = 0; i < gc.grid.nx; i++, n++) {
          uint32_t r[2][4];
          bool both = ref[0][n].x1 >= 0 && ref[1][n].x1 >= 0;
          ref_seen += both;
          seen[n] = vc_carver_footprint(cv.get(), i, j, k, r) == 1;
          if (both) {
            ASSERT_TRUE(seen[n]) << "voxel " << n << " is seen by both cameras but not tested";
          } else {
            extra_seen += seen[n];  // the curvature margin may reach one pixel into an image
          }
          if (centre[0][n] >= 0 && centre[1][n] >= 0) {
            // the footprint holds the centre's pixel: the footprint hull holds the centre rule's
            ASSERT_TRUE(seen[n]) << "voxel " << n << " is seen by the centre rule";
            for (int c = 0; c < 2; c++) {
              const uint32_t px = static_cast<uint32_t>(centre[c][n] % static_cast<int>(rig.cam[c].width)),
                             py = static_cast<uint32_t>(centre[c][n] / static_cast<int>(rig.cam[c].width));
              EXPECT_TRUE(r[c][0] <= px && px <= r[c][2] && r[c][1] <= py && py <= r[c][3]) << "voxel " << n;
            }
          }
          if (!seen[n]) continue;
          for (int c = 0; c < 2; c++) {
            rects[n][c] = {static_cast<int>(r[c][0]), static_cast<int>(r[c][1]), static_cast<int>(r[c][2]),
                           static_cast<int>(r[c][3])};
            if (!both) continue;
            ASSERT_TRUE(contains(r[c], ref[c][n])) << "voxel " << n << " camera " << c;
            // The curvature margin adds at most a pixel on the left/top where the lens is smooth at the
            // voxel's scale; more where a large voxel's box reaches far outside the image or close to
            // the camera (counted, bounded below). Classes widen to the right and bottom only.
            pairs++;
            loose +=
                ref[c][n].x0 - static_cast<int>(r[c][0]) > 1 || ref[c][n].y0 - static_cast<int>(r[c][1]) > 1;
            ref_area += (ref[c][n].x1 - ref[c][n].x0 + 1.0) * (ref[c][n].y1 - ref[c][n].y0 + 1.0);
            area += (r[c][2] - r[c][0] + 1.0) * (r[c][3] - r[c][1] + 1.0);
          }
        }
    EXPECT_LE(extra_seen, nvox / 50 + 1);
    EXPECT_LE(loose, pairs / 20) << "rectangles more than a pixel left of or above the footprint";
    EXPECT_DOUBLE_EQ(vc_carver_unseen_fraction(cv.get()),
                     static_cast<double>(nvox - ref_seen - extra_seen) / static_cast<double>(nvox));
    if (ref_seen > 0) {
      EXPECT_LT(area, GetParam().max_area_ratio * ref_area)
          << "rectangles read " << area / ref_area << "x the footprints' pixels";
      std::printf(
          "rectangles read %.3fx the footprints' pixels; %.4f of them more than a pixel left/up; %llu extra "
          "seen\n",
          area / ref_area, static_cast<double>(loose) / static_cast<double>(pairs),
          static_cast<unsigned long long>(extra_seen));
    }

    const size_t npx = static_cast<size_t>(gc.width) * gc.height;
    std::vector<std::pair<std::vector<uint8_t>, std::vector<uint8_t>>> masks = {
        {random_mask(rng, gc.width, gc.height, 4, 0.0), random_mask(rng, gc.width, gc.height, 4, 0.0)},
        {std::vector<uint8_t>(npx, 0), std::vector<uint8_t>(npx, 255)},
        {random_mask(rng, gc.width, gc.height, 2, 0.0), random_mask(rng, gc.width, gc.height, 5, 0.0)},
        {std::vector<uint8_t>(npx, 255), std::vector<uint8_t>(npx, 255)},
        {random_mask(rng, gc.width, gc.height, 6, 0.02), random_mask(rng, gc.width, gc.height, 3, 0.3)},
        {random_mask(rng, gc.width, gc.height, 1, 0.0), random_mask(rng, gc.width, gc.height, 1, 0.0)},
    };
    for (const auto& [m0, m1] : masks) {
      std::vector<uint8_t> bits(vc_carver_bitset_bytes(cv.get()), 0xCD);
      vc_carve_stats st;
      ASSERT_EQ(vc_carver_run(cv.get(), m0.data(), m1.data(), bits.data(), &st), 0);
      PixelSat s0(m0, gc.width, gc.height), s1(m1, gc.width, gc.height);
      std::vector<uint8_t> want((nvox + 7) / 8, 0);
      uint64_t pop = 0, exact_missing = 0;
      for (uint64_t v = 0; v < nvox; v++) {
        bool on = seen[v] && s0.any(rects[v][0].x0, rects[v][0].y0, rects[v][0].x1, rects[v][0].y1) &&
                  s1.any(rects[v][1].x0, rects[v][1].y0, rects[v][1].x1, rects[v][1].y1);
        if (on) want[v / 8] |= static_cast<uint8_t>(1u << (v % 8));
        pop += on;
        bool exact = ref[0][v].x1 >= 0 && ref[1][v].x1 >= 0 &&
                     s0.any(ref[0][v].x0, ref[0][v].y0, ref[0][v].x1, ref[0][v].y1) &&
                     s1.any(ref[1][v].x0, ref[1][v].y0, ref[1][v].x1, ref[1][v].y1);
        exact_missing += exact && !((bits[v / 8] >> (v % 8)) & 1);
      }
      expect_same_bits(bits, want, nvox);
      EXPECT_EQ(st.occupied, pop);
      EXPECT_EQ(exact_missing, 0u)
          << "voxels whose exact footprint touches both silhouettes were carved away";
    }
  }
}

// Cameras 3-4 m away from the grid: rectangles read under 1.7x the footprints' pixels. Grids that
// reach the cameras (voxels from a few pixels to most of the image) read up to about 3x.
INSTANTIATE_TEST_SUITE_P(
    Grids, FootprintVsReference,
    ::testing::Values(
        FootprintCase{{{64, 64, 64, {-1.0, -1.0, 0.0}, 2.0 / 64}, 320, 240}, 1.7},
        FootprintCase{{{37, 29, 45, {-1.3, -1.1, -0.2}, 0.061}, 320, 240}, 1.7},  // odd sizes
        FootprintCase{{{16, 16, 16, {-0.4, -0.4, 0.5}, 0.05}, 203, 157}, 1.7},    // odd image
        FootprintCase{{{60, 60, 20, {-3.0, -3.0, 0.0}, 0.1}, 320, 240}, 3.5},     // around the cameras
        FootprintCase{{{1, 1, 1, {0.0, 0.0, 1.0}, 0.1}, 64, 48}, 1.7},
        FootprintCase{{{24, 24, 24, {-2.0, -2.0, -0.5}, 0.2}, 160, 120}, 3.5},  // big footprints
        FootprintCase{{{100, 3, 70, {-1.0, -0.1, 0.3}, 0.02}, 320, 240}, 1.7}),
    [](const auto& p) {
      const auto& g = p.param.gc.grid;
      return std::to_string(g.nx) + "x" + std::to_string(g.ny) + "x" + std::to_string(g.nz) + "_" +
             std::to_string(p.param.gc.width);
    });

// Masks rendered exactly from a dense point cloud (spheres and boxes): a pixel is foreground when a
// point projects into its square. Every voxel that holds a point seen by both cameras must be kept;
// the centre rule, on the same masks, loses some of them.
TEST(Footprint, KeepsEveryVoxelThatHoldsTheBody) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(0, 1);
  for (int rep = 0; rep < 3; rep++) {
    const int w = 320, h = 240;
    Rig rig = random_rig(rng, w, h);
    vc_voxel_grid g{48, 48, 64, {-0.75, -0.75, 0.0}, 0.03125};
    // The body: a few spheres and boxes near the grid's centre, sampled densely (volume and surface).
    std::vector<cv::Point3d> pts;
    for (int s = 0; s < 6; s++) {
      cv::Point3d c{0.5 * (u(rng) - 0.5), 0.5 * (u(rng) - 0.5),
                    0.4 + 1.2 * u(rng)};  // braced: drawn in order
      double r = 0.03 + 0.15 * u(rng);
      bool box = s % 2 == 1;
      for (int n = 0; n < 60000; n++) {
        cv::Point3d d{2 * u(rng) - 1, 2 * u(rng) - 1, 2 * u(rng) - 1};
        if (!box && d.dot(d) > 1) continue;
        pts.push_back(c + r * d);
      }
    }
    std::vector<uint8_t> mask[2];
    std::vector<bool> in_view(pts.size(), true);
    for (int c = 0; c < 2; c++) {
      mask[c].assign(static_cast<size_t>(w) * h, 0);
      const vc_camera& cam = rig.cam[c];
      cv::Matx33d R(cam.R_cam_from_world), K(cam.K);
      cv::Vec3d rvec, tvec(cam.t_cam_from_world[0], cam.t_cam_from_world[1], cam.t_cam_from_world[2]);
      cv::Rodrigues(R, rvec);
      std::vector<double> dist(cam.dist, cam.dist + 5);
      std::vector<cv::Point2d> uv;
      cv::projectPoints(pts, rvec, tvec, K, dist, uv);
      for (size_t n = 0; n < pts.size(); n++) {
        double x = std::floor(uv[n].x + 0.5), y = std::floor(uv[n].y + 0.5);
        if (x < 0 || y < 0 || x >= w || y >= h) {
          in_view[n] = false;
          continue;
        }
        mask[c][static_cast<size_t>(y) * w + static_cast<size_t>(x)] = 255;
      }
    }
    CarverPtr fp = new_carver(g, rig.cam[0], rig.cam[1], VC_CARVE_FOOTPRINT);
    CarverPtr ce = new_carver(g, rig.cam[0], rig.cam[1], VC_CARVE_CENTRE);
    ASSERT_NE(fp, nullptr);
    ASSERT_NE(ce, nullptr);
    std::vector<uint8_t> bits(vc_carver_bitset_bytes(fp.get())), centre_bits(bits.size());
    ASSERT_EQ(vc_carver_run(fp.get(), mask[0].data(), mask[1].data(), bits.data(), nullptr), 0);
    ASSERT_EQ(vc_carver_run(ce.get(), mask[0].data(), mask[1].data(), centre_bits.data(), nullptr), 0);
    const uint64_t nvox = vc_carver_voxels(fp.get());
    std::vector<uint8_t> body(nvox, 0);
    for (size_t n = 0; n < pts.size(); n++) {
      if (!in_view[n]) continue;
      double fi = (pts[n].x - g.min_m[0]) / g.voxel_m, fj = (pts[n].y - g.min_m[1]) / g.voxel_m,
             fk = (pts[n].z - g.min_m[2]) / g.voxel_m;
      if (fi < 0 || fj < 0 || fk < 0 || fi >= g.nx || fj >= g.ny || fk >= g.nz) continue;
      body[static_cast<size_t>(fi) + g.nx * (static_cast<size_t>(fj) + g.ny * static_cast<size_t>(fk))] = 1;
    }
    uint64_t held = 0, missing = 0, centre_missing = 0;
    for (uint64_t v = 0; v < nvox; v++) {
      bool on = (bits[v / 8] >> (v % 8)) & 1;
      if (!body[v]) continue;
      held++;
      missing += !on;
      centre_missing += !((centre_bits[v / 8] >> (v % 8)) & 1);
    }
    EXPECT_GT(held, 1000u);
    EXPECT_EQ(missing, 0u) << "of " << held << " voxels holding the body";
    EXPECT_GT(centre_missing, 0u) << "the centre rule was expected to lose some outline voxels";
    RecordProperty("centre_missing_rep" + std::to_string(rep), std::to_string(centre_missing));
    std::printf("footprint rule: %llu voxels hold the body, all kept; the centre rule misses %llu\n",
                static_cast<unsigned long long>(held), static_cast<unsigned long long>(centre_missing));
  }
}

// Voxels at the image border and behind a camera (no distortion: the rectangles are exact).
TEST(Footprint, ImageBorderAndBehindTheCamera) {
  const int w = 64, h = 48;
  const double none[5] = {0, 0, 0, 0, 0};
  double eye[3] = {0, -2, 1}, target[3] = {0, 0, 1};
  vc_camera cam = look_at(eye, target, w, h, 40, none);
  // A row of voxels along x at y = 0 (2 m in front), z about 1: the ends leave the image sideways.
  vc_voxel_grid g{40, 1, 1, {-2.0, -0.05, 0.95}, 0.1};
  CarverPtr cv = new_carver(g, cam, cam, VC_CARVE_FOOTPRINT);
  ASSERT_NE(cv, nullptr);
  std::vector<Rect> ref = reference_footprints(g, cam);
  int straddling = -1, outside = -1;
  for (uint32_t i = 0; i < g.nx; i++) {
    uint32_t r[2][4];
    int got = vc_carver_footprint(cv.get(), i, 0, 0, r);
    if (ref[i].x1 < 0) {
      EXPECT_EQ(got, 0) << "voxel " << i << " lies wholly outside the image";
      if (outside < 0) outside = static_cast<int>(i);
      continue;
    }
    ASSERT_EQ(got, 1) << i;
    EXPECT_TRUE(contains(r[0], ref[i])) << i;
    if (r[0][0] == 0 && straddling < 0) straddling = static_cast<int>(i);
  }
  ASSERT_GE(straddling, 0) << "no voxel reaches the left border";
  ASSERT_GE(outside, 0) << "no voxel lies wholly outside";
  // A voxel partly outside the image is kept when the part inside touches the silhouette: foreground
  // only in column 0.
  std::vector<uint8_t> m(static_cast<size_t>(w) * h, 0);
  for (int y = 0; y < h; y++) m[static_cast<size_t>(y) * w] = 255;
  std::vector<uint8_t> bits(vc_carver_bitset_bytes(cv.get()));
  ASSERT_EQ(vc_carver_run(cv.get(), m.data(), m.data(), bits.data(), nullptr), 0);
  EXPECT_TRUE((bits[straddling / 8] >> (straddling % 8)) & 1);
  EXPECT_FALSE((bits[outside / 8] >> (outside % 8)) & 1);

  // Behind: a grid around the camera's eye; voxels with a corner behind it are empty even when the
  // whole image is foreground, and so are those behind it altogether.
  vc_voxel_grid around{8, 8, 8, {-0.4, -2.4, 0.6}, 0.1};  // the eye (0, -2, 1) is a voxel corner
  CarverPtr cv2 = new_carver(around, cam, cam, VC_CARVE_FOOTPRINT);
  ASSERT_NE(cv2, nullptr);
  std::vector<uint8_t> full(static_cast<size_t>(w) * h, 255), bits2(vc_carver_bitset_bytes(cv2.get()));
  ASSERT_EQ(vc_carver_run(cv2.get(), full.data(), full.data(), bits2.data(), nullptr), 0);
  std::vector<Rect> ref2 = reference_footprints(around, cam);
  uint64_t n = 0, kept = 0;
  for (uint32_t k = 0; k < around.nz; k++)
    for (uint32_t j = 0; j < around.ny; j++)
      for (uint32_t i = 0; i < around.nx; i++, n++) {
        bool on = (bits2[n / 8] >> (n % 8)) & 1;
        kept += on;
        if (j <= 4) EXPECT_FALSE(on) << "voxel " << i << "," << j << "," << k << " reaches behind the camera";
        if (ref2[n].x1 >= 0) EXPECT_TRUE(on) << i << "," << j << "," << k;
      }
  EXPECT_GT(kept, 0u);
}

TEST(Footprint, CentreRuleHasOneClassAndNoScratch) {
  std::mt19937 rng(5);
  Rig rig = random_rig(rng, 320, 240);
  vc_voxel_grid g{32, 32, 32, {-1.0, -1.0, 0.0}, 2.0 / 32};
  CarverPtr ce = new_carver(g, rig.cam[0], rig.cam[1], VC_CARVE_CENTRE);
  CarverPtr fp = new_carver(g, rig.cam[0], rig.cam[1], VC_CARVE_FOOTPRINT);
  ASSERT_NE(ce, nullptr);
  ASSERT_NE(fp, nullptr);
  EXPECT_EQ(vc_carver_classes(ce.get(), 0), 1);
  EXPECT_EQ(vc_carver_classes(ce.get(), 1), 1);
  EXPECT_EQ(vc_carver_scratch_bytes(ce.get()), 0u);
  EXPECT_EQ(vc_carver_classes(fp.get(), 2), 0);
  // 6 cm voxels at 3-4 m through f = 288 px project to about 4-6 pixels: never 1x1.
  size_t per_mask = 320 * 240 + 9 * 40 * 30;  // the dilated mask and its tile lists (8x8 tiles)
  EXPECT_EQ(vc_carver_scratch_bytes(fp.get()),
            per_mask * static_cast<size_t>(vc_carver_classes(fp.get(), 0) + vc_carver_classes(fp.get(), 1)));
  EXPECT_GT(vc_carver_memory_bytes(fp.get()), vc_carver_scratch_bytes(fp.get()));
  uint32_t r[2][4];
  EXPECT_EQ(vc_carver_footprint(fp.get(), 32, 0, 0, r), 0);  // out of the grid
  EXPECT_EQ(vc_carver_footprint(nullptr, 0, 0, 0, r), 0);
  ASSERT_EQ(vc_carver_footprint(ce.get(), 16, 16, 16, r), 1);
  double p[3] = {g.min_m[0] + 16.5 * g.voxel_m, g.min_m[1] + 16.5 * g.voxel_m, g.min_m[2] + 16.5 * g.voxel_m};
  for (int c = 0; c < 2; c++) {
    int x, y;
    ASSERT_EQ(vc_camera_project(&rig.cam[c], p, &x, &y), 1);
    EXPECT_EQ(r[c][0], static_cast<uint32_t>(x));
    EXPECT_EQ(r[c][2], static_cast<uint32_t>(x));
    EXPECT_EQ(r[c][1], static_cast<uint32_t>(y));
    EXPECT_EQ(r[c][3], static_cast<uint32_t>(y));
  }
}

// The subpixel rule's pixels of every voxel in one camera: those whose squares overlap the unit square
// centred on the centre's cv::projectPoints projection (x in (u - 1, u + 1)), clipped; unseen (x1 < x0)
// behind the camera or off the image. `near_edge[n]`: u or v lies within 1e-6 px of an integer, where
// the carver's own float arithmetic may round the other way (skipped by the exact checks).
std::vector<Rect> reference_subpixel(const vc_voxel_grid& g, const vc_camera& cam,
                                     std::vector<bool>* near_edge) {
  const CentreProjections cp = project_centres(g, cam);
  const std::vector<cv::Point2d>& uv = cp.uv;
  std::vector<Rect> out(uv.size(), Rect{0, 0, -1, -1});
  near_edge->assign(uv.size(), false);
  for (size_t n = 0; n < uv.size(); n++) {
    if (!cp.front[n]) continue;
    const double u = uv[n].x, v = uv[n].y;
    (*near_edge)[n] = std::abs(u - std::round(u)) < 1e-6 || std::abs(v - std::round(v)) < 1e-6;
    double x0 = std::max(std::floor(u - 1) + 1, 0.0), x1 = std::min(std::ceil(u + 1) - 1, cam.width - 1.0);
    double y0 = std::max(std::floor(v - 1) + 1, 0.0), y1 = std::min(std::ceil(v + 1) - 1, cam.height - 1.0);
    if (x0 <= x1 && y0 <= y1)
      out[n] = {static_cast<int>(x0), static_cast<int>(y0), static_cast<int>(x1), static_cast<int>(y1)};
  }
  return out;
}

// The carver reads the exact subpixel pixels of each voxel, widened to at most 2x2 (its class), and
// carves "some foreground pixel in each rectangle" exactly; its hull holds the centre rule's.
TEST(Subpixel, ReadsTheCentresPixelsAndCarvesThemExactly) {
  std::mt19937 rng(23);
  const vc_voxel_grid grids[] = {{48, 40, 52, {-1.0, -0.9, 0.0}, 0.04},
                                 {30, 30, 30, {-3.0, -3.0, 0.0}, 0.2},  // voxels of many pixels, near cameras
                                 {64, 64, 64, {-1.0, -1.0, 0.0}, 2.0 / 64}};
  for (const vc_voxel_grid& g : grids) {
    Rig rig = random_rig(rng, 320, 240);
    CarverPtr sp = new_carver(g, rig.cam[0], rig.cam[1], VC_CARVE_SUBPIXEL);
    CarverPtr ce = new_carver(g, rig.cam[0], rig.cam[1], VC_CARVE_CENTRE);
    ASSERT_NE(sp, nullptr);
    ASSERT_NE(ce, nullptr);
    std::vector<bool> edge[2];
    std::vector<Rect> ref[2] = {reference_subpixel(g, rig.cam[0], &edge[0]),
                                reference_subpixel(g, rig.cam[1], &edge[1])};
    const uint64_t nvox = vc_carver_voxels(sp.get());
    std::vector<std::array<Rect, 2>> rects(nvox);
    std::vector<bool> seen(nvox, false);
    uint64_t n = 0, checked = 0;
    for (uint32_t k = 0; k < g.nz; k++)
      for (uint32_t j = 0; j < g.ny; j++)
        for (uint32_t i = 0; i < g.nx; i++, n++) {
          uint32_t r[2][4];
          seen[n] = vc_carver_footprint(sp.get(), i, j, k, r) == 1;
          if (seen[n])
            for (int c = 0; c < 2; c++)
              rects[n][c] = {static_cast<int>(r[c][0]), static_cast<int>(r[c][1]), static_cast<int>(r[c][2]),
                             static_cast<int>(r[c][3])};
          if (edge[0][n] || edge[1][n]) continue;
          const bool both = ref[0][n].x1 >= 0 && ref[1][n].x1 >= 0;
          ASSERT_EQ(seen[n], both) << "voxel " << n;
          if (!both) continue;
          checked++;
          for (int c = 0; c < 2; c++) {
            ASSERT_TRUE(contains(r[c], ref[c][n])) << "voxel " << n << " camera " << c;
            EXPECT_EQ(static_cast<int>(r[c][0]), ref[c][n].x0) << "anchored at the exact pixels";
            EXPECT_EQ(static_cast<int>(r[c][1]), ref[c][n].y0);
            EXPECT_LE(r[c][2] - r[c][0], 1u) << "at most 2 pixels wide";
            EXPECT_LE(r[c][3] - r[c][1], 1u) << "at most 2 pixels high";
          }
        }
    EXPECT_GT(checked, 1000u);
    for (int c = 0; c < 2; c++) EXPECT_LE(vc_carver_classes(sp.get(), c), 4);
    const size_t npx = 320 * 240;
    const std::vector<uint8_t> masks[][2] = {
        {random_mask(rng, 320, 240, 4, 0.0), random_mask(rng, 320, 240, 4, 0.0)},
        {random_mask(rng, 320, 240, 6, 0.05), random_mask(rng, 320, 240, 3, 0.3)},
        {std::vector<uint8_t>(npx, 255), std::vector<uint8_t>(npx, 0)},
    };
    for (const auto& m : masks) {
      std::vector<uint8_t> bits(vc_carver_bitset_bytes(sp.get()), 0xCD), cbits(bits.size());
      ASSERT_EQ(vc_carver_run(sp.get(), m[0].data(), m[1].data(), bits.data(), nullptr), 0);
      ASSERT_EQ(vc_carver_run(ce.get(), m[0].data(), m[1].data(), cbits.data(), nullptr), 0);
      PixelSat s0(m[0], 320, 240), s1(m[1], 320, 240);
      std::vector<uint8_t> want(bits.size(), 0);
      for (uint64_t v = 0; v < nvox; v++)
        if (seen[v] && s0.any(rects[v][0].x0, rects[v][0].y0, rects[v][0].x1, rects[v][0].y1) &&
            s1.any(rects[v][1].x0, rects[v][1].y0, rects[v][1].x1, rects[v][1].y1))
          want[v / 8] |= static_cast<uint8_t>(1u << (v % 8));
      expect_same_bits(bits, want, nvox);
      for (size_t b = 0; b < bits.size(); b++) EXPECT_EQ(cbits[b] & ~bits[b], 0) << "byte " << b;
    }
  }
}

// Masks ray-cast from spheres (a pixel is foreground when the ray through its centre meets a sphere,
// as a camera's silhouette is). Every voxel whose centre lies inside a sphere is kept by the subpixel
// rule; the centre rule, on the same masks, loses some at the silhouettes' edges.
TEST(Subpixel, KeepsEveryVoxelWhoseCentreIsInTheBody) {
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> u(0, 1);
  const vc_voxel_grid g{64, 64, 64, {-0.8, -0.8, 0.4}, 1.6 / 64};
  const int w = 320, h = 240;
  uint64_t centre_missing_total = 0;
  for (int rep = 0; rep < 3; rep++) {
    Rig rig = random_rig(rng, w, h);
    std::vector<cv::Vec4d> spheres;  // centre, radius: limbs of 3-12 cm, like hands to a torso
    spheres.reserve(8);
    for (int s = 0; s < 8; s++)
      spheres.push_back(cv::Vec4d{0.9 * (u(rng) - 0.5), 0.9 * (u(rng) - 0.5), 0.9 + 0.8 * (u(rng) - 0.5),
                                  0.03 + 0.09 * u(rng)});  // braced: drawn in order
    std::vector<uint8_t> mask[2];
    for (int c = 0; c < 2; c++) {
      const vc_camera& cam = rig.cam[c];
      cv::Matx33d R(cam.R_cam_from_world), K(cam.K);
      cv::Vec3d t(cam.t_cam_from_world[0], cam.t_cam_from_world[1], cam.t_cam_from_world[2]);
      std::vector<cv::Point2d> px, norm;
      px.reserve(static_cast<size_t>(w) * h);
      for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) px.emplace_back(x, y);
      cv::undistortPoints(px, norm, K, std::vector<double>(cam.dist, cam.dist + 5));
      const cv::Vec3d eye = -(R.t() * t);
      mask[c].assign(px.size(), 0);
      for (size_t n = 0; n < px.size(); n++) {
        cv::Vec3d d = R.t() * cv::Vec3d(norm[n].x, norm[n].y, 1.0);
        d /= cv::norm(d);
        for (const cv::Vec4d& s : spheres) {
          cv::Vec3d oc = eye - cv::Vec3d(s[0], s[1], s[2]);
          double b = oc.dot(d), q = oc.dot(oc) - s[3] * s[3];
          if (b * b - q >= 0 && -b + std::sqrt(b * b - q) > 0) {
            mask[c][n] = 255;
            break;
          }
        }
      }
    }
    CarverPtr sp = new_carver(g, rig.cam[0], rig.cam[1], VC_CARVE_SUBPIXEL);
    CarverPtr ce = new_carver(g, rig.cam[0], rig.cam[1], VC_CARVE_CENTRE);
    ASSERT_NE(sp, nullptr);
    ASSERT_NE(ce, nullptr);
    std::vector<uint8_t> bits(vc_carver_bitset_bytes(sp.get())), cbits(bits.size());
    ASSERT_EQ(vc_carver_run(sp.get(), mask[0].data(), mask[1].data(), bits.data(), nullptr), 0);
    ASSERT_EQ(vc_carver_run(ce.get(), mask[0].data(), mask[1].data(), cbits.data(), nullptr), 0);
    uint64_t inside = 0, missing = 0, centre_missing = 0, n = 0;
    for (uint32_t k = 0; k < g.nz; k++)
      for (uint32_t j = 0; j < g.ny; j++)
        for (uint32_t i = 0; i < g.nx; i++, n++) {
          cv::Vec3d p(g.min_m[0] + (i + 0.5) * g.voxel_m, g.min_m[1] + (j + 0.5) * g.voxel_m,
                      g.min_m[2] + (k + 0.5) * g.voxel_m);
          bool in = false;
          for (const cv::Vec4d& s : spheres) in = in || cv::norm(p - cv::Vec3d(s[0], s[1], s[2])) < s[3];
          uint32_t r[2][4];
          if (!in || vc_carver_footprint(ce.get(), i, j, k, r) != 1) continue;  // seen by both cameras
          inside++;
          missing += !((bits[n / 8] >> (n % 8)) & 1);
          centre_missing += !((cbits[n / 8] >> (n % 8)) & 1);
        }
    EXPECT_GT(inside, 500u);
    EXPECT_EQ(missing, 0u) << "of " << inside << " voxels whose centre is in a sphere";
    centre_missing_total += centre_missing;
    std::printf("subpixel rule: %llu voxel centres in the body, all kept; the centre rule misses %llu\n",
                static_cast<unsigned long long>(inside), static_cast<unsigned long long>(centre_missing));
  }
  EXPECT_GT(centre_missing_total, 0u) << "the centre rule was expected to lose some edge voxels";
}

// Leaves close to a camera span more pixel rows than 2-byte linear offsets reach (dv * W + du >
// 65535: over 102 rows at 640 wide) and keep full pixel indices; the others keep the offsets. Both
// kinds side by side in one grid carve exactly as each voxel's own pixels say, under every rule.
TEST(Carver, LeavesNearACameraCarveExactlyWithFullPixelIndices) {
  std::mt19937 rng(57);
  const int w = 640, h = 480;
  const double dist[5] = {-0.2, 0.05, 0, 0, 0};
  double eye0[3] = {2.2, 0.3, 1.2}, eye1[3] = {0.4, 3.5, 1.6}, target[3] = {0, 0, 0.9};
  const vc_camera cam0 = look_at(eye0, target, w, h, 0.9 * w, dist),
                  cam1 = look_at(eye1, target, w, h, 0.9 * w, dist);
  const vc_voxel_grid g{24, 24, 24, {-0.9, -0.9, 0.0}, 0.075};  // leaves of 0.3 m, 1.3-3.4 m from cam0
  const size_t npx = static_cast<size_t>(w) * h;
  const std::vector<uint8_t> masks[][2] = {
      {random_mask(rng, w, h, 4, 0.0), random_mask(rng, w, h, 4, 0.0)},
      {random_mask(rng, w, h, 6, 0.05), random_mask(rng, w, h, 3, 0.3)},
      {std::vector<uint8_t>(npx, 255), random_mask(rng, w, h, 5, 0.01)},
  };
  for (vc_carve_rule rule : {VC_CARVE_CENTRE, VC_CARVE_SUBPIXEL, VC_CARVE_FOOTPRINT}) {
    SCOPED_TRACE(::testing::Message() << "rule " << static_cast<int>(rule));
    CarverPtr cv = new_carver(g, cam0, cam1, rule);
    ASSERT_NE(cv, nullptr);
    const uint64_t nvox = vc_carver_voxels(cv.get());
    std::vector<std::array<Rect, 2>> rects(nvox);
    std::vector<bool> seen(nvox, false);
    // Per leaf and camera, the span of its voxels' anchors as a linear pixel offset.
    const uint32_t lx = (g.nx + 3) / 4, ly = (g.ny + 3) / 4, lz = (g.nz + 3) / 4;
    std::vector<std::array<int, 8>> box(static_cast<size_t>(lx) * ly * lz,
                                        {w, h, -1, -1, w, h, -1, -1});  // x0 y0 x1 y1 per camera
    uint64_t n = 0;
    for (uint32_t k = 0; k < g.nz; k++)
      for (uint32_t j = 0; j < g.ny; j++)
        for (uint32_t i = 0; i < g.nx; i++, n++) {
          uint32_t r[2][4];
          seen[n] = vc_carver_footprint(cv.get(), i, j, k, r) == 1;
          if (!seen[n]) continue;
          auto& b = box[i / 4 + lx * (j / 4 + ly * (k / 4))];
          for (int c = 0; c < 2; c++) {
            rects[n][c] = {static_cast<int>(r[c][0]), static_cast<int>(r[c][1]), static_cast<int>(r[c][2]),
                           static_cast<int>(r[c][3])};
            b[4 * c] = std::min(b[4 * c], rects[n][c].x0);
            b[4 * c + 1] = std::min(b[4 * c + 1], rects[n][c].y0);
            b[4 * c + 2] = std::max(b[4 * c + 2], rects[n][c].x0);
            b[4 * c + 3] = std::max(b[4 * c + 3], rects[n][c].y0);
          }
        }
    int wide = 0, narrow = 0;
    for (const auto& b : box) {
      if (b[2] < 0) continue;
      const int span = std::max((b[3] - b[1]) * w + b[2] - b[0], (b[7] - b[5]) * w + b[6] - b[4]);
      (span > 65535 ? wide : narrow)++;
    }
    EXPECT_GT(wide, 0) << "leaves that need full pixel indices";
    EXPECT_GT(narrow, 0) << "leaves with 2-byte offsets";
    const std::vector<int> pix[2] = {reference_pixels(g, cam0), reference_pixels(g, cam1)};
    for (const auto& m : masks) {
      std::vector<uint8_t> bits(vc_carver_bitset_bytes(cv.get()), 0xCD);
      ASSERT_EQ(vc_carver_run(cv.get(), m[0].data(), m[1].data(), bits.data(), nullptr), 0);
      PixelSat s0(m[0], w, h), s1(m[1], w, h);
      std::vector<uint8_t> want(bits.size(), 0);
      for (uint64_t v = 0; v < nvox; v++)
        if (seen[v] && s0.any(rects[v][0].x0, rects[v][0].y0, rects[v][0].x1, rects[v][0].y1) &&
            s1.any(rects[v][1].x0, rects[v][1].y0, rects[v][1].x1, rects[v][1].y1))
          want[v / 8] |= static_cast<uint8_t>(1u << (v % 8));
      expect_same_bits(bits, want, nvox);
      if (rule == VC_CARVE_CENTRE) expect_same_bits(bits, reference_carve(pix[0], pix[1], m[0], m[1]), nvox);
    }
  }
}

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
