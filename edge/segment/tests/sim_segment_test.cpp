// edge/segment against the virtual rig's truth (hw/sim): the initialization frame seen by every
// camera of rigs of 4, 6 and 8 cameras, for every appearance preset, in the default and the
// camouflage room, with the true silhouettes and with the edge's own masks (edge/core's subtraction
// and clean-up; sim_views.hpp). The rule of a correct label is sim_views.hpp's score(): within 8 % of
// the body's height of the true 2D feature and nearer it than any other feature, a hidden one
// not_visible or where it is; left/right by image side (the host agrees them by triangulating).
// bin/edge_segment_survey prints the same per camera (README's figures).
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "sim_views.hpp"
#include "voxcap/edge/segment.hpp"
#include "voxcap/sim/body.hpp"
#include "voxcap/sim/scene.hpp"

namespace vc::segment {
namespace {

struct Score {
  int ok = 0, all_correct = 0, cameras = 0, wrong = 0;
  std::vector<double> errors;  // visible features of the cameras that segmented
};

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Scores every camera's mask (edge or true). `all_right`: every terminal of every camera labelled
// correctly; otherwise the cameras with a wrong label are counted (Score::wrong), and one that
// refuses must say why.
Score check(const std::vector<testing::View>& views, bool edge, bool all_right, const std::string& what) {
  Score sc;
  for (const testing::View& v : views) {
    const Segmentation s = segment(edge ? v.edge_mask : v.truth_mask);
    const testing::CameraScore c = testing::score(s, v);
    sc.cameras++;
    sc.ok += s.ok;
    sc.all_correct += c.all_correct();
    if (!s.ok) EXPECT_FALSE(s.why.empty()) << what << " cam " << v.camera;
    if (all_right) EXPECT_TRUE(s.ok) << what << " cam " << v.camera << ": " << s.why;
    bool wrong = false;
    for (size_t f = 0; f < kFeatures; f++) {
      const testing::TerminalScore& t = c.t[f];
      if (all_right)
        EXPECT_TRUE(t.correct) << what << " cam " << v.camera << " " << feature_name(static_cast<int>(f))
                               << (t.labelled
                                       ? " labelled " + std::to_string(t.error_px) + " px from its truth"
                                       : std::string(" not labelled"));
      wrong = wrong || (t.labelled && !t.correct);
      if (t.labelled && t.visible) sc.errors.push_back(t.error_px);
    }
    sc.wrong += wrong;
  }
  return sc;
}

// (cameras, appearance, room)
class Presets : public ::testing::TestWithParam<std::tuple<int, std::string, std::string>> {};

// Every camera of every rig size, every preset, both rooms: with the true silhouettes all five
// terminals right everywhere (incl. the two cameras of the 8-camera rig that look along the arms:
// a foreshortened arm's hand is its extremity; the far hand seen above the shoulder is found in the
// head's blob). With the edge's masks all five right on every camera but at most one per rig,
// preset and room, no wrong label with 4 and 6 cameras, at most one with 8 (measured over the 36 cases:
// refusals where the mask lost a part, dark's legs in a side view of 6 cameras and an arm in a side
// view of 8 in beige; one wrong hand, a sliver of the broken neck of olive in the camouflage room
// seen by a side camera of 8; README.md).
TEST_P(Presets, InitFrameEveryCamera) {
  const auto& [cameras, appearance, room] = GetParam();
  const std::string what = std::to_string(cameras) + " cameras, " + appearance + ", " + room;
  const sim::Scene scene(testing::init_scene(cameras, appearance, room));
  const testing::EdgeMasks edge(scene);
  const std::vector<testing::View> views = testing::views(scene, 0, &edge);
  const Score truth = check(views, false, true, what + ", true masks");
  EXPECT_EQ(truth.all_correct, truth.cameras) << what;
  EXPECT_LT(median(truth.errors), 3.5) << what;  // measured 1.8 .. 2.8 px at 640x480
  const Score mine = check(views, true, false, what + ", edge masks");
  EXPECT_GE(mine.all_correct, mine.cameras - 1) << what;
  // 4 and 6 cameras (what this test held before, every camera that segmented right): no wrong label.
  EXPECT_LE(mine.wrong, cameras == 8 ? 1 : 0) << what;
  EXPECT_LT(median(mine.errors), 4.5) << what;  // measured 2.4 .. 3.5 px
}

std::vector<std::tuple<int, std::string, std::string>> presets() {
  std::vector<std::tuple<int, std::string, std::string>> p;
  for (int cameras : {4, 6, 8})
    for (const std::string room : {"default", "camouflage"})
      for (const sim::Appearance& a : sim::appearance_presets()) p.emplace_back(cameras, a.name, room);
  return p;
}

INSTANTIATE_TEST_SUITE_P(SimSegment, Presets, ::testing::ValuesIn(presets()), [](const auto& info) {
  return std::to_string(std::get<0>(info.param)) + "cams_" + std::get<1>(info.param) + "_" +
         std::get<2>(info.param);
});

// Rigs of 4, 6 and 8 cameras, true silhouettes of the default performer: every camera segments
// (before: 6 of 8 with 8 cameras) and every visible feature is within 8 % of the height.
TEST(SimSegment, RigsOf4_6_8Cameras) {
  for (int cameras : {4, 6, 8}) {
    const std::string what = std::to_string(cameras) + " cameras";
    const sim::Scene scene(testing::init_scene(cameras, "default", "default"));
    const Score sc = check(testing::views(scene, 0, nullptr), false, true, what);
    EXPECT_EQ(sc.ok, cameras) << what;
    EXPECT_LT(median(sc.errors), 3.0) << what;  // measured 1.9 .. 2.5 px at 640x480
  }
}

// A later initialization frame (other sensor noise) on the edge's masks: the same labels.
TEST(SimSegment, EdgeMasksOfALaterInitFrame) {
  const sim::Scene scene(testing::init_scene(6, "beige", "default"));
  const testing::EdgeMasks edge(scene);
  const Score sc = check(testing::views(scene, 30, &edge), true, true, "beige frame 30");
  EXPECT_EQ(sc.all_correct, 6);
}

// 320x240: the body is ~110 px high, arms ~4 px wide.
TEST(SimSegment, SmallImages) {
  const sim::Scene scene(testing::init_scene(6, "default", "default", 320, 240));
  const std::vector<testing::View> views = testing::views(scene, 0, nullptr);
  int ok = 0;
  for (const testing::View& v : views) {
    const Segmentation s = segment(v.truth_mask);
    if (!s.ok) continue;
    ok++;
    const testing::CameraScore c = testing::score(s, v, 0.12);
    for (size_t f = 0; f < kFeatures; f++)
      EXPECT_TRUE(c.t[f].correct) << "320x240 cam " << v.camera << " " << feature_name(static_cast<int>(f));
  }
  EXPECT_GE(ok, 4);
}

}  // namespace
}  // namespace vc::segment
