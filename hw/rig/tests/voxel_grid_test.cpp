#include "voxcap/rig/voxel_grid.hpp"

#include <vector>

#include <gtest/gtest.h>

namespace vc::rig {
namespace {

VoxelGrid small_grid() {
  VoxelGrid g;
  g.min_m = {-1.0, -0.5, 0.0};
  g.voxel_m = 0.25;
  g.nx = 8;
  g.ny = 4;
  g.nz = 3;
  return g;
}

TEST(RigVoxelGrid, CentreIndexAndCountFollowTheDesignConvention) {
  const VoxelGrid g = small_grid();
  ASSERT_TRUE(g.valid(nullptr));
  EXPECT_EQ(g.count(), 96u);
  EXPECT_EQ(g.bitset_bytes(), 12u);
  EXPECT_EQ(g.index(0, 0, 0), 0u);
  EXPECT_EQ(g.index(1, 0, 0), 1u);
  EXPECT_EQ(g.index(0, 1, 0), 8u);
  EXPECT_EQ(g.index(0, 0, 1), 32u);
  EXPECT_EQ(g.index(7, 3, 2), 95u);
  const cv::Vec3d c = g.center(2, 1, 0);
  EXPECT_DOUBLE_EQ(c[0], -1.0 + 2.5 * 0.25);
  EXPECT_DOUBLE_EQ(c[1], -0.5 + 1.5 * 0.25);
  EXPECT_DOUBLE_EQ(c[2], 0.125);
  EXPECT_LT(cv::norm(g.max_m() - cv::Vec3d(1.0, 0.5, 0.75)), 1e-12);
}

TEST(RigVoxelGrid, LocateInvertsCenter) {
  const VoxelGrid g = small_grid();
  for (int k = 0; k < g.nz; ++k) {
    for (int j = 0; j < g.ny; ++j) {
      for (int i = 0; i < g.nx; ++i) {
        int a = -1, b = -1, c = -1;
        ASSERT_TRUE(g.locate(g.center(i, j, k), &a, &b, &c));
        EXPECT_EQ(a, i);
        EXPECT_EQ(b, j);
        EXPECT_EQ(c, k);
      }
    }
  }
  int a, b, c;
  EXPECT_FALSE(g.locate({1.0, 0, 0.1}, &a, &b, &c));  // the max face is outside
  EXPECT_FALSE(g.locate({0, 0, -0.01}, &a, &b, &c));
}

TEST(RigVoxelGrid, CoveringContainsTheBoxAndIsCentred) {
  const VoxelGrid g = VoxelGrid::covering({-1.25, -1.25, 0}, {1.25, 1.25, 2.2}, 0.02);
  ASSERT_TRUE(g.valid(nullptr));
  EXPECT_EQ(g.nx, 125);
  EXPECT_EQ(g.ny, 125);
  EXPECT_EQ(g.nz, 110);
  EXPECT_NEAR(g.min_m[0], -1.25, 1e-12);
  EXPECT_NEAR(g.min_m[2], 0.0, 1e-12);
  const VoxelGrid h = VoxelGrid::covering({0, 0, 0}, {1.0, 0.5, 0.3}, 0.3);
  EXPECT_EQ(h.nx, 4);
  EXPECT_LE(h.min_m[0], 0.0);
  EXPECT_GE(h.max_m()[0], 1.0);
  EXPECT_NEAR(h.min_m[0] + h.max_m()[0], 1.0, 1e-12);
}

TEST(RigVoxelGrid, BitHelpersAreLsbFirst) {
  std::vector<std::uint8_t> bits(2, 0);
  hull_set(bits.data(), 0);
  hull_set(bits.data(), 9);
  EXPECT_EQ(bits[0], 0x01);
  EXPECT_EQ(bits[1], 0x02);
  EXPECT_TRUE(hull_bit(bits.data(), 9));
  EXPECT_FALSE(hull_bit(bits.data(), 8));
}

TEST(RigVoxelGrid, ValidRejectsBadGrids) {
  std::string why;
  VoxelGrid g = small_grid();
  g.voxel_m = 0;
  EXPECT_FALSE(g.valid(&why));
  EXPECT_NE(why.find("voxel_m"), std::string::npos);
  g = small_grid();
  g.nz = 0;
  EXPECT_FALSE(g.valid(&why));
  EXPECT_NE(why.find("dimensions"), std::string::npos);
  g = small_grid();
  g.nx = g.ny = g.nz = 4000;
  EXPECT_FALSE(g.valid(&why));
  EXPECT_NE(why.find("too many"), std::string::npos);
}

}  // namespace
}  // namespace vc::rig
