// `voxcap export` end to end on a recorded session whose poses are the virtual rig's true joints: the
// BVH read back with hw/body equals joints.csv within 1 mm (metres and centimetres), frame numbers,
// frame time and what is left out are as documented, and bad input is refused.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include <glm/geometric.hpp>

#include "truth_session.hpp"
#include "voxcap/body/bvh.hpp"

namespace vc::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

struct Tmp {
  fs::path p;
  Tmp() {
    char t[] = "/tmp/voxcap-export-cli-XXXXXX";
    p = mkdtemp(t);
  }
  ~Tmp() {
    std::error_code ec;
    fs::remove_all(p, ec);
  }
};

std::string voxcap() {
  return std::string("'") + VOXCAP_BINARY + "'";
}

TEST(ExportCli, BvhAndCsvOfARecordedSessionAgreeAndFollowItsFrames) {
  Tmp tmp;
  TruthSessionOptions o;
  o.no_pose = {40, 41};
  write_truth_session(tmp.p / "s", o);
  const CommandResult r =
      run(voxcap() + " export '" + (tmp.p / "s").string() + "' --bvh '" + (tmp.p / "take.bvh").string() +
              "' --csv '" + (tmp.p / "joints.csv").string() + "'",
          tmp.p);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("5 frames before the first pose (initialization) left out"));
  EXPECT_THAT(r.err,
              HasSubstr("2 frames without a pose (0 of them not recorded at all) hold the previous pose"));
  EXPECT_THAT(r.out, HasSubstr("115 frames (5 .. 119), frame time 0.020000 s (rig.toml)"));

  const JointsCsv csv = read_joints_csv(tmp.p / "joints.csv");
  EXPECT_EQ(csv.header, "frame,joint,x,y,z,state,fitted");
  EXPECT_EQ(csv.p.size(), 113u);  // 5 .. 119 less 40, 41
  EXPECT_EQ(csv.rows, 113u * 18u);
  EXPECT_EQ(csv.p.begin()->first, 5) << "frame = seq - the session's first seq";
  EXPECT_EQ(csv.p.count(40), 0u);
  // The fitted joints are the truth they were recorded from (the take's chest pivots at the hips, the
  // truth's 17 cm higher: a few centimetres at most where the performer bends).
  for (int f : {5, 60, 119})
    for (const auto& [bvh, std_name] : std::map<std::string, std::string>{
             {"Hips", "hips"}, {"LeftHand", "l_wrist"}, {"RightHand", "r_wrist"}, {"LeftFoot", "l_ankle"}})
      EXPECT_LT(glm::length(csv.p.at(f).at(bvh) - true_joint("wave", 50, f, std_name)), 0.03)
          << f << " " << bvh;

  for (const char* units : {"m", "cm"}) {
    SCOPED_TRACE(units);
    const double scale = std::string(units) == "cm" ? 100 : 1;
    const CommandResult u = run(voxcap() + " export '" + (tmp.p / "s").string() + "' --units " + units +
                                    " --bvh '" + (tmp.p / "u.bvh").string() + "'",
                                tmp.p);
    ASSERT_EQ(u.code, 0) << u.err;
    const body::BvhClip clip = body::read_bvh((tmp.p / "u.bvh").string());
    ASSERT_EQ(clip.frames, 115);
    EXPECT_NEAR(clip.frame_time_s, 0.02, 1e-9);
    const body::Skeleton sk = clip.scaled_skeleton(1 / scale);
    double worst = 0;
    for (int k = 0; k < clip.frames; ++k) {
      if (!csv.p.count(5 + k)) continue;
      std::vector<glm::dvec3> p;
      body::forward_kinematics(sk, clip.pose(k, 1 / scale), &p);
      for (size_t j = 0; j < sk.joints.size(); ++j) {
        if (sk.joints[j].end_site) continue;
        const glm::dvec3 world(p[j].x, -p[j].z, p[j].y);
        worst = std::max(worst, glm::length(world - csv.p.at(5 + k).at(sk.joints[j].name)));
      }
    }
    EXPECT_LT(worst, 1e-3);
  }
}

TEST(ExportCli, BadInputAndSessionsWithoutPoses) {
  Tmp tmp;
  EXPECT_EQ(run(voxcap() + " export '" + tmp.p.string() + "' --bvh x.bvh", tmp.p).code, 2);  // not a session
  TruthSessionOptions o;
  o.frames = 10;
  o.init_frames = 10;  // never a pose
  write_truth_session(tmp.p / "s", o);
  const std::string s = "'" + (tmp.p / "s").string() + "'";
  EXPECT_EQ(run(voxcap() + " export " + s, tmp.p).code, 2);  // neither --bvh nor --csv
  EXPECT_EQ(run(voxcap() + " export " + s + " --bvh a.bvh --units inch", tmp.p).code, 2);
  const CommandResult r =
      run(voxcap() + " export " + s + " --csv '" + (tmp.p / "j.csv").string() + "'", tmp.p);
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, HasSubstr("has no fitted poses (10 frames, 10 pose records)"));
  EXPECT_FALSE(fs::exists(tmp.p / "j.csv"));
}

}  // namespace
}  // namespace vc::testing
