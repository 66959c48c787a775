// The renderer against its own ground truth: silhouettes are exactly the body pixels of the
// image, shadows are darker with the same hue, the 2D truth is the projection of the 3D truth
// with the written calibration, visibility follows occlusion, occupancy agrees with the point
// test and the images, noise and flicker have the configured statistics, and everything is
// deterministic.
#include "voxcap/sim/scene.hpp"

#include <filesystem>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace vc::sim {
namespace {

namespace fs = std::filesystem;

SceneOptions small(const std::string& motion, const std::string& appearance = "default") {
  SceneOptions o;
  o.motion.source = motion;
  o.appearance = appearance;
  o.rig.width = 160;
  o.rig.height = 120;
  o.noise_sigma = 0;
  return o;
}

// Pixels where any channel differs.
cv::Mat differs(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  cv::Mat m;
  cv::transform(d, m, cv::Matx13f(1, 1, 1));
  return m > 0;
}

TEST(SimScene, SilhouetteIsExactlyTheBodyPixelsOfTheNoiseFreeImage) {
  // The same scene in two appearances whose every colour differs: the pixels that change are
  // exactly the body's, and both truths must equal them.
  for (const char* motion : {"tpose", "walk", "arms-close", "squat"}) {
    const Scene a(small(motion, "default")), b(small(motion, "dark"));
    for (int frame : {0, 75, 140}) {
      for (int cam = 0; cam < a.camera_count(); ++cam) {
        SCOPED_TRACE(std::string(motion) + " frame " + std::to_string(frame) + " cam " + std::to_string(cam));
        cv::Mat ia, ib, sa, sb, sha;
        a.render_clean(frame, cam, ia, &sa, &sha);
        b.render_clean(frame, cam, ib, &sb);
        ASSERT_EQ(ia.type(), CV_8UC3);
        ASSERT_EQ(sa.type(), CV_8UC1);
        EXPECT_GT(cv::countNonZero(sa), 100);
        EXPECT_EQ(cv::countNonZero(differs(ia, ib) != sa), 0);
        EXPECT_EQ(cv::countNonZero(sa != sb), 0);
        // Outside body and shadow the image is the empty room, pixel for pixel.
        cv::Mat bg;
        a.render_background_clean(cam, bg);
        cv::Mat changed = differs(ia, bg);
        EXPECT_EQ(cv::countNonZero(changed & ~(sa | sha)), 0);
        // The noisy image has the same truth.
        cv::Mat noisy, sn;
        a.render(frame, cam, noisy, &sn);
        EXPECT_EQ(cv::countNonZero(sn != sa), 0);
      }
    }
  }
}

TEST(SimScene, FloorShadowExistsAndIsDarkerWithTheSameHue) {
  const Scene s(small("tpose"));
  int total = 0;
  for (int cam = 0; cam < s.camera_count(); ++cam) {
    cv::Mat img, sil, shadow, bg;
    s.render_clean(0, cam, img, &sil, &shadow);
    s.render_background_clean(cam, bg);
    EXPECT_EQ(cv::countNonZero(sil & shadow), 0);
    const int n = cv::countNonZero(shadow);
    if (cam < 2) {
      EXPECT_GT(n, 200) << "front camera " << cam;
    }
    total += n;
    double ratio_sum = 0;
    int ratios = 0;
    for (int y = 0; y < img.rows; ++y) {
      for (int x = 0; x < img.cols; ++x) {
        if (!shadow.at<std::uint8_t>(y, x)) continue;
        const cv::Vec3d p = img.at<cv::Vec3b>(y, x), q = bg.at<cv::Vec3b>(y, x);
        EXPECT_LT(cv::norm(p), cv::norm(q));
        // Colour angle between shadow and lit floor (the method's eq. 2), in degrees.
        const double c = p.dot(q) / (cv::norm(p) * cv::norm(q));
        EXPECT_LT(std::acos(std::min(1.0, c)) * 180 / M_PI, 2.0);
        for (int ch = 0; ch < 3; ++ch) {
          if (q[ch] >= 40) {
            ratio_sum += p[ch] / q[ch];
            ++ratios;
          }
        }
      }
    }
    if (ratios > 0) {
      EXPECT_NEAR(ratio_sum / ratios, s.options().shadow_factor, 0.02);
    }
  }
  EXPECT_GT(total, 1000);
  SceneOptions o = small("tpose");
  o.shadows = false;
  const Scene none(o);
  cv::Mat img, sil, shadow;
  none.render_clean(0, 0, img, &sil, &shadow);
  EXPECT_EQ(cv::countNonZero(shadow), 0);
}

TEST(SimScene, TwoDTruthIsTheProjectionOfTheThreeDTruthWithTheWrittenCalibration) {
  SceneOptions o = small("wave");
  o.rig.distortion = true;
  const Scene s(o);
  const fs::path yaml = fs::path(::testing::TempDir()) / "vc_sim_scene_rig.yaml";
  rig::write_calibration(yaml.string(), s.calibration());
  const rig::Calibration calib = rig::read_calibration(yaml.string());
  ASSERT_EQ(static_cast<int>(calib.cameras.size()), s.camera_count());
  for (int frame : {0, 100, 200, 300}) {
    const auto joints = s.joints(frame);
    for (int cam = 0; cam < s.camera_count(); ++cam) {
      const auto feats = s.features(frame, cam);
      ASSERT_EQ(feats.size(), static_cast<std::size_t>(kFeatureCount));
      cv::Mat img, sil;
      s.render_clean(frame, cam, img, &sil);
      for (const FeatureTruth& f : feats) {
        const cv::Point2d uv = calib.cameras[static_cast<std::size_t>(cam)].project(
            joints[static_cast<std::size_t>(feature_joint(f.feature))]);
        EXPECT_NEAR(uv.x, f.uv.x, 0.01);
        EXPECT_NEAR(uv.y, f.uv.y, 0.01);
        EXPECT_EQ(f.visible, f.in_image && !f.occluded);
        // A visible head is seen where it projects: that pixel belongs to the body.
        if (f.feature == Feature::head && f.visible) {
          EXPECT_EQ(sil.at<std::uint8_t>(cvRound(f.uv.y), cvRound(f.uv.x)), 255);
        }
      }
    }
  }
}

TEST(SimScene, FeaturesHiddenBehindTheBodyAreNotVisible) {
  const Scene s(small("cross"));
  // tau = 1.5 s into "cross": hands crossed in front of the chest.
  const int frame = s.motion().lead_in_frames() + 90;
  // Front cameras see both hands; a camera straight behind does not.
  for (int cam : {0, 1}) {
    const auto f = s.features(frame, cam);
    EXPECT_TRUE(f[static_cast<int>(Feature::l_hand)].visible) << cam;
    EXPECT_TRUE(f[static_cast<int>(Feature::head)].visible) << cam;
  }
  SceneOptions o = small("cross");
  rig::Calibration calib = default_rig(o.rig);
  calib.cameras.push_back(rig::Camera::look_at("back", 160, 120, 150, {0, 3.5, 1.3}, {0, 0, 1.2}));
  o.calibration = calib;
  const Scene with_back(o);
  const auto back = with_back.features(frame, with_back.camera_count() - 1);
  EXPECT_TRUE(back[static_cast<int>(Feature::l_hand)].occluded);
  EXPECT_TRUE(back[static_cast<int>(Feature::r_hand)].occluded);
  EXPECT_FALSE(back[static_cast<int>(Feature::head)].occluded);
  EXPECT_FALSE(back[static_cast<int>(Feature::l_hand)].visible);
  // In the initialization pose nothing is hidden from the front.
  for (const FeatureTruth& f : s.features(0, 0)) EXPECT_TRUE(f.visible) << feature_name(f.feature);
}

TEST(SimScene, OccupancyAgreesWithThePointTestAndTheImages) {
  const Scene s(small("arms-close"));
  const int frame = 150;
  const rig::VoxelGrid grid = rig::VoxelGrid::covering({-1.25, -1.25, 0}, {1.25, 1.25, 2.2}, 0.04);
  std::vector<std::uint8_t> bits;
  s.occupancy(grid, frame, &bits);
  ASSERT_EQ(bits.size(), grid.bitset_bytes());
  std::size_t occupied = 0;
  std::vector<cv::Mat> sils(static_cast<std::size_t>(s.camera_count()));
  for (int cam = 0; cam < s.camera_count(); ++cam) {
    cv::Mat img;
    s.render_clean(frame, cam, img, &sils[static_cast<std::size_t>(cam)]);
  }
  std::size_t inside = 0, checks = 0;
  const std::vector<Primitive> prims = s.primitives(frame);
  for (int k = 0; k < grid.nz; ++k) {
    for (int j = 0; j < grid.ny; ++j) {
      for (int i = 0; i < grid.nx; ++i) {
        const bool bit = rig::hull_bit(bits.data(), grid.index(i, j, k));
        const cv::Vec3d c = grid.center(i, j, k);
        const bool in_body =
            std::any_of(prims.begin(), prims.end(), [&](const Primitive& p) { return p.contains(c); });
        ASSERT_EQ(bit, in_body && c[2] >= 0) << i << " " << j << " " << k;
        if ((i + j + k) % 97 == 0) {
          ASSERT_EQ(bit, s.occupied(c, frame));
        }
        if (!bit) continue;
        ++occupied;
        for (int cam = 0; cam < s.camera_count(); ++cam) {
          const cv::Point2d uv = s.calibration().cameras[static_cast<std::size_t>(cam)].project(c);
          const cv::Mat& sil = sils[static_cast<std::size_t>(cam)];
          // One of the four pixel centres around the projection is a body pixel.
          const int x0 = static_cast<int>(std::floor(uv.x)), y0 = static_cast<int>(std::floor(uv.y));
          bool any = false;
          for (int dy = 0; dy < 2; ++dy) {
            for (int dx = 0; dx < 2; ++dx) any = any || sil.at<std::uint8_t>(y0 + dy, x0 + dx) == 255;
          }
          ++checks;
          inside += any;
        }
      }
    }
  }
  // A body of ~70 litres in 4 cm voxels.
  EXPECT_GT(occupied, 600u);
  EXPECT_LT(occupied, 2000u);
  // Every occupied voxel centre is seen inside every silhouette.
  EXPECT_EQ(inside, checks);
  EXPECT_FALSE(s.occupied({0, 0, -0.01}, frame));
  EXPECT_FALSE(s.occupied({2, 2, 1}, frame));
  EXPECT_TRUE(s.occupied(s.joints(frame)[static_cast<int>(Joint::head)], frame));
}

TEST(SimScene, RenderingIsDeterministicAndSeeded) {
  SceneOptions o = small("walk");
  o.noise_sigma = 3;
  o.flicker = 0.05;
  const Scene a(o), b(o);
  o.seed = 2;
  const Scene c(o);
  cv::Mat ia, ib, ic;
  a.render(123, 3, ia);
  b.render(123, 3, ib);
  c.render(123, 3, ic);
  EXPECT_EQ(cv::countNonZero(differs(ia, ib)), 0);
  EXPECT_GT(cv::countNonZero(differs(ia, ic)), ia.total() / 2);
  // Successive frames have different noise.
  cv::Mat ia2;
  a.render(124, 3, ia2);
  EXPECT_GT(cv::countNonZero(differs(ia, ia2)), ia.total() / 2);
  // Concurrent rendering gives the same pixels.
  cv::Mat t1, t2;
  std::thread th([&] { a.render(123, 3, t1); });
  a.render(123, 3, t2);
  th.join();
  EXPECT_EQ(cv::countNonZero(differs(t1, ia)), 0);
  EXPECT_EQ(cv::countNonZero(differs(t2, ia)), 0);
}

TEST(SimScene, RendersIntoACallersRegionOfInterest) {
  SceneOptions o = small("walk");
  o.noise_sigma = 2;
  const Scene s(o);
  cv::Mat whole, sil;
  s.render(40, 1, whole, &sil);
  cv::Mat big(200, 300, CV_8UC3, cv::Scalar(1, 2, 3));
  cv::Mat roi = big(cv::Rect(50, 40, 160, 120));
  const uchar* data = roi.data;
  s.render(40, 1, roi);
  EXPECT_EQ(roi.data, data);  // rendered in place
  EXPECT_EQ(cv::countNonZero(differs(roi, whole)), 0);
  EXPECT_EQ(big.at<cv::Vec3b>(0, 0), cv::Vec3b(1, 2, 3));
}

TEST(SimScene, NoiseHasTheConfiguredSigmaAndFlickerTheConfiguredRange) {
  SceneOptions o = small("tpose");
  o.noise_sigma = 4;
  const Scene s(o);
  cv::Mat clean;
  s.render_background_clean(0, clean);
  double sum = 0, sum2 = 0;
  std::size_t n = 0;
  for (int i = 0; i < 10; ++i) {
    cv::Mat bg;
    s.render_background(0, i, bg);
    cv::Mat d;
    cv::subtract(bg, clean, d, cv::noArray(), CV_32F);
    cv::Mat c3;
    clean.convertTo(c3, CV_32F);
    for (std::size_t k = 0; k < d.total() * 3; ++k) {
      const float v = c3.ptr<float>()[k];
      if (v < 20 || v > 235) continue;  // away from saturation
      sum += d.ptr<float>()[k];
      sum2 += d.ptr<float>()[k] * d.ptr<float>()[k];
      ++n;
    }
  }
  const double mean = sum / static_cast<double>(n);
  const double sd = std::sqrt(sum2 / static_cast<double>(n) - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.05);
  EXPECT_NEAR(sd, 4.0, 0.1);  // rounding adds 1/12 to the variance

  o.noise_sigma = 0;
  o.flicker = 0.1;
  const Scene f(o);
  double lo = 2, hi = 0;
  for (int frame = 0; frame < 200; ++frame) {
    const double g = f.flicker_gain(frame);
    lo = std::min(lo, g);
    hi = std::max(hi, g);
  }
  EXPECT_GE(lo, 0.9);
  EXPECT_LE(hi, 1.1);
  EXPECT_LT(lo, 0.93);
  EXPECT_GT(hi, 1.07);
  cv::Mat lit, base, sil;
  f.render(10, 0, lit, &sil);
  f.render_clean(10, 0, base);
  const double g = f.flicker_gain(10);
  const cv::Vec3b p = lit.at<cv::Vec3b>(5, 5), q = base.at<cv::Vec3b>(5, 5);
  for (int ch = 0; ch < 3; ++ch) EXPECT_EQ(p[ch], cv::saturate_cast<std::uint8_t>(q[ch] * g));
}

// FNV-1a over an image's bytes.
std::uint64_t fnv1a(const cv::Mat& m) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (int y = 0; y < m.rows; ++y) {
    const auto* p = m.ptr<std::uint8_t>(y);
    for (std::size_t i = 0; i < static_cast<std::size_t>(m.cols) * m.elemSize(); ++i) {
      h = (h ^ p[i]) * 0x100000001b3ull;
    }
  }
  return h;
}

