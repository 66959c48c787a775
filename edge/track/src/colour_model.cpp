#include "voxcap/edge/track/colour_model.hpp"

#include <algorithm>
#include <string>

namespace vc::track {

namespace {

// Index of (row, col) in a row-major table `cols` wide, computed in size_t.
std::size_t idx(int row, int cols, int col) {
  return static_cast<std::size_t>(row) * static_cast<std::size_t>(cols) + static_cast<std::size_t>(col);
}

int shifted_hue(int h) {
  return (h + ColourModel::kHueShift) % 180;
}

// The value below which `share` of the samples of a 256-bin histogram lie.
int percentile(const std::vector<std::uint32_t>& counts, std::uint32_t total, double share) {
  const auto target = static_cast<std::uint64_t>(share * double(total));
  std::uint64_t acc = 0;
  for (int i = 0; i < 256; ++i) {
    acc += counts[static_cast<std::size_t>(i)];
    if (acc > target) return i;
  }
  return 255;
}

}  // namespace

bool skin_prior(const cv::Vec3b& hsv) {
  const int h = shifted_hue(hsv[0]);  // red at 90; skin about 80 (magenta-red) .. 115 (orange-yellow)
  return h >= 78 && h <= 118 && hsv[1] >= 25 && hsv[1] <= 230 && hsv[2] >= 35;
}

bool ColourModelOptions::valid(std::string* why) const {
  auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (hue_bins < 1 || hue_bins > 180) return fail("hue_bins must be 1..180");
  if (sat_bins < 1 || sat_bins > 256) return fail("sat_bins must be 1..256");
  if (!(tail >= 0 && tail < 0.5)) return fail("tail must be in [0, 0.5)");
  if (hue_margin < 0 || sat_margin < 0 || val_margin < 0) return fail("margins must be >= 0");
  if (min_samples < 1) return fail("min_samples must be >= 1");
  return true;
}

ColourModel::ColourModel(const ColourModelOptions& options) : opt_(options) {
  reset();
}

void ColourModel::reset() {
  for (auto& c : counts_) c.assign(256, 0);
  hist_counts_.assign(idx(opt_.hue_bins, opt_.sat_bins, 0), 0);
  samples_ = 0;
  ready_ = false;
  table_.assign(180 * 256, 0);
}

void ColourModel::learn(const cv::Mat3b& hsv, const cv::Mat1b& region) {
  CV_Assert(hsv.size() == region.size());
  for (int y = 0; y < hsv.rows; ++y) {
    const cv::Vec3b* p = hsv[y];
    const std::uint8_t* m = region[y];
    for (int x = 0; x < hsv.cols; ++x) {
      if (!m[x] || !skin_prior(p[x])) continue;
      const int h = shifted_hue(p[x][0]);
      counts_[0][static_cast<std::size_t>(h)]++;
      counts_[1][p[x][1]]++;
      counts_[2][p[x][2]]++;
      const int hb = h * opt_.hue_bins / 180, sb = p[x][1] * opt_.sat_bins / 256;
      hist_counts_[idx(hb, opt_.sat_bins, sb)]++;
      samples_++;
    }
  }
}

void ColourModel::merge(const ColourModel& other) {
  CV_Assert(other.hist_counts_.size() == hist_counts_.size());
  for (std::size_t c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < 256; ++i) counts_[c][i] += other.counts_[c][i];
  for (std::size_t i = 0; i < hist_counts_.size(); ++i) hist_counts_[i] += other.hist_counts_[i];
  samples_ += other.samples_;
}

bool ColourModel::finish() {
  ready_ = false;
  table_.assign(180 * 256, 0);
  if (samples_ < opt_.min_samples) return false;
  const int margin[3] = {opt_.hue_margin, opt_.sat_margin, opt_.val_margin};
  const int top[3] = {179, 255, 255};
  for (std::size_t c = 0; c < 3; ++c) {
    intervals_[c].lo = std::max(0, percentile(counts_[c], samples_, opt_.tail) - margin[c]);
    intervals_[c].hi = std::min(top[c], percentile(counts_[c], samples_, 1.0 - opt_.tail) + margin[c]);
  }
  // The histogram, smoothed by one bin each way (a learnt model must not have holes between bins that
  // the init frames happened not to hit), scaled to a peak of 255.
  const int hb_n = opt_.hue_bins, sb_n = opt_.sat_bins;
  std::vector<double> smooth(hist_counts_.size(), 0.0);
  double peak = 0;
  for (int hb = 0; hb < hb_n; ++hb)
    for (int sb = 0; sb < sb_n; ++sb) {
      double s = 0;
      for (int dh = -1; dh <= 1; ++dh)
        for (int ds = -1; ds <= 1; ++ds) {
          const int h2 = hb + dh, s2 = sb + ds;
          if (h2 < 0 || h2 >= hb_n || s2 < 0 || s2 >= sb_n) continue;
          const double w = (dh == 0 ? 2.0 : 1.0) * (ds == 0 ? 2.0 : 1.0);
          s += w * hist_counts_[idx(h2, sb_n, s2)];
        }
      smooth[idx(hb, sb_n, sb)] = s;
      peak = std::max(peak, s);
    }
  if (peak <= 0) return false;
  for (int h = 0; h < 180; ++h) {
    const int hs = shifted_hue(h);
    if (hs < intervals_[0].lo || hs > intervals_[0].hi) continue;
    for (int s = intervals_[1].lo; s <= intervals_[1].hi; ++s) {
      const double v = smooth[idx(hs * hb_n / 180, sb_n, s * sb_n / 256)] / peak;
      // A floor inside the intervals: a pixel within the learnt skin intervals is never impossible.
      table_[idx(h, 256, s)] = static_cast<std::uint8_t>(std::clamp(16.0 + 239.0 * v, 0.0, 255.0));
    }
  }
  ready_ = true;
  return true;
}

std::uint8_t ColourModel::probability(const cv::Vec3b& hsv) const {
  if (!ready_ || hsv[2] < intervals_[2].lo || hsv[2] > intervals_[2].hi) return 0;
  return table_[idx(std::min<int>(hsv[0], 179), 256, hsv[1])];
}

void ColourModel::back_project(const cv::Mat3b& hsv, const cv::Mat1b& mask, cv::Mat1b& out) const {
  CV_Assert(hsv.size() == mask.size() && hsv.size() == out.size());
  const int vlo = intervals_[2].lo, vhi = intervals_[2].hi;
  const std::uint8_t* table = table_.data();
  for (int y = 0; y < hsv.rows; ++y) {
    const cv::Vec3b* p = hsv[y];
    const std::uint8_t* m = mask[y];
    std::uint8_t* o = out[y];
    for (int x = 0; x < hsv.cols; ++x) {
      const int v = p[x][2];
      const std::uint8_t t = table[std::min<int>(p[x][0], 179) * 256 + p[x][1]];
      o[x] = (m[x] && ready_ && v >= vlo && v <= vhi) ? t : 0;
    }
  }
}

}  // namespace vc::track
