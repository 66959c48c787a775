// The colour model: skin intervals and histogram learnt from a region, back-projection (unit).
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "voxcap/edge/track/colour_model.hpp"

namespace vc::track {
namespace {

cv::Mat3b hsv_of(const cv::Mat3b& rgb) {
  cv::Mat3b hsv;
  cv::cvtColor(rgb, hsv, cv::COLOR_RGB2HSV);
  return hsv;
}

// Left half skin (with some noise), right half a blue sleeve.
cv::Mat3b skin_and_sleeve() {
  cv::Mat3b rgb(40, 80);
  cv::RNG rng(7);
  for (int y = 0; y < rgb.rows; ++y)
    for (int x = 0; x < rgb.cols; ++x) {
      const int n = rng.uniform(-6, 7);
      rgb(y, x) = x < 40 ? cv::Vec3b(cv::saturate_cast<uchar>(215 + n), cv::saturate_cast<uchar>(165 + n),
                                     cv::saturate_cast<uchar>(135 + n))
                         : cv::Vec3b(40, 60, cv::saturate_cast<uchar>(170 + n));
    }
  return rgb;
}

TEST(SkinPrior, AcceptsSkinTonesFromPaleToDarkAndRejectsClothesAndGrey) {
  auto is_skin = [](const cv::Vec3b& rgb) {
    cv::Mat3b p(1, 1, rgb);
    return skin_prior(hsv_of(p)(0, 0));
  };
  EXPECT_TRUE(is_skin({235, 200, 180}));   // pale
  EXPECT_TRUE(is_skin({215, 165, 135}));   // default
  EXPECT_TRUE(is_skin({120, 80, 55}));     // brown
  EXPECT_TRUE(is_skin({80, 50, 35}));      // dark
  EXPECT_TRUE(is_skin({200, 120, 130}));   // pinkish (hue just below red wraps to 170s)
  EXPECT_FALSE(is_skin({40, 60, 170}));    // blue shirt
  EXPECT_FALSE(is_skin({60, 140, 60}));    // green
  EXPECT_FALSE(is_skin({128, 128, 128}));  // grey: no saturation
  EXPECT_FALSE(is_skin({10, 8, 6}));       // black
}

TEST(ColourModel, LearnsOnlyTheSkinOfARegionThatAlsoHoldsASleeve) {
  const cv::Mat3b hsv = hsv_of(skin_and_sleeve());
  const cv::Mat1b region(hsv.size(), 255);
  ColourModel m;
  m.learn(hsv, region);
  EXPECT_EQ(m.samples(), 40u * 40u);  // the sleeve's pixels are not skin
  ASSERT_TRUE(m.finish());
  cv::Mat1b mask(hsv.size(), 255);
  mask(cv::Rect(0, 0, 10, 40)).setTo(0);  // not in the silhouette
  cv::Mat1b prob(hsv.size());
  m.back_project(hsv, mask, prob);
  EXPECT_EQ(cv::countNonZero(prob(cv::Rect(0, 0, 10, 40))), 0);                         // masked
  EXPECT_EQ(cv::countNonZero(prob(cv::Rect(40, 0, 40, 40))), 0);                        // sleeve
  EXPECT_GE(cv::countNonZero(prob(cv::Rect(10, 0, 30, 40)) > 48), 30 * 40 * 95 / 100);  // skin
  EXPECT_EQ(m.probability(hsv(5, 15)), prob(5, 15));  // one pixel as the image
}

TEST(ColourModel, SkinHuesOnBothSidesOfRedAreOneInterval) {
  // Hues 172..179 and 0..8 (OpenCV units): one skin interval across the wrap, not the whole circle.
  cv::Mat3b hsv(1, 17);
  for (int i = 0; i < 17; ++i) hsv(0, i) = cv::Vec3b(static_cast<uchar>((172 + i) % 180), 120, 180);
  cv::Mat3b many;
  cv::repeat(hsv, 10, 1, many);
  ColourModel m;
  m.learn(many, cv::Mat1b(many.size(), 255));
  ASSERT_TRUE(m.finish());
  EXPECT_GT(m.probability({176, 120, 180}), 0);
  EXPECT_GT(m.probability({4, 120, 180}), 0);
  EXPECT_EQ(m.probability({90, 120, 180}), 0);  // cyan
  EXPECT_EQ(m.probability({30, 120, 180}), 0);  // yellow-green
  EXPECT_EQ(m.probability({176, 120, 10}), 0);  // far too dark
}

TEST(ColourModel, TooFewSamplesGiveNoModelAndNoProbability) {
  ColourModel m;
  const cv::Mat3b hsv = hsv_of(skin_and_sleeve());
  cv::Mat1b region(hsv.size(), 0);
  region(cv::Rect(0, 0, 3, 3)).setTo(255);  // 9 < min_samples
  m.learn(hsv, region);
  EXPECT_FALSE(m.finish());
  EXPECT_FALSE(m.ready());
  cv::Mat1b prob(hsv.size());
  m.back_project(hsv, cv::Mat1b(hsv.size(), 255), prob);
  EXPECT_EQ(cv::countNonZero(prob), 0);
}

TEST(ColourModelOptions, ValidSaysWhatIsWrong) {
  std::string why;
  EXPECT_TRUE(ColourModelOptions{}.valid(&why));
  ColourModelOptions o;
  o.hue_bins = 0;
  EXPECT_FALSE(o.valid(&why));
  EXPECT_EQ(why, "hue_bins must be 1..180");
  o = {};
  o.tail = 0.5;
  EXPECT_FALSE(o.valid(&why));
  EXPECT_EQ(why, "tail must be in [0, 0.5)");
}

}  // namespace
}  // namespace vc::track
