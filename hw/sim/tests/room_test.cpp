// Room presets and per-part occupancy: the camouflage room is what it claims (a floor close to the
// skin presets and walls close to the shirt presets, textured where real surfaces are, flat where
// printed or enamelled ones are), it renders deterministically, and the part labels of the voxels
// agree with occupancy() and with the primitives.
#include <algorithm>
#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "../src/room.hpp"
#include "voxcap/sim/scene.hpp"

namespace vc::sim {
namespace {

SceneOptions small(const std::string& motion, const std::string& room = "default") {
  SceneOptions o;
  o.motion.source = motion;
  o.room = room;
  o.rig.width = 160;
  o.rig.height = 120;
  o.noise_sigma = 0;
  return o;
}

// Angle between two colours (the hue test of the method's shadow rule, eq. 2), degrees.
double angle_deg(const cv::Vec3d& a, const cv::Vec3d& b) {
  return std::acos(std::clamp(a.dot(b) / (cv::norm(a) * cv::norm(b)), -1.0, 1.0)) * 180 / M_PI;
}

struct Stats {
  cv::Vec3d mean;
  double rel_sd = 0;  // of the channel sum, relative to its mean
};

// Albedo statistics over a square of a face (u, v: the face's in-plane coordinates) on a 5 mm raster.
template <typename Point>
Stats sample(const detail::Room& room, int face, double u0, double v0, double side, Point point) {
  cv::Vec3d sum(0, 0, 0);
  double s = 0, s2 = 0;
  int n = 0;
  for (double u = u0; u < u0 + side; u += 0.005) {
    for (double v = v0; v < v0 + side; v += 0.005) {
      const cv::Vec3d c = room.albedo(face, point(u, v));
      sum += c;
      const double t = c[0] + c[1] + c[2];
      s += t;
      s2 += t * t;
      ++n;
    }
  }
  Stats st;
  st.mean = sum / n;
  const double m = s / n;
  st.rel_sd = std::sqrt(std::max(0.0, s2 / n - m * m)) / m;
  return st;
}

detail::Room camouflage() {
  detail::Room r;
  r.style = detail::room_style("camouflage");
  return r;
}

TEST(SimRoom, PresetsAreListedAndUnknownOnesRejected) {
  ASSERT_GE(room_presets().size(), 2u);
  EXPECT_EQ(room_presets()[0].name, "default");
  EXPECT_EQ(room_presets()[1].name, "camouflage");
  for (const RoomPreset& r : room_presets()) EXPECT_GE(detail::room_style(r.name), 0) << r.name;
  SceneOptions o = small("wave", "cave");
  std::string why;
  EXPECT_FALSE(o.valid(&why));
  EXPECT_THAT(why, ::testing::HasSubstr("unknown room 'cave' (known: default, camouflage)"));
  EXPECT_THROW(Scene{o}, std::invalid_argument);
}

TEST(SimRoom, CamouflageFloorIsCloseToTheSkinPresetsAndTextured) {
  const detail::Room room = camouflage();
  // A 1.2 m square of the floor under the performer: 9 tiles.
  const Stats floor =
      sample(room, detail::kFloor, -0.6, -0.6, 1.2, [](double u, double v) { return cv::Vec3d(u, v, 0); });
  for (const char* skin : {"default", "beige", "olive", "pale"}) {
    const cv::Vec3d s = appearance_preset(skin).skin;
    EXPECT_LT(angle_deg(floor.mean, s), 6.0) << skin;
    EXPECT_NEAR(cv::norm(floor.mean) / cv::norm(s), 1.0, 0.25) << skin;
  }
  // Within one tile (away from the grout), a stone-like mottle of a few per cent.
  const Stats tile =
      sample(room, detail::kFloor, 0.05, 0.05, 0.3, [](double u, double v) { return cv::Vec3d(u, v, 0); });
  EXPECT_GT(tile.rel_sd, 0.015);
  EXPECT_LT(tile.rel_sd, 0.08);
}

TEST(SimRoom, CamouflageWallsAreCloseToTheShirtPresetsTexturedWithFlatPrints) {
  const detail::Room room = camouflage();
  // Below 2 m, away from the posters and doors: u along the wall, z up.
  struct Wall {
    int face;
    const char* shirt;
    double u0;
  };
  for (const Wall& w : {Wall{detail::kWallPosY, "default", -1.4}, Wall{detail::kWallNegY, "pale", -2.6},
                        Wall{detail::kWallPosX, "olive", -1.0}, Wall{detail::kWallNegX, "brown", 0.3}}) {
    auto point = [&](double u, double z) {
      const double h = room.half_m;
      switch (w.face) {
        case detail::kWallPosY:
          return cv::Vec3d(u, h, z);
        case detail::kWallNegY:
          return cv::Vec3d(-u, -h, z);
        case detail::kWallPosX:
          return cv::Vec3d(h, -u, z);
        default:
          return cv::Vec3d(-h, u, z);
      }
    };
    const Stats paint = sample(room, w.face, w.u0, 0.4, 0.8, point);
    const cv::Vec3d shirt = appearance_preset(w.shirt).shirt;
    EXPECT_LT(angle_deg(paint.mean, shirt), 4.0) << w.shirt;
    EXPECT_NEAR(cv::norm(paint.mean) / cv::norm(shirt), 1.0, 0.15) << w.shirt;
    // Plaster: a little texture, not flat.
    EXPECT_GT(paint.rel_sd, 0.01) << w.shirt;
    EXPECT_LT(paint.rel_sd, 0.06) << w.shirt;
  }
  // Flat: the skin-toned poster and the door on the +y wall.
  const auto on_pos_y = [&](double u, double z) { return cv::Vec3d(u, room.half_m, z); };
  EXPECT_EQ(sample(room, detail::kWallPosY, -2.5, 1.1, 0.5, on_pos_y).rel_sd, 0.0);
  EXPECT_EQ(sample(room, detail::kWallPosY, 1.0, 0.3, 0.6, on_pos_y).rel_sd, 0.0);
}

TEST(SimRoom, CamouflageRendersDeterministicallyAndDiffersFromTheDefault) {
  const Scene a(small("wave", "camouflage")), b(small("wave", "camouflage")), d(small("wave"));
  for (int cam : {0, 3}) {
    cv::Mat ia, ib, id, sa, sd;
    a.render_clean(100, cam, ia, &sa);
    b.render_clean(100, cam, ib);
    d.render_clean(100, cam, id, &sd);
    EXPECT_EQ(cv::norm(ia, ib, cv::NORM_INF), 0.0);
    // The room differs almost everywhere, the performer is the same.
    cv::Mat diff;
    cv::absdiff(ia, id, diff);
    cv::cvtColor(diff, diff, cv::COLOR_RGB2GRAY);
    EXPECT_GT(cv::countNonZero(diff), static_cast<int>(ia.total() * 3 / 4));
    EXPECT_EQ(cv::norm(sa, sd, cv::NORM_INF), 0.0);
    cv::Mat body_diff;
    diff.copyTo(body_diff, sa);
    EXPECT_EQ(cv::countNonZero(body_diff), 0);
  }
}

TEST(SimOccupancy, PartLabelsAgreeWithOccupancyAndThePrimitives) {
  const rig::VoxelGrid grid = rig::VoxelGrid::covering({-1.25, -1.25, 0}, {1.25, 1.25, 2.2}, 0.02);
  for (const auto& [motion, frame] :
       {std::pair<const char*, int>{"tpose", 0}, {"arms-close", 150}, {"wave", 140}}) {
    const Scene s(small(motion));
    std::vector<std::uint8_t> bits, part;
    s.occupancy(grid, frame, &bits);
    s.occupancy_parts(grid, frame, &part);
    ASSERT_EQ(part.size(), static_cast<std::size_t>(grid.nx) * grid.ny * grid.nz);
    const std::vector<Primitive> prims = s.primitives(frame);
    std::vector<int> per_part(kPartCount, 0);
    int overlaps = 0;
    for (int k = 0; k < grid.nz; ++k) {
      for (int j = 0; j < grid.ny; ++j) {
        for (int i = 0; i < grid.nx; ++i) {
          const std::size_t v = grid.index(i, j, k);
          ASSERT_EQ(part[v] != Scene::kNoPart, rig::hull_bit(bits.data(), v)) << motion << " " << v;
          if (part[v] == Scene::kNoPart) continue;
          ASSERT_LT(part[v], kPartCount);
          ++per_part[part[v]];
          const cv::Vec3d c = grid.center(i, j, k);
          // Its own primitive holds it, and no higher part does.
          ASSERT_TRUE(prims[part[v]].contains(c)) << part_name(static_cast<Part>(part[v]));
          int holders = 0;
          for (int p = 0; p < kPartCount; ++p) {
            if (!prims[static_cast<std::size_t>(p)].contains(c)) continue;
            ++holders;
            ASSERT_LE(p, part[v]) << part_name(static_cast<Part>(p)) << " over "
                                  << part_name(static_cast<Part>(part[v]));
          }
          overlaps += holders > 1;
        }
      }
    }
    // At 2 cm every part has voxels of its own, and the parts overlap at the joints.
    for (int p = 0; p < kPartCount; ++p)
      EXPECT_GT(per_part[static_cast<std::size_t>(p)], 0) << motion << " " << part_name(static_cast<Part>(p));
    EXPECT_GT(overlaps, 0) << motion;
  }
  const Scene s(small("wave"));
  std::vector<std::uint8_t> part;
  rig::VoxelGrid bad = grid;
  bad.nx = 0;
  EXPECT_THROW(s.occupancy_parts(bad, 0, &part), std::invalid_argument);
}

}  // namespace
}  // namespace vc::sim
