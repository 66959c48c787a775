// `voxcap eval`, `voxcap demo` and `voxcap fit` end to end on the emulated rig (real edge processes on
// loopback, the host with triangulation and the fit stage): eval's JSON has the documented keys and
// every frame from the first pose on has one; demo writes take.bvh, joints.csv with the virtual rig's
// frame numbers, and the session; re-fitting that session offline with the same parameters gives the
// same poses, and with others a new pose stream that voxcap export reads; `voxcap fit --score` scores the
// session offline against the virtual rig's truth with the live run's figures.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "voxcap/body/bvh.hpp"
#include "voxcap/body/joints.hpp"
#include "voxcap/sim/scene.hpp"

namespace {

namespace fs = std::filesystem;

struct Out {
  int code = -1;
  std::string out, err;
};

Out voxcap(const std::string& args, const fs::path& scratch) {
  const fs::path o = scratch / "out.txt", e = scratch / "err.txt";
  const int st = std::system(
      (std::string("'") + VOXCAP_BINARY + "' " + args + " >'" + o.string() + "' 2>'" + e.string() + "'")
          .c_str());
  auto slurp = [](const fs::path& p) {
    std::ifstream f(p);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
  };
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, slurp(o), slurp(e)};
}

// The end of `voxcap fit --score`'s swaps line.
std::string fmt_flips(uint64_t flips, uint64_t reinit) {
  return "the feet turned the torso round " + std::to_string(flips) + " times (heading_flips), " +
         std::to_string(reinit) + " frames re-initialized (reinitialized_frames)";
}

struct Tmp {
  fs::path p;
  Tmp() {
    char t[] = "/tmp/voxcap-demo-test-XXXXXX";
    p = mkdtemp(t);
  }
  ~Tmp() {
    std::error_code ec;
    fs::remove_all(p, ec);
  }
};