TEST(SimScene, DefaultRoomKeepsItsPixels) {
  // The room as it was before room presets existed (hashes of the clean empty room of every camera
  // and of a clean frame with the performer and its shadow): the default room must not change.
  const Scene s(small("wave"));
  std::string hashes;
  for (int cam = 0; cam < s.camera_count(); ++cam) {
    cv::Mat img;
    s.render_background_clean(cam, img);
    hashes += std::to_string(fnv1a(img)) + " ";
  }
  cv::Mat img;
  s.render_clean(120, 0, img);
  hashes += std::to_string(fnv1a(img));
  EXPECT_EQ(hashes,
            "5428660355079113908 11180813951846702574 16396637256694128637 16651227523320548650 "
            "9363011303830239858 8948948032044964216 10277829543945014776");
}

TEST(SimScene, OptionsAreValidated) {
  SceneOptions o = small("walk");
  std::string why;
  ASSERT_TRUE(o.valid(&why)) << why;
  o.noise_sigma = -1;
  EXPECT_FALSE(o.valid(&why));
  EXPECT_THAT(why, ::testing::HasSubstr("noise_sigma"));
  o = small("walk");
  o.appearance = "purple";
  EXPECT_FALSE(o.valid(&why));
  EXPECT_THAT(why, ::testing::HasSubstr("default"));
  EXPECT_THROW(Scene{o}, std::invalid_argument);
  o = small("walk");
  o.rig.cameras = 1;
  EXPECT_FALSE(o.valid(&why));
  o = small("no-such-motion");
  EXPECT_THROW(Scene{o}, std::invalid_argument);
  const Scene s(small("walk"));
  cv::Mat img;
  EXPECT_THROW(s.render(0, 6, img), std::out_of_range);
  EXPECT_THROW(s.render(-1, 0, img), std::out_of_range);
}

