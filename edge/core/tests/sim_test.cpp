// edge/core against the virtual rig's ground truth (hw/sim): noise and floor shadows on, a built-in
// motion, the node's two front cameras (with lens distortion).
//  - subtraction + clean-up vs the true silhouettes: IoU >= 0.97 per image;
//  - >= 95 % of the true shadow pixels classified background;
//  - the partial hull carved from the true silhouettes contains every voxel whose centre is inside
//    the body and seen by both cameras. The true silhouette is sampled at pixel centres and a voxel
//    uses the pixel nearest to its centre's projection, so a body voxel near the outline can land on
//    a pixel whose centre just misses the body: the containment is exact with the silhouettes grown
//    by one pixel, and without that growth only such outline voxels may be missing (< 1 %).
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>
#include "voxcap/edge/bgmodel.h"
#include "voxcap/edge/carver.h"
#include "voxcap/edge/cleanup.h"
#include "voxcap/rig/c_models.hpp"
#include "voxcap/sim/body.hpp"
#include "voxcap/sim/scene.hpp"
#include "voxcap/subtraction.h"

namespace {

vc::sim::SceneOptions options() {
  vc::sim::SceneOptions o;
  o.rig.cameras = 4;
  o.rig.distortion = true;
  o.rig.voxel_m = 0.04;
  o.noise_sigma = 2.0;
  o.shadows = true;
  o.seed = 5;
  return o;
}

// The floor shadow darkens by 40 % (up to ~90 levels): T_u * sigma must exceed that so shadows reach
// the colour test; noise of a darkened pixel tilts its colour by a few degrees, hence 8 degrees.
vc_subtract_params sim_params() {
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  p.t_upper = 60.0;
  p.t_lower = 3.5;
  p.cos2_angular = std::pow(std::cos(8.0 * M_PI / 180.0), 2);
  p.shadow_min_gain = 0.3;
  p.shadow_max_gain = 1.0;
  return p;
}

TEST(SimTruth, SubtractionMatchesTrueSilhouettesAndDropsShadows) {
  vc::sim::Scene scene(options());
  const int frames[] = {0, 17, 41};
  for (int cam = 0; cam < 2; cam++) {
    const auto& c = scene.calibration().cameras[cam];
    vc_bgmodel* made = nullptr;
    char why[128];
    ASSERT_EQ(vc_bgmodel_new(c.width, c.height, &made, why, sizeof why), 0) << why;
    std::unique_ptr<vc_bgmodel, void (*)(vc_bgmodel*)> m(made, vc_bgmodel_free);
    ASSERT_NE(m, nullptr);
    cv::Mat rgb, sil, shadow;
    for (int i = 0; i < 20; i++) {
      scene.render_background(cam, i, rgb);
      ASSERT_EQ(vc_bgmodel_learn(m.get(), rgb.data, rgb.step), 0);
    }
    ASSERT_EQ(vc_bgmodel_finish(m.get()), 0);
    vc_subtract_params p = sim_params();
    ASSERT_EQ(vc_bgmodel_set_params(m.get(), &p), 0);
    std::vector<uint8_t> mask(static_cast<size_t>(c.width) * c.height),
        scratch(vc_cleanup_scratch_size(c.width));
    for (int f : frames) {
      scene.render(f, cam, rgb, &sil, &shadow);
      ASSERT_EQ(vc_subtract(m.get(), rgb.data, rgb.step, mask.data(), nullptr), 0);
      ASSERT_EQ(vc_cleanup(mask.data(), c.width, c.height, 1, scratch.data(), scratch.size()), 0);
      size_t inter = 0, uni = 0, sh = 0, sh_bg = 0;
      for (int y = 0; y < c.height; y++)
        for (int x = 0; x < c.width; x++) {
          bool t = sil.at<uint8_t>(y, x) != 0, e = mask[static_cast<size_t>(y) * c.width + x] != 0;
          inter += t && e;
          uni += t || e;
          if (shadow.at<uint8_t>(y, x)) {
            sh++;
            sh_bg += !e;
          }
        }
      ASSERT_GT(uni, 0u);
      double iou = static_cast<double>(inter) / uni;
      EXPECT_GE(iou, 0.97) << "camera " << cam << " frame " << f;
      if (sh > 200) {
        EXPECT_GE(static_cast<double>(sh_bg) / sh, 0.95) << "camera " << cam << " frame " << f;
      }
      RecordProperty("iou_cam" + std::to_string(cam) + "_f" + std::to_string(f), std::to_string(iou));
    }
  }
}

// With the edge's defaults (the texture test on): the whole body is kept, hands and feet over the
// wooden floor included, and the floor shadow still goes: per camera and frame, >= 99 % of the body
// pixels in the cleaned mask, >= 98 % of the mask body, <= 2 % of the shadow pixels kept (measured
// 99.5-99.97 %, 98.6 %, 0.7-0.9 %). Was >= 96 % and >= 97 % while the deepest shadow was 0.25 of
// the light: the waving forearm's shaded blue sleeve over the flat blue painting (1.7 degrees apart,
// no texture to test) passed for shadow; darkened by more than 55 % it is foreground now.
TEST(SimTruth, DefaultsKeepTheBodyAndDropTheShadow) {
  vc::sim::SceneOptions o = options();
  o.motion.source = "wave";
  vc::sim::Scene scene(o);
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  for (int cam = 0; cam < 2; cam++) {
    const auto& c = scene.calibration().cameras[cam];
    vc_bgmodel* made = nullptr;
    char why[128];
    ASSERT_EQ(vc_bgmodel_new(c.width, c.height, &made, why, sizeof why), 0) << why;
    std::unique_ptr<vc_bgmodel, void (*)(vc_bgmodel*)> m(made, vc_bgmodel_free);
    cv::Mat rgb, sil, shadow;
    for (int i = 0; i < VC_BACKGROUND_FRAMES; i++) {
      scene.render_background(cam, i, rgb);
      ASSERT_EQ(vc_bgmodel_learn(m.get(), rgb.data, rgb.step), 0);
    }
    ASSERT_EQ(vc_bgmodel_finish(m.get()), 0);
    ASSERT_EQ(vc_bgmodel_set_params(m.get(), &p), 0);
    std::vector<uint8_t> mask(static_cast<size_t>(c.width) * c.height),
        scratch(vc_cleanup_scratch_size(c.width));
    for (int f : {60, 90, 108}) {
      scene.render(f, cam, rgb, &sil, &shadow);
      ASSERT_EQ(vc_subtract(m.get(), rgb.data, rgb.step, mask.data(), nullptr), 0);
      ASSERT_EQ(
          vc_cleanup(mask.data(), c.width, c.height, VC_CLEANUP_RADIUS_PX, scratch.data(), scratch.size()),
          0);
      size_t body = 0, kept = 0, fg = 0, sh = 0, sh_kept = 0;
      for (size_t i = 0; i < mask.size(); i++) {
        const bool t = sil.data[i] != 0, e = mask[i] != 0;
        body += t;
        kept += t && e;
        fg += e;
        if (shadow.data[i]) {
          sh++;
          sh_kept += e;
        }
      }
      ASSERT_GT(body, 1000u);
      EXPECT_GE(static_cast<double>(kept) / body, 0.99) << "camera " << cam << " frame " << f;
      EXPECT_GE(static_cast<double>(kept) / fg, 0.98) << "camera " << cam << " frame " << f;
      if (sh > 200) EXPECT_LE(static_cast<double>(sh_kept) / sh, 0.02) << "camera " << cam << " frame " << f;
    }
  }
}

// The defaults on every appearance preset in both rooms (the camouflage room's floor is close to
// skin, its walls to the shirts), 4 cameras at 320x240, wave frames with the arms out and down: per
// preset and room, >= 98.5 % of the body pixels in the cleaned masks, >= 96 % of the masks body, and
// <= 2.5 % of the floor-shadow pixels kept (the fringe at the feet weighs more at this size than the
// issue's 2 % at 640x480). Measured: 99.0-99.8 % recall; with the old deepest shadow (min gain 0.25)
// dark skin over the dark floor, and the default preset in the camouflage room, fell to 94.6-97.8 %.
TEST(SimTruth, DefaultsKeepTheBodyOnEveryPresetAndRoom) {
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  for (const vc::sim::Appearance& look : vc::sim::appearance_presets())
    for (const vc::sim::RoomPreset& room : vc::sim::room_presets()) {
      SCOPED_TRACE(look.name + " in the " + room.name + " room");
      vc::sim::SceneOptions o;
      o.rig.cameras = 4;
      o.rig.width = 320;
      o.rig.height = 240;
      o.motion.source = "wave";
      o.appearance = look.name;
      o.room = room.name;
      vc::sim::Scene scene(o);
      size_t body = 0, kept = 0, fg = 0, sh = 0, sh_kept = 0;
      for (int cam = 0; cam < scene.camera_count(); cam++) {
        const auto& c = scene.calibration().cameras[static_cast<size_t>(cam)];
        vc_bgmodel* made = nullptr;
        char why[128];
        ASSERT_EQ(vc_bgmodel_new(c.width, c.height, &made, why, sizeof why), 0) << why;
        std::unique_ptr<vc_bgmodel, void (*)(vc_bgmodel*)> m(made, vc_bgmodel_free);
        cv::Mat rgb, sil, shadow;
        for (int i = 0; i < VC_BACKGROUND_FRAMES; i++) {
          scene.render_background(cam, i, rgb);
          ASSERT_EQ(vc_bgmodel_learn(m.get(), rgb.data, rgb.step), 0);
        }
        ASSERT_EQ(vc_bgmodel_finish(m.get()), 0);
        ASSERT_EQ(vc_bgmodel_set_params(m.get(), &p), 0);
        std::vector<uint8_t> mask(static_cast<size_t>(c.width) * c.height),
            scratch(vc_cleanup_radius_scratch_size(c.width, VC_CLEANUP_RADIUS_PX));
        for (int i = 0; i < 3; i++) {
          scene.render(scene.motion().lead_in_frames() + 20 * i, cam, rgb, &sil, &shadow);
          ASSERT_EQ(vc_subtract(m.get(), rgb.data, rgb.step, mask.data(), nullptr), 0);
          ASSERT_EQ(vc_cleanup_radius(mask.data(), c.width, c.height, VC_CLEANUP_RADIUS_PX, scratch.data(),
                                      scratch.size()),
                    0);
          for (size_t n = 0; n < mask.size(); n++) {
            const bool t = sil.data[n] != 0, e = mask[n] != 0;
            body += t;
            kept += t && e;
            fg += e;
            if (shadow.data[n]) {
              sh++;
              sh_kept += e;
            }
          }
        }
      }
      ASSERT_GT(body, 10000u);
      ASSERT_GT(sh, 1000u);
      EXPECT_GE(static_cast<double>(kept) / body, 0.985);
      EXPECT_GE(static_cast<double>(kept) / fg, 0.96);
      EXPECT_LE(static_cast<double>(sh_kept) / sh, 0.025);
    }
}

TEST(SimTruth, PartialHullContainsTheBodySeenByBothCameras) {
  vc::sim::Scene scene(options());
  const auto& calib = scene.calibration();
  ASSERT_TRUE(calib.grid.has_value());
  const vc::rig::VoxelGrid& g = *calib.grid;
  vc_voxel_grid grid = vc::rig::to_c_grid(g);
  vc_camera cams[2] = {vc::rig::to_c_camera(calib.cameras[0]), vc::rig::to_c_camera(calib.cameras[1])};
  vc_carver* made = nullptr;
  char why[200];
  ASSERT_EQ(vc_carver_new(&grid, &cams[0], &cams[1], VC_CARVE_CENTRE, &made, why, sizeof why), 0) << why;
  std::unique_ptr<vc_carver, void (*)(vc_carver*)> cv(made, vc_carver_free);
  ASSERT_NE(cv, nullptr);
  std::vector<uint8_t> bits(vc_carver_bitset_bytes(cv.get())), grown_bits(bits.size()), body;
  for (int f : {0, 23, 57}) {
    cv::Mat rgb, sil[2], grown[2];
    for (int c = 0; c < 2; c++) {
      scene.render_clean(f, c, rgb, &sil[c]);
      cv::dilate(sil[c], grown[c], cv::Mat::ones(3, 3, CV_8U));
    }
    ASSERT_EQ(vc_carver_run(cv.get(), sil[0].data, sil[1].data, bits.data(), nullptr), 0);
    ASSERT_EQ(vc_carver_run(cv.get(), grown[0].data, grown[1].data, grown_bits.data(), nullptr), 0);
    scene.occupancy(g, f, &body);
    size_t inside = 0, missing = 0, missing_grown = 0;
    for (int k = 0; k < g.nz; k++)
      for (int j = 0; j < g.ny; j++)
        for (int i = 0; i < g.nx; i++) {
          size_t n = g.index(i, j, k);
          if (!((body[n / 8] >> (n % 8)) & 1)) continue;
          cv::Vec3d p = g.center(i, j, k);
          double pw[3] = {p[0], p[1], p[2]};
          int x, y;
          if (!vc_camera_project(&cams[0], pw, &x, &y) || !vc_camera_project(&cams[1], pw, &x, &y)) continue;
          inside++;
          missing += !((bits[n / 8] >> (n % 8)) & 1);
          missing_grown += !((grown_bits[n / 8] >> (n % 8)) & 1);
        }
    EXPECT_GT(inside, 100u) << "frame " << f;
    EXPECT_EQ(missing_grown, 0u) << "frame " << f << ": body voxels seen by both cameras but not in the hull";
    EXPECT_LE(missing, inside / 100) << "frame " << f;
  }
}

}  // namespace
