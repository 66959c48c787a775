// The BVH writer: a hand-checked small file (exact text, axes, units), the standard skeleton
// exported with Blender's axes and MotionBuilder names (read back and mapped by name), and a
// write -> read round trip of every real clip of the shared data folder (listed): joint world
// positions equal within 1e-6 m on every frame.
#include <filesystem>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "voxcap/body/bvh.hpp"
#include "voxcap/body/humanoid.hpp"
#include "voxcap/body/joints.hpp"
#include "voxcap/body/testing/shared_clips.hpp"

namespace vc::body {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

double deg(double d) {
  return d * M_PI / 180.0;
}

TEST(BodyBvhWriter, HandCheckedSmallFileWithBlenderAxes) {
  Skeleton sk;
  sk.joints = {
      {"hips", -1, {0, 0, 0}, false}, {"chest", 0, {0, 0, 0.5}, false}, {"tip", 1, {0.25, 0, 0}, true}};
  std::vector<Pose> poses(2, rest_pose(sk));
  poses[0].root_position = {1, 2, 3};
  poses[1].root_position = {0, 0, 1};
  poses[1].local[0] = rot_z(deg(30));  // turned 30 degrees about the world's up axis
  poses[1].local[1] = rot_x(deg(90));
  BvhWriteOptions o = BvhWriteOptions::blender();
  o.standard_names = false;
  o.decimals = 3;
  // Worked by hand: the file is Y up, p_file = (x, z, -y); a turn about world z is a turn about
  // file Y; Rx(90) stays about X; ZYX Euler angles are (Z, Y, X) = (a, b, c) with R = Rz Ry Rx.
  const std::string want =
      "HIERARCHY\n"
      "ROOT hips\n"
      "{\n"
      "\tOFFSET 0.000 0.000 0.000\n"
      "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"
      "\tJOINT chest\n"
      "\t{\n"
      "\t\tOFFSET 0.000 0.500 0.000\n"
      "\t\tCHANNELS 3 Zrotation Yrotation Xrotation\n"
      "\t\tEnd Site\n"
      "\t\t{\n"
      "\t\t\tOFFSET 0.250 0.000 0.000\n"
      "\t\t}\n"
      "\t}\n"
      "}\n"
      "MOTION\n"
      "Frames: 2\n"
      "Frame Time: 0.033333333\n"
      "1.000 3.000 -2.000 0.000 0.000 0.000 0.000 0.000 0.000\n"
      "0.000 1.000 0.000 0.000 30.000 0.000 0.000 0.000 90.000\n";
  const std::string text = format_bvh(sk, poses, 1.0 / 30, o);
  EXPECT_EQ(text, want);
  // Read back: the file's own kinematics, turned back to the world, is the world's. Frame 1's tip
  // by hand: root (0, 0, 1), chest 0.5 above, tip 0.25 along x turned 30 degrees about z.
  const BvhClip c = parse_bvh(text, "hand");
  std::vector<glm::dvec3> p;
  forward_kinematics(c.skeleton, c.pose(1), &p);
  const glm::dmat3 world_from_file = glm::transpose(o.R_file_from_world);
  const glm::dvec3 tip = world_from_file * p[2];
  EXPECT_LT(glm::length(tip - glm::dvec3(0.25 * std::cos(deg(30)), 0.25 * std::sin(deg(30)), 1.5)), 1e-3);
  // Centimetres: offsets and positions 100 times larger, angles the same.
  o.units_per_metre = 100;
  const BvhClip cm = parse_bvh(format_bvh(sk, poses, 1.0 / 30, o), "cm");
  EXPECT_NEAR(cm.skeleton.joints[1].offset.y, 50.0, 1e-12);
  EXPECT_NEAR(cm.values[1], 300.0, 1e-12);
  EXPECT_NEAR(cm.values[9 + 4], 30.0, 1e-12);
}

TEST(BodyBvhWriter, RejectsWhatBvhCannotHold) {
  Skeleton sk;
  sk.joints = {{"hips", -1, {0, 0, 0}, false}, {"a", 0, {0, 0, 1}, false}};
  Pose p = rest_pose(sk);
  p.translation = {glm::dvec3(0), glm::dvec3(0, 0.1, 0)};
  EXPECT_THROW(format_bvh(sk, {p}, 0.01), std::invalid_argument);
  EXPECT_THROW(format_bvh(sk, {rest_pose(sk)}, 0.0), std::invalid_argument);
  BvhWriteOptions o;
  o.standard_names = true;  // not the standard skeleton
  EXPECT_THROW(format_bvh(sk, {rest_pose(sk)}, 0.01, o), std::invalid_argument);
  o = {};
  o.R_file_from_world = glm::dmat3(2.0);
  EXPECT_THROW(format_bvh(sk, {rest_pose(sk)}, 0.01, o), std::invalid_argument);
  o = {};
  o.units_per_metre = 0;
  EXPECT_THROW(format_bvh(sk, {rest_pose(sk)}, 0.01, o), std::invalid_argument);
  Skeleton end_with_child = sk;
  end_with_child.joints[1].end_site = true;
  end_with_child.joints.push_back({"c", 1, {0, 0, 1}, false});
  EXPECT_THROW(format_bvh(end_with_child, {rest_pose(end_with_child)}, 0.01), std::invalid_argument);
  Skeleton other = sk;
  other.joints.push_back({"b", 1, {0, 0, 1}, false});
  EXPECT_THROW(format_bvh(other, {rest_pose(sk)}, 0.01), std::invalid_argument);
  EXPECT_THROW(write_bvh("/nonexistent/dir/x.bvh", sk, {rest_pose(sk)}, 0.01), std::runtime_error);
}

TEST(BodyBvhWriter, StandardSkeletonForBlenderReadsBackByName) {
  const Skeleton sk = standard_skeleton({});
  std::vector<Pose> poses;
  for (int f = 0; f < 5; ++f) {
    Pose p = rest_pose(sk, {0.1 * f, -0.05 * f, 0.98});
    p.local[static_cast<std::size_t>(Joint::l_shoulder)] = rot_y(deg(60 + 5 * f));  // arm down
    p.local[static_cast<std::size_t>(Joint::r_elbow)] = rot_z(deg(-20 * f));
    p.local[static_cast<std::size_t>(Joint::l_knee)] = rot_x(deg(-10 * f));
    p.local[static_cast<std::size_t>(Joint::spine)] = rot_z(deg(3 * f)) * rot_x(deg(4));
    poses.push_back(p);
  }
  const BvhWriteOptions o = BvhWriteOptions::blender();
  const std::string text = format_bvh(sk, poses, 1.0 / 60, o);
  for (const char* name : {"ROOT Hips", "JOINT Spine", "JOINT Neck", "JOINT Head", "JOINT LeftArm",
                           "JOINT LeftForeArm", "JOINT LeftHand", "JOINT RightArm", "JOINT LeftUpLeg",
                           "JOINT LeftLeg", "JOINT LeftFoot", "JOINT LeftToeBase", "JOINT RightToeBase"}) {
    EXPECT_THAT(text, HasSubstr(name));
  }
  EXPECT_THAT(text, Not(HasSubstr("l_shoulder")));
  const BvhClip c = parse_bvh(text, "standard.bvh");
  // Joints by name: the standard ones under their export names, head_top and the hand tips as
  // End Sites ("<parent>_end" when read), plus the zero End Sites that close the toes.
  ASSERT_EQ(c.skeleton.joints.size(), sk.joints.size() + 2);
  std::vector<int> in_file(sk.joints.size());
  for (int j = 0; j < kJointCount; ++j) {
    const std::string name = joint_is_end(j) ? std::string(joint_bvh_name(joint_parent(j))) + "_end"
                                             : std::string(joint_bvh_name(j));
    in_file[static_cast<std::size_t>(j)] = c.skeleton.find(name);
    ASSERT_GE(in_file[static_cast<std::size_t>(j)], 0) << name;
  }
  // The file is Y up: its forward kinematics is R_file_from_world times the world's.
  double worst = 0;
  for (int f = 0; f < 5; ++f) {
    std::vector<glm::dvec3> a, b;
    forward_kinematics(sk, poses[static_cast<std::size_t>(f)], &a);
    forward_kinematics(c.skeleton, c.pose(f), &b);
    for (std::size_t j = 0; j < a.size(); ++j) {
      worst =
          std::max(worst, glm::length(o.R_file_from_world * a[j] - b[static_cast<std::size_t>(in_file[j])]));
    }
  }
  EXPECT_LT(worst, 1e-6);
  // Our own reader recognises every name, the units (metres) and the axes.
  const HumanoidClip h = map_humanoid(c, "standard.bvh");
  EXPECT_EQ(h.map.units, "m");
  EXPECT_DOUBLE_EQ(h.map.scale, 1.0);
  for (int j = 0; j < kJointCount; ++j) {
    if (joint_is_end(j)) continue;
    EXPECT_EQ(
        h.clip.skeleton.joints[static_cast<std::size_t>(h.map.anchor[static_cast<std::size_t>(j)])].name,
        joint_bvh_name(j));
  }
  const glm::dmat3 want = glm::transpose(o.R_file_from_world);
  for (int col = 0; col < 3; ++col) EXPECT_LT(glm::length(h.map.R_world_from_file[col] - want[col]), 1e-9);
}

TEST(BodyBvhWriter, EveryRealClipRoundTripsWithinAMicrometre) {
  const std::vector<fs::path> clips = testing::shared_bvh_clips();
  ASSERT_FALSE(clips.empty()) << testing::no_clips_message();
  const BvhWriteOptions o = BvhWriteOptions::blender();
  const BvhWriteOptions as_is;  // the file's own axes, metres
  for (const fs::path& path : clips) {
    SCOPED_TRACE(path.string());
    const HumanoidClip h = read_humanoid(path.string());
    std::vector<Pose> poses;
    for (int f = h.map.first_frame; f < h.map.frames; ++f) poses.push_back(h.frame_pose(f));
    for (const BvhWriteOptions* opt : {&as_is, &o}) {
      BvhWriteOptions w = *opt;
      w.standard_names = false;
      const BvhClip back = parse_bvh(format_bvh(h.skeleton, poses, h.map.frame_time_s, w), "roundtrip");
      ASSERT_EQ(back.frames, static_cast<int>(poses.size()));
      ASSERT_EQ(back.skeleton.joints.size(), h.skeleton.joints.size());
      double worst = 0;
      std::vector<glm::dvec3> a, b;
      for (int f = 0; f < back.frames; ++f) {
        forward_kinematics(h.skeleton, poses[static_cast<std::size_t>(f)], &a);
        forward_kinematics(back.skeleton, back.pose(f), &b);
        for (std::size_t j = 0; j < a.size(); ++j)
          worst = std::max(worst, glm::length(w.R_file_from_world * a[j] - b[j]));
      }
      EXPECT_LT(worst, 1e-6) << "worst " << worst * 1e6 << " um";
      for (std::size_t j = 0; j < back.skeleton.joints.size(); ++j) {
        EXPECT_EQ(back.skeleton.joints[j].name, h.skeleton.joints[j].name);
      }
    }
  }
}

}  // namespace
}  // namespace vc::body
