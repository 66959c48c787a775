// The BVH reader: hierarchy, channels and frames of a hand-checked file, hostile input (bounded
// sizes, NaN/inf, truncation), and every real clip of the shared data folder (listed).
#include "voxcap/body/bvh.hpp"

#include <filesystem>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "voxcap/body/testing/shared_clips.hpp"

namespace vc::body {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
double norm(const glm::dvec3& v) {
  return glm::length(v);
}

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

TEST(BodyBvh, ParsesHierarchyChannelsAndFrames) {
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
  std::vector<glm::dvec3> p;
  forward_kinematics(c.skeleton, c.pose(0, 1.0), &p);
  EXPECT_LT(norm(p[0] - glm::dvec3(1, 2, 3)), 1e-12);
  EXPECT_LT(norm(p[2] - glm::dvec3(-1, 3, 3)), 1e-12);
  // Frame 1: root Xrotation 90, Spine Yrotation 90: root maps y -> z.
  forward_kinematics(c.scaled_skeleton(0.5), c.pose(1, 0.5), &p);
  EXPECT_LT(norm(p[0] - glm::dvec3(0.5, 1, 1.5)), 1e-12);
  EXPECT_LT(norm(p[1] - glm::dvec3(0.5, 1, 2.0)), 1e-12);
  EXPECT_LT(norm(p[2] - glm::dvec3(0.5, 1, 3.0)), 1e-12);
}

TEST(BodyBvh, HandlesCrlfAndRejectsMalformedInput) {
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

TEST(BodyBvh, RejectsNonFiniteAndOutOfRangeNumbers) {
  const std::string t = kSmall;
  const std::size_t at = t.find("1 2 3 0 0 0 90");
  for (const char* bad :
       {"nan", "NaN", "inf", "-inf", "infinity", "1e999", "-1e400", "0x10", "1.2.3", "--1"}) {
    std::string text = t;
    text.replace(at, 1, bad);
    EXPECT_THAT(error_of(text), AllOf(HasSubstr("t.bvh:19:"), HasSubstr("expected a number"))) << bad;
  }
  // Finite but absurd values (issue #13: 1e308 gave NaN ground truth): refused with the line.
  for (const char* huge : {"1e308", "-1e11", "12345678901"}) {
    std::string text = t;
    text.replace(at, 1, huge);
    EXPECT_THAT(error_of(text), AllOf(HasSubstr("t.bvh:19:"), HasSubstr("out of range"))) << huge;
  }
  std::string text = t;
  text.replace(text.find("OFFSET 0 1 0"), 12, "OFFSET 0 nan 0");
  EXPECT_THAT(error_of(text), HasSubstr("expected a number"));
  text = t;
  text.replace(text.find("Frame Time: .0083333"), 20, "Frame Time: inf");
  EXPECT_THAT(error_of(text), HasSubstr("expected a number"));
  text = t;
  text.replace(text.find("Frame Time: .0083333"), 20, "Frame Time: -1");
  EXPECT_THAT(error_of(text), HasSubstr("Frame Time"));
  text = t;
  text.replace(text.find("Frames: 2"), 9, "Frames: -2");
  EXPECT_THAT(error_of(text), HasSubstr("out of range"));
  text = t;
  text.replace(text.find("Frames: 2"), 9, "Frames: 99999999999999999999");
  EXPECT_THAT(error_of(text), HasSubstr("expected an integer"));
  text = t;
  text.replace(text.find("CHANNELS 3"), 10, "CHANNELS 7");
  EXPECT_THAT(error_of(text), HasSubstr("CHANNELS count"));
}

TEST(BodyBvh, BoundsNestingAndJointCount) {
  // Nesting deeper than 256 levels and more than kBvhMaxJoints joints are errors, not crashes.
  std::string deep = "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\n";
  for (int i = 0; i < 300; ++i) deep += "JOINT J\n{\nOFFSET 0 0 0\n";
  EXPECT_THAT(error_of(deep), HasSubstr("nested too deeply"));
  std::string wide = "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\n";
  for (int i = 0; i < kBvhMaxJoints + 1; ++i) wide += "End Site\n{\nOFFSET 0 0 0\n}\n";
  EXPECT_THAT(error_of(wide), HasSubstr("too many joints"));
  EXPECT_THAT(error_of("HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\n}\nROOT B\n"), HasSubstr("more than one ROOT"));
}

TEST(BodyBvh, WriteThenParseReproducesThePoses) {
  Skeleton sk;
  sk.joints = {{"hips", -1, {0, 0, 0}, false},
               {"spine", 0, {0, 0, 0.2}, false},
               {"arm", 1, {0.3, 0, 0.1}, false},
               {"tip", 2, {0.25, 0, 0}, true}};
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
    std::vector<glm::dvec3> a, b;
    forward_kinematics(sk, poses[static_cast<std::size_t>(f)], &a);
    forward_kinematics(c.skeleton, c.pose(f), &b);
    for (std::size_t j = 0; j < a.size(); ++j) EXPECT_LT(norm(a[j] - b[j]), 2e-6);
  }
}

TEST(BodyBvh, EveryClipInTheSharedDataParses) {
  const std::vector<fs::path> clips = testing::shared_bvh_clips();
  ASSERT_FALSE(clips.empty()) << testing::no_clips_message();
  for (const fs::path& path : clips) {
    SCOPED_TRACE(path.string());
    const BvhClip c = read_bvh(path.string());
    EXPECT_GE(c.skeleton.joints.size(), 20u);
    EXPECT_GT(c.frames, 100);
    EXPECT_EQ(c.values.size(),
              static_cast<std::size_t>(c.frames) * static_cast<std::size_t>(c.channel_count));
    EXPECT_GT(c.frame_time_s, 0.005);
    EXPECT_EQ(c.channels[0].size(), 6u);
  }
  // The listing finds every clip the folder's checksum list names (when it has one).
  const int listed = testing::checksummed_bvh_count();
  if (listed >= 0) {
    EXPECT_EQ(static_cast<int>(clips.size()), listed);
  }
  // Known layouts (data/README.md), looked up by file name in the listing: 31 joints + 7 End
  // Sites, 96 values per frame for CMU; the 3dsMax-friendly arms have Z X Y channels.
  const fs::path cmu_path = testing::find_clip(clips, "02_01.bvh");
  const fs::path jj_path = testing::find_clip(clips, "cmu1_jumping_jacks.bvh");
  ASSERT_FALSE(cmu_path.empty()) << "02_01.bvh (data/README.md) is not in the listing";
  ASSERT_FALSE(jj_path.empty()) << "cmu1_jumping_jacks.bvh (data/README.md) is not in the listing";
  const BvhClip cmu = read_bvh(cmu_path.string());
  EXPECT_EQ(cmu.channel_count, 96);
  EXPECT_EQ(cmu.frames, 344);
  EXPECT_EQ(cmu.skeleton.joints.size(), 38u);
  const BvhClip jj = read_bvh(jj_path.string());
  const int ls = jj.skeleton.find("LeftShoulder");
  ASSERT_GE(ls, 0);
  EXPECT_EQ(jj.channels[static_cast<std::size_t>(ls)][1], BvhChannel::Xrotation);
}

}  // namespace
}  // namespace vc::body
