#include "voxcap/sim/bvh.hpp"

#include <filesystem>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace vc::sim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const char* kSmall = R"(HIERARCHY
ROOT Hips
{
	OFFSET 0 0 0
	CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
	JOINT Spine
	{
		OFFSET 0 1 0
		CHANNELS 3 Zrotation Xrotation Yrotation
		End Site
		{
			OFFSET 0 2 0
		}
	}
}
MOTION
Frames: 2
Frame Time: .0083333
1 2 3 0 0 0 90 0 0
1 2 3 0 0 90 0 0 90
)";

std::string error_of(const std::string& text) {
  try {
    (void)parse_bvh(text, "t.bvh");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "no error";
}

TEST(SimBvh, ParsesHierarchyChannelsAndFrames) {
  const BvhClip c = parse_bvh(kSmall, "small");
  ASSERT_EQ(c.skeleton.joints.size(), 3u);
  EXPECT_EQ(c.skeleton.joints[2].name, "Spine_end");
  EXPECT_TRUE(c.skeleton.joints[2].end_site);
  EXPECT_EQ(c.skeleton.joints[2].parent, 1);
  EXPECT_EQ(c.channel_count, 9);
  EXPECT_EQ(c.first_channel[1], 6);
  EXPECT_EQ(c.frames, 2);
  EXPECT_DOUBLE_EQ(c.frame_time_s, 0.0083333);
  EXPECT_EQ(c.frame_time_decimals, 7);
  EXPECT_EQ(c.channels[1][1], BvhChannel::Xrotation);
  // Frame 0: Spine Zrotation 90 -> its End Site offset (0,2,0) becomes (-2,0,0).
  std::vector<cv::Vec3d> p;
  forward_kinematics(c.skeleton, c.pose(0, 1.0), &p);
  EXPECT_LT(cv::norm(p[0] - cv::Vec3d(1, 2, 3)), 1e-12);
  EXPECT_LT(cv::norm(p[2] - cv::Vec3d(-1, 3, 3)), 1e-12);
  // Frame 1: root Xrotation 90, Spine Yrotation 90: root maps y -> z.
  forward_kinematics(c.scaled_skeleton(0.5), c.pose(1, 0.5), &p);
  EXPECT_LT(cv::norm(p[0] - cv::Vec3d(0.5, 1, 1.5)), 1e-12);
  EXPECT_LT(cv::norm(p[1] - cv::Vec3d(0.5, 1, 2.0)), 1e-12);
  EXPECT_LT(cv::norm(p[2] - cv::Vec3d(0.5, 1, 3.0)), 1e-12);
}

TEST(SimBvh, HandlesCrlfAndRejectsMalformedInput) {
  std::string crlf;
  for (char ch : std::string(kSmall)) {
    if (ch == '\n') crlf += '\r';
    crlf += ch;
  }
  EXPECT_EQ(parse_bvh(crlf).frames, 2);
  std::string t = kSmall;
  EXPECT_THAT(error_of(t.substr(0, t.find("MOTION"))), HasSubstr("unexpected end of file"));
  EXPECT_THAT(error_of(t.substr(0, t.size() - 10)), HasSubstr("larger than the file"));
  EXPECT_THAT(error_of(t + "7\n"), HasSubstr("more values"));
  std::string bad = t;
  bad.replace(bad.find("Yrotation Xrotation"), 9, "Wrotation");
  EXPECT_THAT(error_of(bad), HasSubstr("unknown channel"));
  bad = t;
  bad.replace(bad.find("1 2 3 0 0 0 90"), 1, "x");
  EXPECT_THAT(error_of(bad), AllOf(HasSubstr("t.bvh:19:"), HasSubstr("expected a number")));
  bad = t;
  bad.replace(bad.find("Frames: 2"), 9, "Frames: 9999999");
  EXPECT_THAT(error_of(bad), HasSubstr("larger than the file"));
  EXPECT_THAT(error_of("HIERARCHY\nROOT A\n{\nOFFSET 0 0\n"), HasSubstr("t.bvh:5: unexpected end of file"));
  EXPECT_THAT(error_of("HIERARCHY\nROOT A\n{\nOFFSET 0 0 zero\n"), HasSubstr("t.bvh:4: expected a number"));
  EXPECT_THAT(error_of(""), HasSubstr("unexpected end of file"));
  EXPECT_THROW(read_bvh("/nonexistent/x.bvh"), std::runtime_error);
}

TEST(SimBvh, WriteThenParseReproducesThePoses) {
  Skeleton sk;
  sk.joints = {{"hips", -1, {0, 0, 0}, false}, {"spine", 0, {0, 0, 0.2}, false},
               {"arm", 1, {0.3, 0, 0.1}, false}, {"tip", 2, {0.25, 0, 0}, true}};
  std::vector<Pose> poses;
  for (int f = 0; f < 4; ++f) {
    Pose p = rest_pose(sk, {0.1 * f, -0.2, 1.0});
    p.local[0] = rot_z(0.3 * f) * rot_x(0.1);
    p.local[1] = rot_axis({1, 2, 3}, 0.2 * f);
    p.local[2] = rot_y(-0.5 * f);
    poses.push_back(p);
  }
  const BvhClip c = parse_bvh(format_bvh(sk, poses, 1.0 / 60), "roundtrip");
  ASSERT_EQ(c.frames, 4);
  ASSERT_EQ(c.skeleton.joints.size(), sk.joints.size());
  EXPECT_NEAR(c.frame_time_s, 1.0 / 60, 1e-9);
  for (int f = 0; f < 4; ++f) {
    std::vector<cv::Vec3d> a, b;
    forward_kinematics(sk, poses[static_cast<std::size_t>(f)], &a);
    forward_kinematics(c.skeleton, c.pose(f), &b);
    for (std::size_t j = 0; j < a.size(); ++j) EXPECT_LT(cv::norm(a[j] - b[j]), 2e-6);
  }
}

TEST(SimBvh, EveryClipInTheSharedDataParses) {
  const fs::path dir = fs::path(VOXCAP_SHARED_DIR) / "data" / "mocap";
  if (!fs::is_directory(dir)) GTEST_SKIP() << "no BVH clips: " << dir << " is absent";
  int clips = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.path().extension() != ".bvh") continue;
    SCOPED_TRACE(entry.path().string());
    const BvhClip c = read_bvh(entry.path().string());
    ++clips;
    EXPECT_GE(c.skeleton.joints.size(), 20u);
    EXPECT_GT(c.frames, 100);
    EXPECT_EQ(c.values.size(), static_cast<std::size_t>(c.frames) * static_cast<std::size_t>(c.channel_count));
    EXPECT_GT(c.frame_time_s, 0.005);
    EXPECT_EQ(c.channels[0].size(), 6u);
  }
  EXPECT_EQ(clips, 13);
  // Known layouts (data/README.md): 31 joints + 7 End Sites, 96 values per frame for CMU; the
  // 3dsMax-friendly arms have Z X Y channels.
  const BvhClip cmu = read_bvh((dir / "cmu" / "02_01.bvh").string());
  EXPECT_EQ(cmu.channel_count, 96);
  EXPECT_EQ(cmu.frames, 344);
  EXPECT_EQ(cmu.skeleton.joints.size(), 38u);
  const BvhClip jj = read_bvh((dir / "animateddrawings" / "cmu1_jumping_jacks.bvh").string());
  const int ls = jj.skeleton.find("LeftShoulder");
  ASSERT_GE(ls, 0);
  EXPECT_EQ(jj.channels[static_cast<std::size_t>(ls)][1], BvhChannel::Xrotation);
}

}  // namespace
}  // namespace vc::sim