TEST(SimRigLayout, DefaultRingHasAFrontPairAndFramesTheVolume) {
  const RigLayout layout;
  const rig::Calibration c = default_rig(layout);
  ASSERT_EQ(c.cameras.size(), 6u);
  ASSERT_TRUE(c.grid.has_value());
  EXPECT_TRUE(c.valid(nullptr));
  const cv::Vec3d c0 = c.cameras[0].center_world(), c1 = c.cameras[1].center_world();
  EXPECT_NEAR(cv::norm(c0 - c1), 0.8, 1e-9);
  EXPECT_LT(c0[1], -3.5);  // in front: -y
  double best_fill = 0;
  for (const auto& cam : c.cameras) {
    EXPECT_NEAR(std::hypot(cam.center_world()[0], cam.center_world()[1]), 3.8, 1e-9);
    // Every volume corner is in the image, and the volume fills it.
    double umin = 1e9, umax = -1e9, vmin = 1e9, vmax = -1e9;
    for (int k = 0; k < 8; ++k) {
      const cv::Vec3d corner((k & 1) ? 1.25 : -1.25, (k & 2) ? 1.25 : -1.25, (k & 4) ? 2.2 : 0.0);
      const cv::Point2d uv = cam.project(corner);
      EXPECT_TRUE(cam.in_image(uv));
      umin = std::min(umin, uv.x);
      umax = std::max(umax, uv.x);
      vmin = std::min(vmin, uv.y);
      vmax = std::max(vmax, uv.y);
    }
    const double fill = std::max((umax - umin) / cam.width, (vmax - vmin) / cam.height);
    EXPECT_GT(fill, 0.8);
    best_fill = std::max(best_fill, fill);
  }
  EXPECT_GT(best_fill, 0.93);  // one focal length: the tightest view fills its image
}

}  // namespace
}  // namespace vc::sim
