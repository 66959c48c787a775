// edge/segment against known answers: stick figures drawn with cv::line/circle/ellipse in the
// initialization pose at several sizes (head centre, wrists and ankles known by construction), and
// hostile masks that must give ok == false with a reason, never a crash.
#include <cmath>
#include <cstdlib>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "voxcap/edge/segment.hpp"

namespace vc::segment {
namespace {

struct Figure {
  cv::Mat1b mask;
  std::array<cv::Point2f, kFeatures> truth;  // in the image: left = the image's right
};

// A stick figure of height h px standing in a w x hh image, arms spread, legs together or apart.
Figure stick_figure(int w, int hh, double h, bool legs_apart) {
  Figure f;
  f.mask = cv::Mat1b::zeros(hh, w);
  const double cx = w / 2.0, top = (hh - h) / 2.0;
  auto P = [&](double x, double y) { return cv::Point(cvRound(cx + x * h), cvRound(top + y * h)); };
  auto T = [&](double t) { return std::max(1, cvRound(t * h)); };
  const cv::Scalar on(255);
  cv::circle(f.mask, P(0, 0.07), T(0.065), on, cv::FILLED);              // head
  cv::line(f.mask, P(0, 0.12), P(0, 0.19), on, T(0.05));                 // neck
  cv::rectangle(f.mask, P(-0.09, 0.18), P(0.09, 0.56), on, cv::FILLED);  // torso
  for (int side : {-1, 1}) {
    cv::line(f.mask, P(side * 0.08, 0.205), P(side * 0.41, 0.205), on, T(0.045));  // arm
    cv::ellipse(f.mask, P(side * 0.45, 0.205), cv::Size(T(0.045), T(0.035)), 0, 0, 360, on,
                cv::FILLED);  // hand
    const double lx = side * (legs_apart ? 0.06 : 0.042);
    cv::line(f.mask, P(lx, 0.55), P(lx, 0.93), on, T(0.075));  // leg
    cv::ellipse(f.mask, P(lx + side * 0.015, 0.96), cv::Size(T(0.055), T(0.03)), 0, 0, 360, on,
                cv::FILLED);  // foot
  }
  auto F = [&](double x, double y) {
    return cv::Point2f(static_cast<float>(cx + x * h), static_cast<float>(top + y * h));
  };
  f.truth[kHead] = F(0, 0.07);
  f.truth[kLeftHand] = F(0.41, 0.205);
  f.truth[kRightHand] = F(-0.41, 0.205);
  const double lx = legs_apart ? 0.06 : 0.042;
  f.truth[kLeftFoot] = F(lx, 0.93);
  f.truth[kRightFoot] = F(-lx, 0.93);
  return f;
}

// With VC_SEGMENT_DEBUG_DIR set, the debug picture of a case goes there (to look at a failure).
void debug_png(const Segmentation& s, const std::string& name) {
  const char* dir = std::getenv("VC_SEGMENT_DEBUG_DIR");
  if (!dir) return;
  cv::Mat out;
  draw(s, cv::Mat(), &out);
  cv::imwrite(std::string(dir) + "/" + name + ".png", out);
}

class StickFigure : public ::testing::TestWithParam<std::tuple<int, bool>> {};

TEST_P(StickFigure, FiveTerminalsAtTheirJoints) {
  const auto [height, apart] = GetParam();
  const int w = height * 4 / 3 + 20, hh = height + 40;
  const Figure f = stick_figure(w, hh, height, apart);
  const Segmentation s = segment(f.mask);
  debug_png(s, "stick_" + std::to_string(height) + (apart ? "_apart" : "_together"));
  ASSERT_TRUE(s.ok) << s.why;
  // Within 4 % of the height: wrists and ankles are on a cut near the constriction, not at the
  // blob's centroid (a hand's centroid is 4 % of the height beyond the wrist).
  const double tol = std::max(2.0, 0.035 * height);
  for (int i = 0; i < kFeatures; i++) {
    const cv::Point2f d = s.point[static_cast<size_t>(i)] - f.truth[static_cast<size_t>(i)];
    EXPECT_LT(std::hypot(d.x, d.y), tol) << feature_name(i) << " at " << s.point[static_cast<size_t>(i)]
                                         << ", truth " << f.truth[static_cast<size_t>(i)];
    EXPECT_GE(s.terminal[static_cast<size_t>(i)], 0) << feature_name(i);
  }
  // The graph: head and hands are leaves (feet are found at the bottom: legs together make no
  // leaf of them); regions are ids; labels cover the silhouette (up to the smoothing of its outline).
  for (int i = kHead; i <= kRightHand; i++) {
    const Region& r = s.regions.at(static_cast<size_t>(s.terminal[static_cast<size_t>(i)]));
    EXPECT_EQ(r.neighbours.size(), 1U) << feature_name(i);
  }
  for (size_t i = 0; i < s.regions.size(); i++) EXPECT_EQ(s.regions[i].id, static_cast<int>(i));
  EXPECT_NEAR(cv::countNonZero(s.labels >= 0), cv::countNonZero(f.mask), 0.02 * cv::countNonZero(f.mask));
  EXPECT_FALSE(s.cuts.empty());
  EXPECT_EQ(s.critical.size() >= s.cuts.size(), true);
  EXPECT_GT(cv::countNonZero(s.gvd), 0);
}

INSTANTIATE_TEST_SUITE_P(Sizes, StickFigure,
                         ::testing::Combine(::testing::Values(220, 480), ::testing::Bool()));

TEST(Segment, HostileMasksGiveAReason) {
  struct Case {
    const char* name;
    cv::Mat1b mask;
  };
  std::vector<Case> cases;
  cases.push_back({"empty image", cv::Mat1b()});
  cases.push_back({"all background", cv::Mat1b::zeros(240, 320)});
  cases.push_back({"all foreground", cv::Mat1b(240, 320, uchar{255})});
  cv::Mat1b one = cv::Mat1b::zeros(240, 320);
  one(100, 100) = 255;
  cases.push_back({"one pixel", one});
  cv::Mat1b noise(240, 320);
  cv::randu(noise, 0, 256);
  noise = noise > 128;
  cases.push_back({"random noise", noise});
  cv::Mat1b blob = cv::Mat1b::zeros(240, 320);
  cv::circle(blob, {160, 120}, 60, cv::Scalar(255), cv::FILLED);
  cases.push_back({"a disc", blob});
  cv::Mat1b huge = cv::Mat1b::zeros(5000, 10);
  cases.push_back({"too large", huge});
  for (const Case& c : cases) {
    const Segmentation s = segment(c.mask);
    EXPECT_FALSE(s.ok) << c.name;
    EXPECT_FALSE(s.why.empty()) << c.name;
  }
}

TEST(Segment, PartlyOutsideTheImageIsRefused) {
  const Figure f = stick_figure(300, 260, 220, true);
  const Segmentation s = segment(f.mask(cv::Rect(0, 0, 300, 200)).clone());  // feet cut off
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.why.find("border"), std::string::npos) << s.why;
}

// Speckles outside and holes inside (a ragged outline is not handled yet: its notches make
// constrictions along the arms).
TEST(Segment, NoisyMaskStillSegments) {
  Figure f = stick_figure(340, 300, 240, false);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> ux(0, f.mask.cols - 1), uy(0, f.mask.rows - 1);
  cv::Mat1b m = f.mask.clone();
  for (int i = 0; i < 150; i++) {  // speckles outside (the draws sequenced: argument order is unspecified)
    const int y = uy(rng);
    const int x = ux(rng);
    m(y, x) = 255;
  }
  for (int i = 0; i < 150; i++) {  // holes inside
    const int x = ux(rng), y = uy(rng);
    if (f.mask(y, x)) m(y, x) = 0;
  }
  const Segmentation s = segment(m);
  debug_png(s, "noisy");
  ASSERT_TRUE(s.ok) << s.why;
  for (int i = 0; i < kFeatures; i++) {
    const cv::Point2f d = s.point[static_cast<size_t>(i)] - f.truth[static_cast<size_t>(i)];
    EXPECT_LT(std::hypot(d.x, d.y), 0.04 * 240) << feature_name(i);
  }
}

TEST(Segment, OptionsCheckThemselves) {
  Options o;
  std::string why;
  EXPECT_TRUE(o.valid(&why)) << why;
  o.gvd_ratio = 3;
  EXPECT_FALSE(o.valid(&why));
  EXPECT_NE(why.find("gvd_ratio"), std::string::npos);
  EXPECT_THROW(segment(cv::Mat1b::zeros(10, 10), o), std::invalid_argument);
}

TEST(Segment, DrawMarksTheFeatures) {
  const Figure f = stick_figure(320, 280, 220, true);
  const Segmentation s = segment(f.mask);
  cv::Mat bgr(f.mask.size(), CV_8UC3, cv::Scalar(0, 0, 0)), out;
  draw(s, bgr, &out);
  ASSERT_EQ(out.size(), f.mask.size());
  ASSERT_EQ(out.type(), CV_8UC3);
  // The GVD is drawn white where no marker covers it, the regions are tinted.
  EXPECT_GT(cv::countNonZero(out.reshape(1) != 0), cv::countNonZero(f.mask));
  draw(Segmentation{}, cv::Mat(), &out);  // nothing at all: still a picture
  EXPECT_FALSE(out.empty());
}

}  // namespace
}  // namespace vc::segment
