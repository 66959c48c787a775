// voxcap carve's library on a scene whose answer is known: a sphere of radius 0.3 m at (0, 0, 1) seen by
// four cameras round it. Its exact silhouettes (a pixel is foreground when its ray passes within the
// radius of the centre) are drawn as masks, as a bright disc on black for --threshold, and over a
// textured background for the edge's subtraction; each carve must hold every voxel whose centre is inside
// the sphere and be a visual hull of four views (not much more than the sphere). The output files are
// parsed back: the .npy header and data (numpy is not installed here), the PLY's vertex count.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "voxcap/calib/carve.hpp"
#include "voxcap/rig/calibration.hpp"

namespace vc::calib {
namespace {

namespace fs = std::filesystem;

const cv::Vec3d kCentre(0, 0, 1);
constexpr double kRadius = 0.3;

rig::Calibration ring(int n) {
  rig::Calibration cal;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n + 0.3;
    cal.cameras.push_back(rig::Camera::look_at("cam" + std::to_string(i), 320, 240, 300,
                                               cv::Vec3d(3 * std::cos(a), 3 * std::sin(a), 1.6), kCentre));
  }
  return cal;
}

cv::Mat true_mask(const rig::Camera& c) {
  cv::Mat m(c.height, c.width, CV_8U, cv::Scalar(0));
  const cv::Vec3d C = c.center_world();
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      const cv::Vec3d d = c.ray_world(cv::Point2d(x, y));
      const cv::Vec3d v = kCentre - C;
      const double along = v.dot(d);
      if (cv::norm(v - along * d) < kRadius) m.at<std::uint8_t>(y, x) = 255;
    }
  return m;
}

struct Scene {
  fs::path dir;
  rig::Calibration cal = ring(4);
  rig::VoxelGrid grid;
  Scene() {
    dir = fs::temp_directory_path() / ("vc_carve_" + std::to_string(::getpid()));
    fs::create_directories(dir / "images");
    fs::create_directories(dir / "masks");
    fs::create_directories(dir / "bg");
    fs::create_directories(dir / "sub");
    cv::RNG rng(7);
    for (const rig::Camera& c : cal.cameras) {
      const cv::Mat m = true_mask(c);
      cv::imwrite((dir / "masks" / (c.name + ".png")).string(), m);
      cv::Mat bright;
      cv::cvtColor(m, bright, cv::COLOR_GRAY2BGR);
      cv::imwrite((dir / "images" / (c.name + ".png")).string(), bright);
      // A textured background, and the sphere in a saturated colour over it (two frames: folders).
      cv::Mat bg(c.height, c.width, CV_8UC3);
      rng.fill(bg, cv::RNG::UNIFORM, cv::Scalar(60, 80, 70), cv::Scalar(120, 140, 130));
      fs::create_directories(dir / "bg" / c.name);
      cv::imwrite((dir / "bg" / c.name / "0.png").string(), bg);
      cv::Mat bg2 = bg.clone();
      bg2 += cv::Scalar(1, 1, 1);
      cv::imwrite((dir / "bg" / c.name / "1.png").string(), bg2);
      cv::Mat fg = bg.clone();
      fg.setTo(cv::Scalar(20, 30, 230), m);
      fs::create_directories(dir / "sub" / c.name);
      cv::imwrite((dir / "sub" / c.name / "f000.png").string(), fg);
    }
    grid.min_m = cv::Vec3d(-0.5, -0.5, 0.5);
    grid.voxel_m = 1.0 / 64;
    grid.nx = grid.ny = grid.nz = 64;
  }
  ~Scene() { fs::remove_all(dir); }
};