TEST(Eval, JsonHasTheFiguresAndEveryFrameFromTheFirstPoseOnHasOne) {
  Tmp tmp;
  const Out r = voxcap("eval --motion wave --frames 150 --nodes 3 --grid 96 --json", tmp.p);
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  for (const char* key :
       {"mpjpe_mm", "per_joint_mm", "pa_mpjpe_mm", "frames", "fitted_frames", "fps", "latency_ms",
        "arm_in_torso_frames", "frames_outside_volume", "init_frames", "scored_frames"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_TRUE(j["latency_ms"].contains("p50"));
  EXPECT_TRUE(j["latency_ms"].contains("p99"));
  EXPECT_EQ(j["per_joint_mm"].size(), 15u);
  EXPECT_TRUE(j["per_joint_mm"].contains("l_wrist"));
  EXPECT_GT(j["frames"].get<int>(), 20);  // the fitter initializes on the first frames of the init pose
  EXPECT_EQ(j["fitted_frames"], j["frames"]);
  EXPECT_GT(j["scored_frames"].get<int>(), 0);
  EXPECT_GT(j["mpjpe_mm"].get<double>(), 0.0);
  // No accuracy bound here: under sanitizers on a loaded machine the fit falls behind the rig (its figures
  // are the release build's, tests/bench); this test checks the figures and that no frame lost its pose.
  EXPECT_GT(j["pa_mpjpe_mm"].get<double>(), 0.0);  // a mean of distances: it may exceed mpjpe_mm
  EXPECT_GT(j["latency_ms"]["p99"].get<double>(), 0.0);
}

TEST(Demo, WritesTheTakeWithTheVirtualRigsFrameNumbersAndFitReFitsItsSession) {
  Tmp tmp;
  const fs::path out = tmp.p / "demo";
  // 320x240, as the other rig tests run under the sanitizers: at the demo's 640x480 a loaded 2-core
  // machine (load 20) merged about a third of the pulses, each frame from one node only (degraded at the
  // deadline), so the fit predicted 136 of 139 poses 1.2 m off and the numbering check below was left to
  // chance. 240 frames: without an init pose the fit starts after 120 (host/fit "Initialization"), and
  // the poses must come from the run, not from the frames merged while the edges stop.
  const Out r = voxcap(
      "demo --motion wave --frames 240 --nodes 3 --size 320x240 --grid 96 --out '" + out.string() + "'",
      tmp.p);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("MPJPE"));
  EXPECT_THAT(r.out, ::testing::HasSubstr("trigger -> pose p50"));
  ASSERT_TRUE(fs::exists(out / "take.bvh"));
  ASSERT_TRUE(fs::exists(out / "joints.csv"));
  fs::path session;
  for (const auto& e : fs::directory_iterator(out))
    if (e.is_directory() && fs::exists(e.path() / "records.vcr")) session = e.path();
  ASSERT_FALSE(session.empty()) << "the session folder";
  {
    // The run summary counts what the session holds (#13): its frames are the frames merged once the
    // host stopped and the recording was drained and closed, not a count taken before the pipeline
    // drained ("607 frames (of 600 merged)").
    const std::string head = "session   " + session.string() + ": ";
    const size_t at = r.out.find(head);
    ASSERT_NE(at, std::string::npos) << "no session line in:\n" << r.out;
    const std::string line = r.out.substr(at, r.out.find('\n', at) - at);
    unsigned long long frames = 0, merged = 0;
    ASSERT_EQ(std::sscanf(line.c_str() + head.size(), "%llu frames (of %llu merged)", &frames, &merged), 2)
        << line;
    EXPECT_EQ(frames, merged) << line;
    EXPECT_GT(frames, 100u) << line;
    EXPECT_THAT(line, ::testing::HasSubstr("closed cleanly"));
    EXPECT_THAT(line, ::testing::Not(::testing::HasSubstr("skipped")));
  }

  // joints.csv frame f is the virtual rig's frame f: the fitted wrists there are near the true wrists of
  // frame f (the same motion rendered by hw/sim), nearer than those of frames a third of a second away.
  vc::sim::SceneOptions so;
  so.motion.source = "wave";
  so.motion.fps = 60;
  const vc::sim::Scene scene(so);
  std::ifstream csv(out / "joints.csv");
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "frame,joint,x,y,z,state,fitted");
  // The wrist's error against the truth of its own frame number beats the error against frames a third
  // of a second earlier or later (wave moves the arm): the numbering is the virtual rig's. Judged on
  // the Fitted rows (every feature in: the fit's own answer, not a prediction through a lost feature)
  // by the median, so that a stretch of frames the loaded rig got wrong does not decide it, and on
  // enough of them for the median to mean something.
  std::vector<double> err0, err_early, err_late;
  std::set<int> fitted_frames, csv_frames;
  while (std::getline(csv, line)) {
    std::stringstream ss(line);
    std::string f, joint, x, y, z, state;
    std::getline(ss, f, ',');
    std::getline(ss, joint, ',');
    std::getline(ss, x, ',');
    std::getline(ss, y, ',');
    std::getline(ss, z, ',');
    std::getline(ss, state, ',');
    const int frame = std::stoi(f);
    ASSERT_GE(frame, 0);
    csv_frames.insert(frame);
    if (joint != "LeftHand" && joint != "RightHand") continue;
    if (state != "fitted" || frame < 20) continue;
    const cv::Vec3d p(std::stod(x), std::stod(y), std::stod(z));
    const auto j =
        static_cast<size_t>(joint == "LeftHand" ? vc::body::Joint::l_wrist : vc::body::Joint::r_wrist);
    err0.push_back(cv::norm(p - scene.joints(frame)[j]));
    err_early.push_back(cv::norm(p - scene.joints(frame - 20)[j]));
    err_late.push_back(cv::norm(p - scene.joints(frame + 20)[j]));
    fitted_frames.insert(frame);
  }
  // Measured 101 Fitted frames of 260 posed with the machine at load 15-20 (median wrist error 11 mm at
  // its own frame, 36 and 29 mm at 20 frames before and after). Three of these tests at once on the
  // loaded 2-core machine left 1-8: every frame merged from one node at the deadline, the init pose not
  // seen, the poses predictions 0.2-1.1 m off, which can tell no frame from another; then only the
  // numbering's plumbing is checked (below, against the session), and the test says so.
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  if (fitted_frames.size() >= 30u) {
    EXPECT_LT(median(err0), median(err_early));
    EXPECT_LT(median(err0), median(err_late));
  } else {
    std::printf(
        "[   NOTE   ] %zu Fitted frames (< 30): the rig was too loaded to judge the numbering by the "
        "wrists\n",
        fitted_frames.size());
  }
  const vc::body::BvhClip clip = vc::body::read_bvh((out / "take.bvh").string());
  EXPECT_NEAR(clip.frame_time_s, 1.0 / 60, 1e-7);
  EXPECT_EQ(clip.skeleton.joints[0].name, "Hips");

  // Re-fit offline with the same parameters: the same poses as live. With others: a new pose stream.
  const fs::path same = tmp.p / "same", other = tmp.p / "other";
  Out f = voxcap("fit '" + session.string() + "' --out '" + same.string() + "'", tmp.p);
  ASSERT_EQ(f.code, 0) << f.err;
  auto poses = [&](const fs::path& s) {
    const Out d = voxcap("session dump --type pose --json '" + s.string() + "'", tmp.p);
    std::vector<nlohmann::json> v;
    std::stringstream ss(d.out);
    std::string l;
    while (std::getline(ss, l)) v.push_back(nlohmann::json::parse(l));
    return v;
  };
  const auto live = poses(session), refit = poses(same);
  ASSERT_EQ(live.size(), refit.size());
  ASSERT_GT(live.size(), 100u);
  {
    // joints.csv's frames are the session's posed seqs less the run's origin (virtual_rig.json): the
    // frame the virtual rig rendered for that seq.
    const uint64_t origin =
        nlohmann::json::parse(std::ifstream(session / "virtual_rig.json"))["origin"].get<uint64_t>();
    std::set<int> posed;
    for (const auto& p : live)
      if (p["state"] != "none") posed.insert(static_cast<int>(p["seq"].get<uint64_t>() - origin));
    EXPECT_EQ(posed, csv_frames);
  }
  for (size_t i = 0; i < live.size(); ++i) {
    EXPECT_EQ(live[i]["seq"], refit[i]["seq"]);
    EXPECT_EQ(live[i]["state"], refit[i]["state"]) << i;
    EXPECT_EQ(live[i]["p_world_m"], refit[i]["p_world_m"]) << i;
  }
  f = voxcap("fit '" + session.string() + "' --steps 9 --span-deg 30 --smoothing one-euro --out '" +
                 other.string() + "'",
             tmp.p);
  ASSERT_EQ(f.code, 0) << f.err;
  EXPECT_THAT(f.out, ::testing::HasSubstr("frames re-fitted"));
  const Out e = voxcap("export '" + other.string() + "' --bvh '" + (tmp.p / "o.bvh").string() + "'", tmp.p);
  EXPECT_EQ(e.code, 0) << e.err;
  EXPECT_EQ(
      voxcap("fit '" + session.string() + "' --steps 0 --out '" + (tmp.p / "bad").string() + "'", tmp.p).code,
      2);

  // Scored offline against the virtual rig's truth (virtual_rig.json): the same parameters give the live
  // run's poses, so the live run's accuracy figures, with eval's keys.
  ASSERT_TRUE(fs::exists(session / "virtual_rig.json"));
  const nlohmann::json vr = nlohmann::json::parse(std::ifstream(session / "virtual_rig.json"));
  EXPECT_EQ(vr["motion"], "wave");
  EXPECT_EQ(vr["frames"], 240);
  const Out sc = voxcap("fit '" + session.string() + "' --score --json", tmp.p);
  ASSERT_EQ(sc.code, 0) << sc.err;
  const nlohmann::json js = nlohmann::json::parse(sc.out);
  const nlohmann::json& lv = vr["live"];
  for (const char* key :
       {"mpjpe_mm", "per_joint_mm", "pa_mpjpe_mm", "frames", "fitted_frames", "fps", "latency_ms",
        "arm_in_torso_frames", "frames_outside_volume", "init_frames", "scored_frames", "fit_stage_ms",
        "live", "reinitialized_frames", "heading_flips", "lr_swap_frames", "fit_pair_swaps"})
    EXPECT_TRUE(js.contains(key)) << key;
  EXPECT_EQ(js["offline"], true);
  // The fit's own corrections: re-initializations (the same poses: the live run's count) and how often
  // the feet turned the torso round (Fitter::heading_flips), also on the text's swaps line.
  EXPECT_EQ(js["reinitialized_frames"], lv["reinitialized_frames"]);
  EXPECT_TRUE(js["heading_flips"].is_number_unsigned()) << js["heading_flips"];
  const Out st = voxcap("fit '" + session.string() + "' --score", tmp.p);
  ASSERT_EQ(st.code, 0) << st.err;
  EXPECT_THAT(st.out, ::testing::HasSubstr(fmt_flips(js["heading_flips"].get<uint64_t>(),
                                                     js["reinitialized_frames"].get<uint64_t>())))
      << st.out;
  EXPECT_EQ(js["frames"], lv["frames"]);
  EXPECT_EQ(js["fitted_frames"], lv["fitted_frames"]);
  EXPECT_EQ(js["scored_frames"], lv["scored_frames"]);
  EXPECT_EQ(js["arm_in_torso_frames"], lv["arm_in_torso_frames"]);
  EXPECT_NEAR(js["mpjpe_mm"].get<double>(), lv["mpjpe_mm"].get<double>(), 1e-6);
  EXPECT_NEAR(js["pa_mpjpe_mm"].get<double>(), lv["pa_mpjpe_mm"].get<double>(), 1e-6);
  EXPECT_NEAR(js["per_joint_mm"]["r_wrist"].get<double>(), lv["per_joint_mm"]["r_wrist"].get<double>(), 1e-6);
  // Other parameters: other poses, scored too; a session without virtual_rig.json cannot be scored.
  const Out sc2 = voxcap("fit '" + session.string() + "' --steps 9 --score --json", tmp.p);
  ASSERT_EQ(sc2.code, 0) << sc2.err;
  EXPECT_EQ(nlohmann::json::parse(sc2.out)["fitted_frames"], lv["fitted_frames"]);
  const Out bad = voxcap("fit '" + same.string() + "' --score", tmp.p);
  EXPECT_EQ(bad.code, 2);
  EXPECT_THAT(bad.err, ::testing::HasSubstr("virtual_rig.json"));
}

}  // namespace
