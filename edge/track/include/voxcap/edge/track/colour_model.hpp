// The colour model of one tracked feature (paper sec. 6): skin-colour intervals in HSV and a
// hue/saturation histogram, learnt from the feature's region over the initialization frames, and the
// back-projection that CamShift follows.
//
// Pixels are OpenCV 8-bit HSV (H 0..179, S and V 0..255). Hue wraps at red, where skin lives, so hue is
// handled shifted by kHueShift (hue + 90 mod 180): skin hues (about 170..179 and 0..25) become one
// contiguous interval. Learning keeps counts only (no image is kept); finish() turns them into
// intervals (the central 96 % of the samples, widened by a margin) and a histogram normalised to a
// peak of 255, and precomputes the back-projection table, so back_project() is one lookup per pixel.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace vc::track {

// A pixel that can be skin at all, before anything is learnt: a hue in the red-orange range of every
// skin tone (pale to dark), some saturation, not black. Used to pick the samples of a feature's region
// (which may also hold sleeve or trouser pixels) and as the gate of a model learnt from few samples.
bool skin_prior(const cv::Vec3b& hsv);

struct ColourModelOptions {
  int hue_bins = 30;   // histogram bins over the (shifted) hue 0..179
  int sat_bins = 32;   // and over saturation 0..255
  double tail = 0.02;  // each interval drops this share of the samples at each end
  int hue_margin = 4;  // and is then widened by these margins (8-bit HSV units)
  int sat_margin = 20;
  int val_margin = 30;
  std::uint32_t min_samples = 40;  // fewer: the model is not usable (ready() false)

  bool valid(std::string* why) const;
};

class ColourModel {
 public:
  static constexpr int kHueShift = 90;

  explicit ColourModel(const ColourModelOptions& options = {});

  void reset();
  // Adds the pixels of hsv (CV_8UC3) where region != 0 and skin_prior() holds; region is the same size.
  void learn(const cv::Mat3b& hsv, const cv::Mat1b& region);
  // Adds all of another model's samples (a model pooled from every feature).
  void merge(const ColourModel& other);
  std::uint32_t samples() const { return samples_; }
  // Computes the intervals, the histogram and the table; false (and not ready) with too few samples.
  bool finish();
  bool ready() const { return ready_; }

  // Probability 0..255 per pixel of hsv (same size as out), 0 outside the intervals or where mask is 0.
  void back_project(const cv::Mat3b& hsv, const cv::Mat1b& mask, cv::Mat1b& out) const;
  // The probability of one HSV pixel.
  std::uint8_t probability(const cv::Vec3b& hsv) const;

  // The learnt intervals, inclusive: shifted hue, saturation, value.
  struct Interval {
    int lo = 0, hi = 255;
  };
  const std::array<Interval, 3>& intervals() const { return intervals_; }

 private:
  ColourModelOptions opt_;
  std::array<std::vector<std::uint32_t>, 3> counts_;  // per channel (shifted hue, s, v), 256 bins
  std::vector<std::uint32_t> hist_counts_;            // hue_bins x sat_bins
  std::uint32_t samples_ = 0;
  bool ready_ = false;
  std::array<Interval, 3> intervals_{};
  std::vector<std::uint8_t> table_;  // 180 x 256: (raw hue, saturation) -> probability, 0 outside
};

}  // namespace vc::track