// Every voxel whose centre is inside the sphere is kept; the hull is at most 1.6x the sphere's volume.
void expect_sphere_hull(const Hull& h) {
  const rig::VoxelGrid& g = h.grid;
  std::size_t inside = 0, kept_inside = 0;
  for (int k = 0; k < g.nz; ++k)
    for (int j = 0; j < g.ny; ++j)
      for (int i = 0; i < g.nx; ++i) {
        if (cv::norm(g.center(i, j, k) - kCentre) >= kRadius - 0.5 * g.voxel_m) continue;
        ++inside;
        kept_inside += rig::hull_bit(h.bits.data(), g.index(i, j, k));
      }
  EXPECT_EQ(kept_inside, inside);
  const double sphere_voxels = 4.0 / 3.0 * M_PI * std::pow(kRadius / g.voxel_m, 3);
  EXPECT_GT(static_cast<double>(h.occupied), 0.95 * sphere_voxels);
  EXPECT_LT(static_cast<double>(h.occupied), 1.6 * sphere_voxels);
}

TEST(CalibCarve, SilhouettesThresholdAndSubtractionCarveTheSphere) {
  Scene s;
  CarveOptions o;
  o.images = (s.dir / "images").string();
  o.grid = s.grid;
  o.source = MaskSource::Silhouettes;
  o.silhouettes = (s.dir / "masks").string();
  CarveSession sil(s.cal, o);
  ASSERT_EQ(sil.frames(), 1);
  ASSERT_EQ(sil.cameras().size(), 4u);
  const Hull h = sil.carve(0);
  expect_sphere_hull(h);

  o.source = MaskSource::Threshold;
  o.threshold = 0.5;
  CarveSession thr(s.cal, o);
  const Hull t = thr.carve(0);
  EXPECT_EQ(t.bits, h.bits) << "the bright disc thresholded is the mask";

  o.source = MaskSource::Background;
  o.background = (s.dir / "bg").string();
  o.images = (s.dir / "sub").string();
  CarveSession sub(s.cal, o);
  std::vector<cv::Mat> masks;
  const Hull b = sub.carve(0, &masks);
  ASSERT_EQ(masks.size(), 4u);
  for (std::size_t m = 0; m < masks.size(); ++m) {
    const cv::Mat truth = true_mask(s.cal.cameras[m]);
    cv::Mat diff;
    cv::compare(masks[m], truth, diff, cv::CMP_NE);
    EXPECT_LT(cv::countNonZero(diff), 0.002 * truth.total()) << "camera " << m;
  }
  expect_sphere_hull(b);
}

TEST(CalibCarve, OutputsParseBack) {
  Scene s;
  CarveOptions o;
  o.images = (s.dir / "images").string();
  o.grid = s.grid;
  o.source = MaskSource::Silhouettes;
  o.silhouettes = (s.dir / "masks").string();
  CarveSession sil(s.cal, o);
  const Hull h = sil.carve(0);
  const std::string npy = (s.dir / "hull.npy").string(), ply = (s.dir / "hull.ply").string(),
                    png = (s.dir / "hull.png").string();
  write_npy(npy, h);
  write_ply(ply, h);
  write_preview(png, h);

  std::ifstream in(npy, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 10u);
  EXPECT_EQ(bytes.substr(0, 6), "\x93NUMPY");
  EXPECT_EQ(bytes[6], 1);
  EXPECT_EQ(bytes[7], 0);
  const std::size_t hlen = static_cast<unsigned char>(bytes[8]) | (static_cast<unsigned char>(bytes[9]) << 8);
  EXPECT_EQ((10 + hlen) % 64, 0u);
  const std::string header = bytes.substr(10, hlen);
  EXPECT_NE(header.find("'descr': '|b1'"), std::string::npos) << header;
  EXPECT_NE(header.find("'fortran_order': False"), std::string::npos) << header;
  EXPECT_NE(header.find("'shape': (262144,)"), std::string::npos) << header;
  EXPECT_EQ(header.back(), '\n');
  ASSERT_EQ(bytes.size(), 10 + hlen + h.grid.count());
  for (std::size_t i = 0; i < h.grid.count(); ++i)
    ASSERT_EQ(bytes[10 + hlen + i], rig::hull_bit(h.bits.data(), i) ? 1 : 0) << "voxel " << i;

  std::ifstream p(ply, std::ios::binary);
  std::string line;
  std::size_t vertices = 0;
  while (std::getline(p, line) && line != "end_header")
    if (line.rfind("element vertex ", 0) == 0) vertices = std::stoul(line.substr(15));
  EXPECT_EQ(vertices, h.occupied);
  const auto data_start = p.tellg();
  p.seekg(0, std::ios::end);
  EXPECT_EQ(static_cast<std::size_t>(p.tellg() - data_start), 12 * h.occupied);

  const cv::Mat preview = cv::imread(png, cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(preview.empty());
  EXPECT_GE(preview.rows, 256);
  EXPECT_GT(cv::countNonZero(preview == 255), 0);
}

TEST(CalibCarve, AutoGridHoldsTheRegionAllSee) {
  Scene s;
  const rig::VoxelGrid g = auto_grid(s.cal, {0, 1, 2, 3}, 64);
  EXPECT_EQ(std::max({g.nx, g.ny, g.nz}), 64);
  // The sphere is seen by all four: it lies inside the grid, and the grid's corners are not seen by all.
  for (int a = 0; a < 3; ++a) {
    EXPECT_LT(g.min_m[a], kCentre[a] - kRadius);
    EXPECT_GT(g.max_m()[a], kCentre[a] + kRadius);
  }
  CarveOptions o;
  o.images = (s.dir / "images").string();
  o.auto_n = 64;
  o.source = MaskSource::Silhouettes;
  o.silhouettes = (s.dir / "masks").string();
  CarveSession sil(s.cal, o);
  EXPECT_EQ(sil.grid().nx, g.nx);
  const Hull h = sil.carve(0);
  int lo[3], hi[3];
  ASSERT_TRUE(h.bounds(lo, hi));
  for (int a = 0; a < 3; ++a) {
    EXPECT_GT(lo[a], 0) << "axis " << a;  // the sphere does not touch the region's faces
    EXPECT_LT(hi[a], (a == 0 ? g.nx : a == 1 ? g.ny : g.nz) - 1) << "axis " << a;
  }
}

TEST(CalibCarve, MatchingAndBadInput) {
  Scene s;
  rig::Calibration cal = s.cal;
  cal.cameras.push_back(rig::Camera::look_at("nobody", 320, 240, 300, cv::Vec3d(0, 3, 3), kCentre));
  CarveOptions o;
  o.images = (s.dir / "images").string();
  o.grid = s.grid;
  o.source = MaskSource::Threshold;
  CarveSession ok(cal, o);
  EXPECT_EQ(ok.cameras().size(), 4u);
  ASSERT_EQ(ok.skipped().size(), 1u);
  EXPECT_EQ(ok.skipped()[0], "nobody");

  rig::Calibration wrong = s.cal;
  wrong.cameras[2].width = 321;
  CarveSession bad_size(wrong, o);
  try {
    bad_size.carve(0);
    FAIL() << "an image of another size was carved";
  } catch (const CarveError& e) {
    EXPECT_NE(std::string(e.what()).find("calibrated for 321x240"), std::string::npos) << e.what();
  }
  CarveOptions none = o;
  none.images = (s.dir / "masks" / "cam0.png").string();
  EXPECT_THROW(CarveSession(s.cal, none), CarveError);
  rig::Calibration one;
  one.cameras.push_back(s.cal.cameras[0]);
  EXPECT_THROW(CarveSession(one, o), CarveError);
  CarveOptions no_grid = o;
  no_grid.grid.reset();
  EXPECT_THROW(CarveSession(s.cal, no_grid), CarveError);
  CarveOptions bad = o;
  bad.threshold = 1.5;
  std::string why;
  EXPECT_FALSE(bad.valid(&why));
  EXPECT_NE(why.find("--threshold"), std::string::npos);
}

}  // namespace
}  // namespace vc::calib
