// Background model and subtraction against a float reference of the method's eq. 1 and 2.
#include "voxcap/edge/bgmodel.h"

#include <gtest/gtest.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "synth.hpp"
#include "voxcap/edge/cleanup.h"

namespace {

using vc::edge_test::Blob;
using vc::edge_test::Scene;
using vc::edge_test::Truth;

struct ModelDeleter {
  void operator()(vc_bgmodel* m) const { vc_bgmodel_free(m); }
};
using ModelPtr = std::unique_ptr<vc_bgmodel, ModelDeleter>;

// A new model (null, with the reason reported, when vc_bgmodel_new fails).
ModelPtr new_model(int width, int height) {
  vc_bgmodel* m = nullptr;
  char why[128];
  EXPECT_EQ(vc_bgmodel_new(width, height, &m, why, sizeof why), 0) << why;
  return ModelPtr(m);
}

// The rule of bgmodel.h in doubles, with acos: eq. 1 with the brighter/darker split, eq. 2, and the
// texture and flat-patch tests over the 5x5 window, on the model's own mean and sigma.
std::vector<uint8_t> reference_subtract(const vc_bgmodel* m, const vc_subtract_params& p,
                                        const std::vector<uint8_t>& rgb) {
  const int w = vc_bgmodel_width(m), h = vc_bgmodel_height(m);
  const uint8_t* mean = vc_bgmodel_mean(m);
  const uint16_t* sigma_q8 = vc_bgmodel_sigma_q8(m);
  const double t_angular = std::acos(std::sqrt(p.cos2_angular));
  constexpr uint8_t kCandidate = 1, kDark = 2;
  std::vector<uint8_t> out(static_cast<size_t>(w) * h);
  for (size_t i = 0; i < out.size(); i++) {
    const uint8_t* px = &rgb[3 * i];
    const uint8_t* mu = &mean[3 * i];
    bool fg = false, band = false, dark = false;
    for (int c = 0; c < 3; c++) {
      double sigma = std::max(sigma_q8[3 * i + c] / 256.0, p.sigma_floor);
      double d = static_cast<double>(px[c]) - mu[c];
      if (d >= p.t_lower * sigma) fg = true;  // brighter: shadows only darken
      double deepest = std::min(p.t_upper * sigma, (1.0 - p.shadow_min_gain) * mu[c] + p.t_lower * sigma);
      if (-d > deepest) fg = true;
      if (-d >= p.t_lower * sigma) band = true;
    }
    if (!fg && band) {
      double dot = 0, pp = 0, mm = 0;
      for (int c = 0; c < 3; c++) {
        dot += static_cast<double>(px[c]) * mu[c];
        pp += static_cast<double>(px[c]) * px[c];
        mm += static_cast<double>(mu[c]) * mu[c];
      }
      double delta = (pp == 0 || mm == 0) ? 0.0 : std::acos(std::min(1.0, dot / std::sqrt(pp * mm)));
      double alpha = mm == 0 ? 0.0 : dot / mm;
      bool shadow = delta <= t_angular && alpha >= p.shadow_min_gain && alpha <= p.shadow_max_gain;
      if (mm == 0) shadow = delta <= t_angular;  // black background: every band pixel is shadow
      // below the gain bound with the background's hue: foreground, but in the windows' fits
      dark = !shadow && delta <= t_angular && alpha < p.shadow_min_gain;
      fg = !shadow;
    }
    out[i] = dark ? kDark : fg ? 255 : band ? kCandidate : 0;
  }
  const double floor_q8 = std::round(p.sigma_floor * 256.0);
  std::vector<uint8_t> done = out;
  for (uint8_t& d : done) d = d == kDark ? 255 : d;
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (out[i] != kCandidate) continue;
      double spp = 0, spm = 0, smm = 0, v = 0, sl = 0, slm = 0, smml = 0;  // L: the luminance p_0 + p_1 + p_2
      int n = 0;
      for (int yy = std::max(0, y - 2); yy <= std::min(h - 1, y + 2); yy++)
        for (int xx = std::max(0, x - 2); xx <= std::min(w - 1, x + 2); xx++) {
          const size_t j = static_cast<size_t>(yy) * w + xx;
          if (out[j] != kCandidate && out[j] != kDark) continue;
          n++;
          double L = 0, LM = 0;
          for (int c = 0; c < 3; c++) {
            const double P = rgb[3 * j + c], M = mean[3 * j + c];
            spp += P * P;
            spm += P * M;
            smm += M * M;
            L += P;
            LM += M;
          }
          sl += L;
          slm += L * LM;
          smml += LM * LM;
        }
      for (int c = 0; c < 3; c++) {  // the noise: n times the centre pixel's
        const double s = std::max(static_cast<double>(sigma_q8[3 * i + c]), floor_q8) / 256.0;
        v += n * s * s;
      }
      bool shadow = true;
      if (p.shadow_texture_k > 0 && n >= 3) {
        const double ss = smm == 0 ? 0.0 : spp - spm * spm / smm;
        shadow = ss <= p.shadow_texture_k * p.shadow_texture_k * v;
      }
      if (shadow && p.shadow_flat_margin > 0 && n >= 3) {  // flat patch against scaled texture, luminance
        const double flat = sl * sl / n, gain = smml > 0 ? slm * slm / smml : 0.0;
        shadow = flat - gain <= p.shadow_flat_margin * v;
      }
      done[i] = shadow ? 0 : 255;
    }
  return done;
}

// The rule of bgmodel.h in the kernel's own integers, written plainly (a loop per pixel, the 5x5
// window summed afresh for every candidate): the thresholds as vc_bgmodel_set_params derives them,
// eq. 2 and the texture test's comparisons exactly as bgmodel.c states them. The kernel's passes,
// vectors and running sums must give this mask bit for bit. `dark_in_fits` false gives the rule before
// session 16: the band pixels below eq. 2's gain bound left out of the windows' fits.
std::vector<uint8_t> integer_subtract(const vc_bgmodel* m, const vc_subtract_params& p,
                                      const std::vector<uint8_t>& rgb, bool dark_in_fits = true) {
  const int w = vc_bgmodel_width(m), h = vc_bgmodel_height(m);
  const uint8_t* mean = vc_bgmodel_mean(m);
  const uint16_t* sigma_q8 = vc_bgmodel_sigma_q8(m);
  const uint64_t c2 = static_cast<uint64_t>(std::llround(p.cos2_angular * 16777216.0));
  const uint64_t glo = static_cast<uint64_t>(std::llround(p.shadow_min_gain * 65536.0));
  const uint64_t ghi = static_cast<uint64_t>(std::llround(p.shadow_max_gain * 65536.0));
  const uint64_t k2 = static_cast<uint64_t>(std::llround(p.shadow_texture_k * p.shadow_texture_k * 256.0));
  const uint64_t fl = static_cast<uint64_t>(std::llround(p.sigma_floor * 256.0));
  const uint64_t flat_q8 = static_cast<uint64_t>(std::llround(p.shadow_flat_margin * 256.0));
  enum : uint8_t { kBg = 0, kCandidate = 1, kDark = 2, kFg = 255 };
  std::vector<uint8_t> cls(static_cast<size_t>(w) * h);
  for (size_t i = 0; i < cls.size(); i++) {
    const uint8_t* px = &rgb[3 * i];
    const uint8_t* mu = &mean[3 * i];
    bool fg = false, band = false;
    for (int c = 0; c < 3; c++) {
      const double sigma = std::max(sigma_q8[3 * i + c] / 256.0, p.sigma_floor);
      const double up = std::min(std::floor(p.t_upper * sigma),
                                 std::floor((1.0 - p.shadow_min_gain) * mu[c] + p.t_lower * sigma));
      const double lo = std::ceil(p.t_lower * sigma) - 1.0;
      const int tu = static_cast<int>(std::min(up, 255.0)), tl = static_cast<int>(std::min(lo, 255.0));
      const int d = px[c] - mu[c];
      fg = fg || d > tl || -d > tu;
      band = band || -d > tl;
    }
    uint8_t v = fg ? kFg : band ? kCandidate : kBg;
    if (v == kCandidate) {
      uint64_t dot = 0, pp = 0, mm = 0;
      for (int c = 0; c < 3; c++) {
        dot += uint64_t{px[c]} * mu[c];
        pp += uint64_t{px[c]} * px[c];
        mm += uint64_t{mu[c]} * mu[c];
      }
      const bool hue = (dot * dot << 24) >= c2 * pp * mm;
      const bool shadow = hue && (dot << 16) >= glo * mm && (dot << 16) <= ghi * mm;
      const bool dark = hue && (dot << 16) < glo * mm;  // in the windows' fits, foreground itself
      v = shadow ? (k2 != 0 || flat_q8 != 0 ? kCandidate : kBg) : dark && dark_in_fits ? kDark : kFg;
    }
    cls[i] = v;
  }
  std::vector<uint8_t> out = cls;
  for (uint8_t& o : out) o = o == kDark ? kFg : o;
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (cls[i] != kCandidate) continue;
      uint64_t n = 0, spp = 0, spm = 0, smm = 0, sl = 0, slm = 0, smml = 0;
      for (int yy = std::max(0, y - 2); yy <= std::min(h - 1, y + 2); yy++)
        for (int xx = std::max(0, x - 2); xx <= std::min(w - 1, x + 2); xx++) {
          const size_t j = static_cast<size_t>(yy) * w + xx;
          if (cls[j] != kCandidate && cls[j] != kDark) continue;
          n++;
          uint64_t L = 0, LM = 0;
          for (int c = 0; c < 3; c++) {
            spp += uint64_t{rgb[3 * j + c]} * rgb[3 * j + c];
            spm += uint64_t{rgb[3 * j + c]} * mean[3 * j + c];
            smm += uint64_t{mean[3 * j + c]} * mean[3 * j + c];
            L += rgb[3 * j + c];
            LM += mean[3 * j + c];
          }
          sl += L;
          slm += L * LM;
          smml += LM * LM;
        }
      bool shadow = true;
      if (n >= 3) {
        uint64_t v = 0;
        for (int c = 0; c < 3; c++) {
          const uint64_t sg = std::max<uint64_t>(sigma_q8[3 * i + c], fl);
          v += sg * sg;
        }
        if (k2 != 0) {
          const unsigned __int128 lhs = static_cast<unsigned __int128>(spp * smm - spm * spm) << 24;
          shadow = lhs <= static_cast<unsigned __int128>(k2 * n * v) * smm;
        }
        if (shadow && flat_q8 != 0) {  // (SL^2 SMML - n SLM^2) 2^24 > t n^2 v SMML, SMML >= 1
          using u128 = unsigned __int128;
          const uint64_t q = std::max<uint64_t>(smml, 1);
          shadow = !((u128{sl * sl * q} << 24) > (u128{slm * slm * n} << 24) + u128{flat_q8 * n * n * v} * q);
        }
      }
      out[i] = shadow ? kBg : kFg;
    }
  return out;
}

Scene test_scene() {
  Scene s;
  s.people = {{100, 120, 30, 70, 200, 60, 50, 0},
              {230, 140, 25, 60, 40, 70, 170, 0},
              {160, 60, 12, 14, 215, 170, 140, 0},  // skin-coloured head
              {60, 200, 18, 22, 60, 60, 60, 0}};    // dark grey trousers-like blob
  s.shadows = {{130, 215, 90, 20, 0, 0, 0, 0.55}, {250, 200, 40, 25, 0, 0, 0, 0.75}};
  return s;
}

vc_subtract_params test_params() {
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  p.t_upper = 25.0;
  p.t_lower = 3.5;
  p.cos2_angular = std::pow(std::cos(5.0 * M_PI / 180.0), 2);
  p.shadow_min_gain = 0.3;
  p.shadow_max_gain = 1.0;
  return p;
}

ModelPtr learn(const Scene& scene, int frames, std::mt19937& rng) {
  Scene empty = scene;
  empty.people.clear();
  empty.shadows.clear();
  ModelPtr m = new_model(scene.width, scene.height);
  EXPECT_NE(m, nullptr);
  std::vector<uint8_t> rgb;
  for (int i = 0; i < frames; i++) {
    empty.render(rng, rgb, nullptr);
    EXPECT_EQ(vc_bgmodel_learn(m.get(), rgb.data(), 3 * static_cast<size_t>(scene.width)), 0);
  }
  EXPECT_EQ(vc_bgmodel_finish(m.get()), 0);
  return m;
}

TEST(SubtractParams, DefaultsAreValidAndBadOnesAreNamed) {
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  char why[128] = "unset";
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), 0);
  EXPECT_STREQ(why, "");
  p.t_lower = p.t_upper * 2;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), -EINVAL);
  EXPECT_NE(std::string(why).find("t_lower"), std::string::npos);
  EXPECT_NE(std::string(why).find("not 120"), std::string::npos) << why;  // and the bad value
  vc_subtract_params_default(&p);
  p.cos2_angular = 1.5;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), -EINVAL);
  EXPECT_NE(std::string(why).find("cos2"), std::string::npos);
  p.cos2_angular = std::nan("");
  EXPECT_EQ(vc_subtract_params_check(&p, nullptr, 0), -EINVAL);
  EXPECT_EQ(vc_subtract_params_check(nullptr, why, sizeof why), -EINVAL);
  EXPECT_STREQ(why, "params is NULL");
}

TEST(SubtractParams, ReasonIsTruncatedAndTerminatedLikeVcWhy) {
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  p.sigma_floor = 0;
  char full[128], tiny[8];
  ASSERT_EQ(vc_subtract_params_check(&p, full, sizeof full), -EINVAL);
  EXPECT_STREQ(full, "sigma_floor must be in (0, 255], not 0");
  std::memset(tiny, 'x', sizeof tiny);
  EXPECT_EQ(vc_subtract_params_check(&p, tiny, sizeof tiny), -EINVAL);
  EXPECT_EQ(std::string(tiny), std::string(full).substr(0, sizeof tiny - 1));  // terminated, cut
  char untouched[4] = "abc";
  EXPECT_EQ(vc_subtract_params_check(&p, untouched, 0), -EINVAL);  // no room: left alone
  EXPECT_STREQ(untouched, "abc");
}

TEST(BgModel, LifecycleErrors) {
  char why[128] = "unset";
  vc_bgmodel* failed = reinterpret_cast<vc_bgmodel*>(why);  // must come back NULL
  EXPECT_EQ(vc_bgmodel_new(0, 10, &failed, why, sizeof why), -EINVAL);
  EXPECT_EQ(failed, nullptr);
  EXPECT_STREQ(why, "background model: frame size 0x10 must be 1..16384 each");
  EXPECT_EQ(vc_bgmodel_new(8, 16385, &failed, nullptr, 0), -EINVAL);
  EXPECT_EQ(failed, nullptr);
  EXPECT_EQ(vc_bgmodel_new(8, 4, nullptr, why, sizeof why), -EINVAL);  // nowhere to put it
  vc_bgmodel_free(nullptr);
  ModelPtr m;
  {
    vc_bgmodel* made = nullptr;
    ASSERT_EQ(vc_bgmodel_new(8, 4, &made, why, sizeof why), 0);
    m.reset(made);
  }
  EXPECT_STREQ(why, "");
  ASSERT_NE(m, nullptr);
  std::vector<uint8_t> rgb(8 * 4 * 3, 100), mask(8 * 4);
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  EXPECT_EQ(vc_subtract(m.get(), rgb.data(), 24, mask.data(), nullptr), -EAGAIN);
  EXPECT_EQ(vc_bgmodel_set_params(m.get(), &p), -EAGAIN);
  EXPECT_EQ(vc_bgmodel_learn(m.get(), rgb.data(), 23), -EINVAL);  // stride < 3*width
  EXPECT_EQ(vc_bgmodel_learn(m.get(), rgb.data(), 24), 0);
  EXPECT_EQ(vc_bgmodel_finish(m.get()), -ENODATA);  // one frame gives no deviation
  EXPECT_EQ(vc_bgmodel_learn(m.get(), rgb.data(), 24), 0);
  EXPECT_EQ(vc_bgmodel_finish(m.get()), 0);
  EXPECT_EQ(vc_bgmodel_finish(m.get()), -EBUSY);
  EXPECT_EQ(vc_bgmodel_learn(m.get(), rgb.data(), 24), -EBUSY);
  EXPECT_EQ(vc_bgmodel_frames(m.get()), 2);
  p.t_upper = -1;
  EXPECT_EQ(vc_bgmodel_set_params(m.get(), &p), -EINVAL);
  vc_subtract_params_default(&p);
  EXPECT_EQ(vc_bgmodel_set_params(m.get(), &p), 0);
  EXPECT_EQ(vc_subtract(m.get(), rgb.data(), 24, mask.data(), nullptr), 0);
  for (uint8_t v : mask) EXPECT_EQ(v, 0);
}

TEST(BgModel, MeanAndSigmaMatchTheSamples) {
  // Two frames per pixel with known values: mean and sample deviation are exact.
  const int w = 5, h = 3;
  ModelPtr m = new_model(w, h);
  std::vector<uint8_t> a(w * h * 3), b(w * h * 3), c(w * h * 3);
  for (size_t i = 0; i < a.size(); i++) {
    a[i] = static_cast<uint8_t>(i * 7);
    b[i] = static_cast<uint8_t>(i * 7 + 2);
    c[i] = static_cast<uint8_t>(i * 7 + 4 * (i % 2));
  }
  ASSERT_EQ(vc_bgmodel_learn(m.get(), a.data(), w * 3), 0);
  ASSERT_EQ(vc_bgmodel_learn(m.get(), b.data(), w * 3), 0);
  ASSERT_EQ(vc_bgmodel_learn(m.get(), c.data(), w * 3), 0);
  ASSERT_EQ(vc_bgmodel_finish(m.get()), 0);
  for (size_t i = 0; i < a.size(); i++) {
    double s[3] = {double(a[i]), double(b[i]), double(c[i])};
    double mean = (s[0] + s[1] + s[2]) / 3;
    double var = 0;
    for (double v : s) var += (v - mean) * (v - mean);
    double sigma = std::sqrt(var / 2);
    EXPECT_EQ(vc_bgmodel_mean(m.get())[i], static_cast<uint8_t>(std::floor(mean + 0.5))) << i;
    EXPECT_NEAR(vc_bgmodel_sigma_q8(m.get())[i] / 256.0, sigma, 0.5 / 256 + 1e-9) << i;
  }
}

TEST(BgModel, LearntSigmaEstimatesTheSensorNoise) {
  Scene s = test_scene();
  s.noise_sigma = 2.5;
  std::mt19937 rng(7);
  ModelPtr m = learn(s, 40, rng);
  const uint16_t* sq = vc_bgmodel_sigma_q8(m.get());
  double sum = 0;
  size_t n = static_cast<size_t>(s.width) * s.height * 3;
  for (size_t i = 0; i < n; i++) sum += sq[i] / 256.0;
  EXPECT_NEAR(sum / n, 2.5, 0.1);
}

class SubtractVariants : public ::testing::TestWithParam<const char*> {
 protected:
  void SetUp() override {
    int err = vc_edge_kernel_select(GetParam());
    if (err == -ENOTSUP) GTEST_SKIP() << GetParam() << " kernels do not run on this CPU";
    ASSERT_EQ(err, 0);
    ASSERT_STREQ(vc_edge_kernel_name(), GetParam());
  }
  void TearDown() override { vc_edge_kernel_select("auto"); }
};

TEST_P(SubtractVariants, SameClassAsFloatReferenceOfEq1And2) {
  Scene s = test_scene();
  std::mt19937 rng(42);
  ModelPtr m = learn(s, 30, rng);
  vc_subtract_params p = test_params();
  ASSERT_EQ(vc_bgmodel_set_params(m.get(), &p), 0);
  std::vector<uint8_t> rgb, mask(static_cast<size_t>(s.width) * s.height);
  std::vector<Truth> truth;
  size_t total = 0, same = 0, band = 0;
  for (int f = 0; f < 6; f++) {
    // Move the blobs a little each frame; vary the thresholds to cover the whole band.
    for (Blob& b : s.people) b.cx += 3;
    if (f == 3) {
      p.t_upper = 8.0;
      // Was shadow_max_gain 1.3; a gain above 1 is now refused (a shadow only darkens), so the
      // lower gain varies instead (it also bounds how dark a band pixel may be, eq. 1).
      p.shadow_min_gain = 0.5;
      ASSERT_EQ(vc_bgmodel_set_params(m.get(), &p), 0);
    }
    s.render(rng, rgb, &truth);
    vc_subtract_stats st;
    ASSERT_EQ(vc_subtract(m.get(), rgb.data(), 3 * static_cast<size_t>(s.width), mask.data(), &st), 0);
    std::vector<uint8_t> ref = reference_subtract(m.get(), p, rgb);
    for (size_t i = 0; i < mask.size(); i++) {
      ASSERT_TRUE(mask[i] == 0 || mask[i] == 255);
      same += mask[i] == ref[i];
    }
    total += mask.size();
    band += st.band;
    EXPECT_GT(st.shadow, 0u);
    EXPECT_LE(st.shadow, st.band);
  }
  EXPECT_GT(band, total / 100) << "the scene must exercise the shadow test";
  EXPECT_GE(static_cast<double>(same) / total, 0.999) << (total - same) << " pixels differ";
}

TEST_P(SubtractVariants, SeparatesPeopleFromShadowsInTheSyntheticScene) {
  Scene s = test_scene();
  std::mt19937 rng(3);
  ModelPtr m = learn(s, 30, rng);
  // Shadows darken by up to 45 % (up to 85 levels here): T_u * sigma must lie above that, so that
  // they reach the shadow test instead of eq. 1; the colour angle then keeps the people.
  // Sensor noise on a darkened pixel tilts its colour by a few degrees: T_angular 8 degrees keeps
  // shadows, and the people's colours are all more than 10 degrees from the background's.
  vc_subtract_params p = test_params();
  p.t_upper = 60.0;
  p.cos2_angular = std::pow(std::cos(8.0 * M_PI / 180.0), 2);
  ASSERT_EQ(vc_bgmodel_set_params(m.get(), &p), 0);
  std::vector<uint8_t> rgb, mask(static_cast<size_t>(s.width) * s.height);
  std::vector<Truth> truth;
  s.render(rng, rgb, &truth);
  ASSERT_EQ(vc_subtract(m.get(), rgb.data(), 3 * static_cast<size_t>(s.width), mask.data(), nullptr), 0);
  size_t fg = 0, fg_hit = 0, shadow = 0, shadow_bg = 0, bg = 0, bg_hit = 0;
  for (size_t i = 0; i < mask.size(); i++) {
    switch (truth[i]) {
      case Truth::kForeground:
        fg++;
        fg_hit += mask[i] != 0;
        break;
      case Truth::kShadow:
        shadow++;
        shadow_bg += mask[i] == 0;
        break;
      case Truth::kBackground:
        bg++;
        bg_hit += mask[i] == 0;
        break;
    }
  }
  EXPECT_GE(static_cast<double>(fg_hit) / fg, 0.99);
  EXPECT_GE(static_cast<double>(shadow_bg) / shadow, 0.97);
  EXPECT_GE(static_cast<double>(bg_hit) / bg, 0.995);
}

TEST_P(SubtractVariants, HonoursStrideAndOddWidths) {
  // Width 37 (not a multiple of any vector size), rows padded to 128 bytes.
  Scene s;
  s.width = 37;
  s.height = 9;
  s.people = {{18, 4, 6, 3, 250, 10, 10, 0}};
  std::mt19937 rng(5);
  ModelPtr m = learn(s, 8, rng);
  vc_subtract_params p = test_params();
  ASSERT_EQ(vc_bgmodel_set_params(m.get(), &p), 0);
  std::vector<uint8_t> rgb;
  s.render(rng, rgb, nullptr);
  const size_t stride = 128;
  std::vector<uint8_t> padded(stride * s.height, 0xAB);
  for (int y = 0; y < s.height; y++) std::memcpy(&padded[y * stride], &rgb[y * 37 * 3], 37 * 3);
  std::vector<uint8_t> a(37 * 9), b(37 * 9);
  ASSERT_EQ(vc_subtract(m.get(), rgb.data(), 37 * 3, a.data(), nullptr), 0);
  ASSERT_EQ(vc_subtract(m.get(), padded.data(), stride, b.data(), nullptr), 0);
  EXPECT_EQ(a, b);
  EXPECT_EQ(a, reference_subtract(m.get(), p, rgb));
  EXPECT_EQ(a[4 * 37 + 18], 255);
}

// ---- the texture test on synthetic images (models restored from a known mean, sigma 2) ----------

constexpr int kW = 96, kH = 72;

// A model of kW x kH with the given mean image and sigma 2.0 everywhere (learnt from 30 frames).
ModelPtr model_of(const std::vector<uint8_t>& mean, const vc_subtract_params& p) {
  ModelPtr m = new_model(kW, kH);
  std::vector<uint16_t> sigma(mean.size(), 512);
  EXPECT_EQ(vc_bgmodel_restore(m.get(), mean.data(), sigma.data(), 30), 0);
  EXPECT_EQ(vc_bgmodel_set_params(m.get(), &p), 0);
  return m;
}

uint8_t clamp8(double v) {
  return static_cast<uint8_t>(std::lround(std::min(255.0, std::max(0.0, v))));
}

// Oak-like boards: (160,114,74) with grain (~10 % stripes) and per-pixel variation.
std::vector<uint8_t> wood(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-0.06, 0.06);
  std::vector<uint8_t> img(static_cast<size_t>(kW) * kH * 3);
  const double base[3] = {160, 114, 74};
  for (int y = 0; y < kH; y++)
    for (int x = 0; x < kW; x++) {
      const double g = 1.0 + 0.1 * std::sin(0.9 * y + 0.15 * x) + u(rng);
      for (int c = 0; c < 3; c++) img[(static_cast<size_t>(y) * kW + x) * 3 + c] = clamp8(base[c] * g);
    }
  return img;
}

std::vector<uint8_t> flat(const double rgb[3]) {
  std::vector<uint8_t> img(static_cast<size_t>(kW) * kH * 3);
  for (size_t i = 0; i < img.size(); i++) img[i] = clamp8(rgb[i % 3]);
  return img;
}

// The frame: `scene(x, y, c)` plus Gaussian noise of sigma 2.
template <typename F>
std::vector<uint8_t> render_frame(std::mt19937& rng, F scene) {
  std::normal_distribution<double> noise(0.0, 2.0);
  std::vector<uint8_t> img(static_cast<size_t>(kW) * kH * 3);
  for (int y = 0; y < kH; y++)
    for (int x = 0; x < kW; x++)
      for (int c = 0; c < 3; c++)
        img[(static_cast<size_t>(y) * kW + x) * 3 + c] = clamp8(scene(x, y, c) + noise(rng));
  return img;
}

std::vector<uint8_t> run(const ModelPtr& m, const std::vector<uint8_t>& rgb) {
  std::vector<uint8_t> mask(static_cast<size_t>(kW) * kH);
  EXPECT_EQ(vc_subtract(m.get(), rgb.data(), 3 * kW, mask.data(), nullptr), 0);
  return mask;
}

// Share of the pixels of rectangle [x0, x1) x [y0, y1) that are foreground.
double fg_share(const std::vector<uint8_t>& mask, int x0, int y0, int x1, int y1) {
  size_t n = 0, fg = 0;
  for (int y = y0; y < y1; y++)
    for (int x = x0; x < x1; x++) {
      n++;
      fg += mask[static_cast<size_t>(y) * kW + x] != 0;
    }
  return static_cast<double>(fg) / n;
}

TEST_P(SubtractVariants, ShadowOverTextureIsRemovedWithoutAnEdgeLine) {
  std::mt19937 rng(11);
  const std::vector<uint8_t> bg = wood(rng);
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  ModelPtr m = model_of(bg, p);
  // A shadow (factor 0.6) over [20, 70) x [15, 55): its edges run through the textured floor.
  auto in = [](int x, int y) { return x >= 20 && x < 70 && y >= 15 && y < 55; };
  const std::vector<uint8_t> frame = render_frame(rng, [&](int x, int y, int c) {
    return bg[(static_cast<size_t>(y) * kW + x) * 3 + c] * (in(x, y) ? 0.6 : 1.0);
  });
  const std::vector<uint8_t> mask = run(m, frame);
  EXPECT_LE(fg_share(mask, 20, 15, 70, 55), 0.005);  // the shadow is background ...
  EXPECT_LE(fg_share(mask, 0, 0, kW, kH), 0.002);    // ... and so is everything else,
  // ... its outline included: a ring of 2 pixels on either side of the edge (no line left behind).
  size_t ring = 0, ring_fg = 0;
  for (int y = 0; y < kH; y++)
    for (int x = 0; x < kW; x++) {
      bool near_edge = false;
      for (int d = -2; d <= 2 && !near_edge; d++)
        near_edge = in(x, y) != in(x + d, y) || in(x, y) != in(x, y + d);
      if (!near_edge) continue;
      ring++;
      ring_fg += mask[static_cast<size_t>(y) * kW + x] != 0;
    }
  EXPECT_GT(ring, 300u);
  EXPECT_LE(ring_fg, ring / 200) << ring_fg << " of " << ring << " outline pixels left as foreground";
}

TEST_P(SubtractVariants, FlatObjectOfTheBackgroundsHueOverTextureIsKept) {
  std::mt19937 rng(12);
  const std::vector<uint8_t> bg = wood(rng);
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  // A flat object of the floor's own hue, 80 % as bright: per pixel it looks like a shadow (angle
  // ~0, alpha ~0.8), but the grain is not in it.
  const double obj[3] = {128, 91.2, 59.2};
  const std::vector<uint8_t> frame = render_frame(rng, [&](int x, int y, int c) {
    return x >= 30 && x < 60 && y >= 20 && y < 50 ? obj[c] : bg[(static_cast<size_t>(y) * kW + x) * 3 + c];
  });
  ModelPtr m = model_of(bg, p);
  std::vector<uint8_t> mask = run(m, frame);
  EXPECT_GE(fg_share(mask, 30, 20, 60, 50), 0.98);  // where the grain is locally flat, a pixel may go
  std::vector<uint8_t> scratch(vc_cleanup_scratch_size(kW));
  ASSERT_EQ(vc_cleanup(mask.data(), kW, kH, 1, scratch.data(), scratch.size()), 0);
  // ... and the edge's clean-up fills it (the majority filter rounds the corners: the interior).
  EXPECT_EQ(fg_share(mask, 31, 21, 59, 49), 1.0);
  p.shadow_texture_k = 0;  // without the window's tests most of it is taken for a shadow
  p.shadow_flat_margin = 0;
  ModelPtr off = model_of(bg, p);
  EXPECT_LE(fg_share(run(off, frame), 30, 20, 60, 50), 0.5);
}

TEST_P(SubtractVariants, ShadedSleeveOverFlatPaintOfItsHueIsKept) {
  std::mt19937 rng(13);
  const double paint[3] = {40, 80, 165}, shirt[3] = {38, 78, 168};  // 1.7 degrees apart
  const std::vector<uint8_t> bg = flat(paint);
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  // A sleeve 12 pixels wide, shaded from 0.35 to 0.95 across (a cylinder's flank): every pixel
  // passes the per-pixel tests; the gradient the wall has not fails the texture test.
  const std::vector<uint8_t> frame = render_frame(rng, [&](int x, int y, int c) {
    return x >= 40 && x < 52 && y >= 10 && y < 62 ? shirt[c] * (0.35 + 0.05 * (x - 40)) : paint[c];
  });
  ModelPtr m = model_of(bg, p);
  EXPECT_GE(fg_share(run(m, frame), 40, 10, 52, 62), 0.95);
  p.shadow_texture_k = 0;
  p.shadow_flat_margin = 0;
  ModelPtr off = model_of(bg, p);
  EXPECT_LE(fg_share(run(off, frame), 40, 10, 52, 62), 0.2);
}

// Beige tiles whose mottle is as faint as the sensor noise: (214,166,130) times 1 +- 2 % per pixel
// (1.5-2.5 grey levels rms, the noise's sigma is 2), the camouflage room's floor at a pixel's scale.
// `mottle`: the per-pixel tone's half range (0.03: 1.5 times the noise).
std::vector<uint8_t> faint_tiles(std::mt19937& rng, double mottle = 0.02) {
  std::uniform_real_distribution<double> u(-mottle, mottle);
  std::vector<uint8_t> img(static_cast<size_t>(kW) * kH * 3);
  const double base[3] = {214, 166, 130};
  for (size_t i = 0; i < img.size(); i += 3) {
    const double g = 1.0 + u(rng);
    for (int c = 0; c < 3; c++) img[i + c] = clamp8(base[c] * g);
  }
  return img;
}

TEST_P(SubtractVariants, ShadowOverFaintTextureStaysShadow) {
  std::mt19937 rng(14);
  const std::vector<uint8_t> bg = faint_tiles(rng);
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  ASSERT_GT(p.shadow_flat_margin, 0.0);
  ModelPtr m = model_of(bg, p);
  // Shadows of 0.6 and 0.8 over the faint tiles: scaled copies of it, so the tiles' luminance scaled
  // explains them better than a flat patch, and both window tests leave them shadow.
  for (double factor : {0.6, 0.8}) {
    const std::vector<uint8_t> frame = render_frame(rng, [&](int x, int y, int c) {
      const bool in = x >= 20 && x < 70 && y >= 15 && y < 55;
      return bg[(static_cast<size_t>(y) * kW + x) * 3 + c] * (in ? factor : 1.0);
    });
    std::vector<uint8_t> mask = run(m, frame);
    EXPECT_LE(fg_share(mask, 20, 15, 70, 55), 0.01) << "shadow factor " << factor;
    EXPECT_LE(fg_share(mask, 0, 0, kW, kH), 0.005) << "shadow factor " << factor;
    // ... and the flat-patch test takes hardly any shadow the texture test alone leaves (at 0.8 that
    // one calls 0.75 % of it foreground: a few pixels whose window the noise tilts; the flat-patch
    // test on the luminance, one channel, adds up to 0.3 % at 0.6), and what it adds is lone pixels
    // that the edge's clean-up removes: after it, no more than the texture test alone leaves.
    vc_subtract_params k_only = p;
    k_only.shadow_flat_margin = 0;
    ModelPtr m_k = model_of(bg, k_only);
    std::vector<uint8_t> mask_k = run(m_k, frame);
    EXPECT_LE(fg_share(mask, 20, 15, 70, 55), fg_share(mask_k, 20, 15, 70, 55) + 0.004)
        << "shadow factor " << factor;
    std::vector<uint8_t> scratch(vc_cleanup_scratch_size(kW));
    for (std::vector<uint8_t>* mk : {&mask, &mask_k})
      ASSERT_EQ(vc_cleanup(mk->data(), kW, kH, 1, scratch.data(), scratch.size()), 0);
    EXPECT_LE(fg_share(mask, 20, 15, 70, 55), fg_share(mask_k, 20, 15, 70, 55)) << "shadow factor " << factor;
  }
}

TEST_P(SubtractVariants, SkinOverFaintTextureOfItsHueIsKept) {
  std::mt19937 rng(15);
  const std::vector<uint8_t> bg = faint_tiles(rng);
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  // Skin of the tiles' hue, darker (0.8, then a shaded 0.65): per pixel a shadow (angle ~0, alpha
  // in the band), and the tiles' texture is within the noise, so the texture test with its k keeps
  // only a part of it; but the skin is flat where the tiles are not, which the flat-patch test sees.
  for (double shade : {0.8, 0.65}) {
    const double skin[3] = {214 * shade, 166 * shade, 130 * shade};
    const std::vector<uint8_t> frame = render_frame(rng, [&](int x, int y, int c) {
      return x >= 30 && x < 60 && y >= 20 && y < 50 ? skin[c] : bg[(static_cast<size_t>(y) * kW + x) * 3 + c];
    });
    ModelPtr m = model_of(bg, p);
    std::vector<uint8_t> mask = run(m, frame);
    EXPECT_GE(fg_share(mask, 30, 20, 60, 50), 0.97) << "shade " << shade;
    std::vector<uint8_t> scratch(vc_cleanup_scratch_size(kW));
    ASSERT_EQ(vc_cleanup(mask.data(), kW, kH, 1, scratch.data(), scratch.size()), 0);
    EXPECT_GE(fg_share(mask, 31, 21, 59, 49), 0.985) << "shade " << shade;  // the clean-up fills most
    EXPECT_LE(fg_share(mask, 0, 0, 29, kH), 0.002) << "shade " << shade;    // the tiles beside it stay
    // The same frame with the texture test alone (the rule before the flat-patch test) loses most
    // of it (measured: under 1 %): the tiles' texture does not rise above k noise sigmas.
    vc_subtract_params old = p;
    old.shadow_flat_margin = 0;
    ModelPtr m_old = model_of(bg, old);
    EXPECT_LE(fg_share(run(m_old, frame), 30, 20, 60, 50), 0.05) << "shade " << shade;
  }
}

// Skin of the tiles' hue in deep shade, as dark as the deepest shadow (alpha ~0.46 against the
// shadow bound 0.45), over tiles whose mottle is 1.5 times the noise's (6.5 noise variances of L a
// pixel): the tiles' mottle and the noise spread the pixels' ratio across eq. 2's gain bound, and the
// part of the skin below it was left out of the windows' fits. The fits then saw only the pixels the
// bound let through, those over the darker tiles: the survivors of a cut at a fixed ratio follow the
// background even over a flat surface, so they look like the tiles scaled, and the window tests called
// much of the skin shadow (the `beige` hand's shaded side over the camouflage room's tiles). With the
// pixels below the bound in the fits (foreground themselves), the windows see the skin flat.
TEST_P(SubtractVariants, DeepShadedSkinAtTheShadowBoundOverTilesIsKept) {
  std::mt19937 rng(16);
  const std::vector<uint8_t> bg = faint_tiles(rng, 0.03);
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  ASSERT_EQ(p.shadow_min_gain, 0.45);
  ModelPtr m = model_of(bg, p);
  std::vector<uint8_t> scratch(vc_cleanup_scratch_size(kW));
  auto cleaned = [&](std::vector<uint8_t> mask) {
    EXPECT_EQ(vc_cleanup(mask.data(), kW, kH, 1, scratch.data(), scratch.size()), 0);
    return mask;
  };
  const double skin[3] = {205, 160, 128};  // the `beige` skin, ~4 % darker than the tiles
  for (double shade : {0.465, 0.47}) {
    const std::vector<uint8_t> frame = render_frame(rng, [&](int x, int y, int c) {
      return x >= 30 && x < 60 && y >= 20 && y < 50 ? skin[c] * shade
                                                    : bg[(static_cast<size_t>(y) * kW + x) * 3 + c];
    });
    const std::vector<uint8_t> mask = run(m, frame);
    ASSERT_EQ(mask, integer_subtract(m.get(), p, frame)) << "shade " << shade;
    // Measured (shade 0.465 / 0.47): 85.0 / 84.1 % of the skin foreground, 93.0 / 92.5 % of its
    // interior after the clean-up; the rule before: 68.9 / 65.7 %, 80.1 / 71.7 %.
    const std::vector<uint8_t> before = integer_subtract(m.get(), p, frame, false);
    EXPECT_GE(fg_share(mask, 30, 20, 60, 50), 0.82) << "shade " << shade;
    EXPECT_LE(fg_share(before, 30, 20, 60, 50), 0.72) << "shade " << shade;
    EXPECT_GE(fg_share(cleaned(mask), 31, 21, 59, 49), 0.91) << "shade " << shade;
    EXPECT_LE(fg_share(cleaned(before), 31, 21, 59, 49), 0.82) << "shade " << shade;
    EXPECT_LE(fg_share(cleaned(mask), 0, 0, 29, kH), 0.002) << "shade " << shade;  // the tiles beside it
  }
  // Shadows over the same tiles, down to near the bound: scaled copies of them, still removed (their
  // pixels below the bound are few and a scaled copy too), exactly as before after the clean-up.
  for (double factor : {0.5, 0.6}) {
    const std::vector<uint8_t> frame = render_frame(rng, [&](int x, int y, int c) {
      const bool in = x >= 20 && x < 70 && y >= 15 && y < 55;
      return bg[(static_cast<size_t>(y) * kW + x) * 3 + c] * (in ? factor : 1.0);
    });
    const std::vector<uint8_t> mask = run(m, frame);
    ASSERT_EQ(mask, integer_subtract(m.get(), p, frame)) << "shadow factor " << factor;
    EXPECT_LE(fg_share(mask, 20, 15, 70, 55), 0.01) << "shadow factor " << factor;
    EXPECT_LE(fg_share(cleaned(mask), 0, 0, kW, kH), 0.002) << "shadow factor " << factor;
    EXPECT_EQ(cleaned(mask), cleaned(integer_subtract(m.get(), p, frame, false)))
        << "shadow factor " << factor;
  }
}

TEST_P(SubtractVariants, FixedPointMatchesTheDoubleRuleOnRandomInputs) {
  std::mt19937 rng(21);
  std::uniform_int_distribution<int> byte(0, 255), sig(64, 1536), coin(0, 3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  size_t total = 0, same = 0, candidates = 0;
  for (int round = 0; round < 12; round++) {
    std::vector<uint8_t> mean(static_cast<size_t>(kW) * kH * 3);
    std::vector<uint16_t> sigma(mean.size());
    for (size_t i = 0; i < mean.size(); i++) {
      mean[i] = static_cast<uint8_t>(byte(rng));
      sigma[i] = static_cast<uint16_t>(sig(rng));
    }
    vc_subtract_params p;
    vc_subtract_params_default(&p);
    p.t_lower = 1.5 + 3.0 * unit(rng);
    p.t_upper = p.t_lower + 70.0 * unit(rng);
    const double angle = (2.0 + 14.0 * unit(rng)) * M_PI / 180.0;
    p.cos2_angular = std::cos(angle) * std::cos(angle);
    p.shadow_min_gain = 0.6 * unit(rng);
    p.shadow_max_gain = p.shadow_min_gain + (1.0 - p.shadow_min_gain) * unit(rng);
    p.sigma_floor = 0.5 + 2.0 * unit(rng);
    p.shadow_texture_k = round % 4 == 0 ? 0.0 : 0.5 + 4.0 * unit(rng);
    p.shadow_flat_margin = round % 3 == 0 ? 0.0 : 2.0 * unit(rng);
    ModelPtr m = new_model(kW, kH);
    ASSERT_EQ(vc_bgmodel_restore(m.get(), mean.data(), sigma.data(), 30), 0);
    ASSERT_EQ(vc_bgmodel_set_params(m.get(), &p), 0);
    // Regions darkened by one gain (shadow-like, many candidates), random pixels and the mean.
    std::vector<uint8_t> frame(mean.size());
    const double gain = 0.3 + 0.7 * unit(rng);
    std::normal_distribution<double> noise(0.0, 1.0 + 3.0 * unit(rng));
    for (size_t i = 0; i < frame.size(); i += 3) {
      const int kind = coin(rng) == 0 ? 2 : ((i / 3) % kW) / 24;  // columns in 4 bands, some random
      for (int c = 0; c < 3; c++) {
        const double mu = mean[i + c];
        frame[i + c] = kind == 0   ? clamp8(mu + noise(rng))
                       : kind == 1 ? clamp8(gain * mu + noise(rng))
                       : kind == 2 ? static_cast<uint8_t>(byte(rng))
                                   : clamp8(0.9 * gain * mu + noise(rng));
      }
    }
    vc_subtract_stats st;
    std::vector<uint8_t> mask(static_cast<size_t>(kW) * kH);
    ASSERT_EQ(vc_subtract(m.get(), frame.data(), 3 * kW, mask.data(), &st), 0);
    const std::vector<uint8_t> ref = reference_subtract(m.get(), p, frame);
    for (size_t i = 0; i < mask.size(); i++) {
      ASSERT_TRUE(mask[i] == 0 || mask[i] == 255) << i;
      same += mask[i] == ref[i];
    }
    total += mask.size();
    candidates += st.band;
  }
  EXPECT_GT(candidates, total / 10) << "the inputs must exercise the shadow and texture tests";
  EXPECT_GE(static_cast<double>(same) / total, 0.9999) << (total - same) << " pixels differ";
}

// The kernel gives the plain integer rule's mask bit for bit (integer_subtract above): with both
// kernel variants, widths around the vector and bitmap word sizes (31 .. 130 pixels), frames with
// shadows, people, random pixels and whole shadow-like regions, texture test on and off.
TEST_P(SubtractVariants, SameMaskAsThePlainIntegerRuleBitForBit) {
  std::mt19937 rng(31);
  std::uniform_int_distribution<int> byte(0, 255), sig(64, 1536), coin(0, 3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int widths[] = {31, 32, 33, 63, 64, 65, 97, 130, 7, 1};
  size_t band = 0, pixels = 0;
  for (int round = 0; round < 20; round++) {
    const int w = widths[round % 10], h = 2 + (round * 7) % 23;
    std::vector<uint8_t> mean(static_cast<size_t>(w) * h * 3);
    std::vector<uint16_t> sigma(mean.size());
    for (size_t i = 0; i < mean.size(); i++) {
      mean[i] = static_cast<uint8_t>(byte(rng));
      sigma[i] = static_cast<uint16_t>(sig(rng));
    }
    vc_subtract_params p;
    vc_subtract_params_default(&p);
    if (round % 2 == 1) {  // defaults on even rounds, random thresholds on odd ones
      p.t_lower = 1.5 + 3.0 * unit(rng);
      p.t_upper = p.t_lower + 70.0 * unit(rng);
      const double angle = (2.0 + 14.0 * unit(rng)) * M_PI / 180.0;
      p.cos2_angular = std::cos(angle) * std::cos(angle);
      p.shadow_min_gain = 0.6 * unit(rng);
      p.shadow_max_gain = p.shadow_min_gain + (1.0 - p.shadow_min_gain) * unit(rng);
      p.sigma_floor = 0.5 + 2.0 * unit(rng);
      p.shadow_texture_k = round % 3 == 0 ? 0.0 : 0.5 + 4.0 * unit(rng);
      p.shadow_flat_margin = round % 5 == 1 ? 0.0 : std::ldexp(std::floor(512.0 * unit(rng)), -8);
    }
    vc_bgmodel* raw = nullptr;
    ASSERT_EQ(vc_bgmodel_new(w, h, &raw, nullptr, 0), 0);
    ModelPtr m(raw);
    ASSERT_EQ(vc_bgmodel_restore(m.get(), mean.data(), sigma.data(), 30), 0);
    ASSERT_EQ(vc_bgmodel_set_params(m.get(), &p), 0);
    const double gain = 0.3 + 0.7 * unit(rng);
    std::normal_distribution<double> noise(0.0, 1.0 + 3.0 * unit(rng));
    std::vector<uint8_t> frame(mean.size());
    for (size_t i = 0; i < frame.size(); i += 3) {
      const int kind = coin(rng) == 0 ? 2 : static_cast<int>(((i / 3) % w) / 9 % 4);
      for (int c = 0; c < 3; c++) {
        const double mu = mean[i + c];
        frame[i + c] = kind == 0   ? clamp8(mu + noise(rng))
                       : kind == 1 ? clamp8(gain * mu + noise(rng))
                       : kind == 2 ? static_cast<uint8_t>(byte(rng))
                                   : clamp8(0.9 * gain * mu + noise(rng));
      }
    }
    std::vector<uint8_t> mask(static_cast<size_t>(w) * h);
    vc_subtract_stats st;
    ASSERT_EQ(vc_subtract(m.get(), frame.data(), 3 * static_cast<size_t>(w), mask.data(), &st), 0);
    EXPECT_EQ(mask, integer_subtract(m.get(), p, frame)) << "round " << round << ", " << w << "x" << h;
    band += st.band;
    pixels += mask.size();
  }
  // The synthetic scene of the other tests too, frame after frame with moving blobs.
  Scene s = test_scene();
  ModelPtr m = learn(s, 30, rng);
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  ASSERT_EQ(vc_bgmodel_set_params(m.get(), &p), 0);
  std::vector<uint8_t> rgb, mask(static_cast<size_t>(s.width) * s.height);
  for (int f = 0; f < 4; f++) {
    for (Blob& b : s.people) b.cx += 4;
    s.render(rng, rgb, nullptr);
    ASSERT_EQ(vc_subtract(m.get(), rgb.data(), 3 * static_cast<size_t>(s.width), mask.data(), nullptr), 0);
    EXPECT_EQ(mask, integer_subtract(m.get(), p, rgb)) << "scene frame " << f;
  }
  EXPECT_GT(band, pixels / 10) << "the inputs must exercise the shadow and texture tests";
}

TEST(SubtractParams, GainsAndTextureKAreBounded) {
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  EXPECT_EQ(p.shadow_texture_k, VC_SUBTRACT_SHADOW_TEXTURE_K);
  char why[128];
  p.shadow_max_gain = 1.2;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), -EINVAL);
  EXPECT_NE(std::string(why).find("shadow_max_gain"), std::string::npos) << why;
  vc_subtract_params_default(&p);
  p.shadow_texture_k = -1;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), -EINVAL);
  EXPECT_NE(std::string(why).find("shadow_texture_k"), std::string::npos) << why;
  p.shadow_texture_k = VC_SUBTRACT_SHADOW_TEXTURE_K_MAX + 1;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), -EINVAL);
  p.shadow_texture_k = 0;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), 0);
  EXPECT_EQ(p.shadow_flat_margin, VC_SUBTRACT_SHADOW_FLAT_MARGIN);
  p.shadow_flat_margin = -0.5;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), -EINVAL);
  EXPECT_NE(std::string(why).find("shadow_flat_margin"), std::string::npos) << why;
  p.shadow_flat_margin = VC_SUBTRACT_SHADOW_FLAT_MARGIN_MAX + 1;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), -EINVAL);
  p.shadow_flat_margin = 0;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), 0);
}

// ---- the limb-scale cue (grow_px, grow_sigma) -----------------------------------------------------

// The cue of bgmodel.h on a clean mask (subtracted and cleaned up without it), in plain loops: the first ring
// is the background pixels with a foreground 4-neighbour, each ring's weak pixels (eq. 1's background in
// every channel and |p - mu|^2 >= grow_sigma^2 sum_c s_c^2, in the kernel's integers; or foreground in
// `raw`, the subtraction's mask before the clean-up, with another such pixel among its 8 neighbours that
// the clean mask does not hold) become foreground and queue their 4-neighbours that are background and
// not yet queued, for grow_px rings.
std::vector<uint8_t> reference_grow(const vc_bgmodel* m, const vc_subtract_params& p,
                                    const std::vector<uint8_t>& rgb, std::vector<uint8_t> mask,
                                    const std::vector<uint8_t>& raw) {
  const int w = vc_bgmodel_width(m), h = vc_bgmodel_height(m);
  const uint8_t* mean = vc_bgmodel_mean(m);
  const uint16_t* sigma_q8 = vc_bgmodel_sigma_q8(m);
  const uint64_t floor_q8 = static_cast<uint64_t>(std::llround(p.sigma_floor * 256.0));
  const uint64_t grow_q8 = static_cast<uint64_t>(std::llround(p.grow_sigma * p.grow_sigma * 256.0));
  // grow_flat: the background's luminance over the 5x5 window (clipped) varies by less than grow_flat
  // noise variances of L (sum_c s_c^2) at the pixel
  auto flat_background = [&](size_t i) {
    const int x = static_cast<int>(i % w), y = static_cast<int>(i / w);
    double s = 0, s2 = 0, n = 0, v = 0;
    for (int yy = std::max(0, y - 2); yy <= std::min(h - 1, y + 2); yy++)
      for (int xx = std::max(0, x - 2); xx <= std::min(w - 1, x + 2); xx++) {
        const size_t j = static_cast<size_t>(yy) * w + xx;
        const double l = static_cast<double>(mean[3 * j]) + mean[3 * j + 1] + mean[3 * j + 2];
        s += l;
        s2 += l * l;
        n++;
      }
    for (int c = 0; c < 3; c++) {
      const double sg =
          std::max(static_cast<double>(sigma_q8[3 * i + c]), static_cast<double>(floor_q8)) / 256.0;
      v += sg * sg;
    }
    return (n * s2 - s * s) / (n * n) < p.grow_flat * v;
  };
  const std::vector<uint8_t> clean = mask;
  auto cut_off = [&](size_t i) {  // what the clean-up took away from a structure of 2 or more pixels
    if (raw[i] == 0) return false;
    const int x = static_cast<int>(i % w), y = static_cast<int>(i / w);
    for (int yy = std::max(0, y - 1); yy <= std::min(h - 1, y + 1); yy++)
      for (int xx = std::max(0, x - 1); xx <= std::min(w - 1, x + 1); xx++) {
        const size_t j = static_cast<size_t>(yy) * w + xx;
        if (j != i && raw[j] != 0 && clean[j] == 0) return true;
      }
    return false;
  };
  auto weak = [&](size_t i) {
    if (cut_off(i)) return true;
    uint64_t d2 = 0, v = 0;
    for (int c = 0; c < 3; c++) {
      const double sigma = std::max(sigma_q8[3 * i + c] / 256.0, p.sigma_floor);
      const int tl = static_cast<int>(std::min(255.0, std::ceil(p.t_lower * sigma) - 1.0));
      if (rgb[3 * i + c] < std::max(mean[3 * i + c] - tl, 0)) return flat_background(i);  // the shadow band
      const int64_t d = static_cast<int64_t>(rgb[3 * i + c]) - mean[3 * i + c];
      const uint64_t s = std::max<uint64_t>(sigma_q8[3 * i + c], floor_q8);
      d2 += static_cast<uint64_t>(d * d);
      v += s * s;
    }
    return (d2 << 24) >= grow_q8 * v;
  };
  const int steps = static_cast<int>(p.grow_px);
  if (steps == 0 || w < 3 || h < 3) return mask;
  std::vector<uint8_t> queued(mask.size(), 0);
  std::vector<size_t> ring;
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (mask[i] != 0) continue;
      int n = 0;  // foreground 4-neighbours
      for (int k = 0; k < 4; k++) {
        const int dx = k == 0 ? -1 : k == 1 ? 1 : 0, dy = k == 2 ? -1 : k == 3 ? 1 : 0;
        if (x + dx >= 0 && x + dx < w && y + dy >= 0 && y + dy < h)
          n += mask[static_cast<size_t>(y + dy) * w + x + dx] == 255;
      }
      if (n >= 1) ring.push_back(i);
    }
  for (size_t i : ring) queued[i] = 1;
  for (int step = 1; step <= steps && !ring.empty(); step++) {
    std::vector<size_t> next;
    for (size_t i : ring) {
      if (!weak(i)) continue;
      mask[i] = VC_MASK_GROWN;
      const int x = static_cast<int>(i % w), y = static_cast<int>(i / w);
      const int nx[4] = {x - 1, x + 1, x, x}, ny[4] = {y, y, y - 1, y + 1};
      for (int k = 0; k < 4; k++) {
        if (nx[k] < 0 || nx[k] >= w || ny[k] < 0 || ny[k] >= h) continue;
        const size_t j = static_cast<size_t>(ny[k]) * w + nx[k];
        if (mask[j] == 0 && !queued[j]) {
          queued[j] = 1;
          next.push_back(j);
        }
      }
    }
    ring.swap(next);
  }
  return mask;
}

// The edge's whole sequence (vc_mask_frame: subtraction, 3x3 clean-up, the cue when it is on).
std::vector<uint8_t> run_frame(const ModelPtr& m, const std::vector<uint8_t>& rgb,
                               vc_subtract_stats* st = nullptr) {
  std::vector<uint8_t> mask(static_cast<size_t>(kW) * kH), scratch(vc_cleanup_scratch_size(kW));
  EXPECT_EQ(vc_mask_frame(m.get(), rgb.data(), 3 * kW, mask.data(), 1, scratch.data(), scratch.size(), st),
            0);
  return mask;
}

// Faint beige tiles (the camouflage room's floor at a pixel's scale), a body block that the
// subtraction sees (darker, another hue), a strip of "skin" beside it that is the floor's colour
// lifted by 4 grey levels per channel (2 noise sigmas: eq. 1 calls most of it background), a floor
// shadow touching the block's other side, and far from all of it the floor alone.
struct CueScene {
  std::vector<uint8_t> bg, frame;
};
CueScene cue_scene(std::mt19937& rng) {
  CueScene s;
  s.bg = faint_tiles(rng);
  s.frame = render_frame(rng, [&](int x, int y, int c) {
    const double b = s.bg[(static_cast<size_t>(y) * kW + x) * 3 + c];
    if (y < 10 || y >= 60) return b;
    if (x >= 30 && x < 46) return std::array<double, 3>{120, 60, 40}[static_cast<size_t>(c)];  // the body
    if (x >= 46 && x < 50) return b + 4.0;                                                     // camouflaged
    if (x >= 14 && x < 30) return b * 0.6;                                                     // its shadow
    return b;
  });
  return s;
}

TEST_P(SubtractVariants, LimbScaleCueKeepsCamouflagedSkinJoinedToTheBody) {
  std::mt19937 rng(41);
  const CueScene s = cue_scene(rng);
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  p.grow_px = 0;
  ModelPtr off = model_of(s.bg, p);
  p.grow_px = 4;
  ModelPtr on = model_of(s.bg, p);
  const std::vector<uint8_t> without = run_frame(off, s.frame), with = run_frame(on, s.frame);
  // vc_subtract alone leaves the cue to the clean-up's step (stats.grown 0, the same mask):
  EXPECT_EQ(run(on, s.frame), run(off, s.frame));
  // The strip, 4 pixels wide, within the cue's reach of the body: eq. 1 keeps a quarter of its pixels
  // (where the noise lifts a channel over 3.5 sigma) and the clean-up few of those, the cue most of
  // the rest (a pixel the noise takes back under 1.5 pooled sigmas ends its row's path).
  EXPECT_LE(fg_share(without, 46, 10, 50, 60), 0.5);
  EXPECT_GE(fg_share(with, 46, 10, 50, 60), 0.75);  // 0.82 here, against 0.25 without the cue
  EXPECT_GE(fg_share(with, 46, 10, 50, 60), fg_share(without, 46, 10, 50, 60) + 0.4);
  EXPECT_GE(fg_share(with, 30, 10, 46, 60), 0.99);  // the body itself (the clean-up rounds its corners)
  EXPECT_GE(fg_share(with, 30, 10, 46, 60), fg_share(without, 30, 10, 46, 60));
  // The floor shadow touching the body is in the band, which the cue does not enter ...
  EXPECT_LE(fg_share(with, 14, 10, 30, 60), fg_share(without, 14, 10, 30, 60) + 0.005);
  EXPECT_LE(fg_share(with, 14, 10, 30, 60), 0.01);
  // ... and the floor's noise alone does not form regions for it to grow from: beyond the strip's
  // reach (4 pixels past it) the cue adds nothing, and the empty rows keep their few speckles.
  EXPECT_EQ(fg_share(with, 55, 0, kW, kH), fg_share(without, 55, 0, kW, kH));
  EXPECT_LE(fg_share(with, 0, 0, kW, 8), 0.005);
}

// Flat paint (the camouflage room's wall, at a pixel's scale) behind a body block that the
// subtraction sees, a sleeve of the paint's own hue beside it, shaded to 0.7 (per pixel and per window
// a shadow: a scaled copy of a flat background), 4 pixels wide, and apart from both a true shadow of
// the same depth on the same paint.
CueScene paint_scene(std::mt19937& rng) {
  CueScene s;
  const double paint[3] = {50, 118, 62};
  s.bg = flat(paint);
  s.frame = render_frame(rng, [&](int x, int y, int c) {
    const double b = paint[c];
    if (y < 10 || y >= 60) return b;
    if (x >= 30 && x < 46) return std::array<double, 3>{200, 150, 120}[static_cast<size_t>(c)];  // the body
    if (x >= 46 && x < 50) return 0.7 * b;                                                       // the sleeve
    if (x >= 70 && x < 86) return 0.7 * b;  // a shadow, not joined to the body
    return b;
  });
  return s;
}

TEST_P(SubtractVariants, LimbScaleCueEntersTheShadowBandOnlyOverAFlatBackground) {
  std::mt19937 rng(47);
  const CueScene s = paint_scene(rng);
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  ASSERT_GT(p.grow_flat, 0.0);
  ModelPtr on = model_of(s.bg, p);
  p.grow_flat = 0;  // the cue outside the band only (the rule before grow_flat)
  ModelPtr off = model_of(s.bg, p);
  const std::vector<uint8_t> without = run_frame(off, s.frame), with = run_frame(on, s.frame);
  // The sleeve passes every shadow test (the paint has no texture to compare): lost without ...
  EXPECT_LE(fg_share(without, 46, 10, 50, 60), 0.05);
  // ... kept with it, as the cue's pixels
  EXPECT_GE(fg_share(with, 46, 10, 50, 60), 0.99);
  EXPECT_EQ(with[static_cast<size_t>(30) * kW + 47], VC_MASK_GROWN);
  // The shadow on the same paint, not joined to the body, stays background, and so does the paint
  // beyond the sleeve (outside the band, within the noise).
  EXPECT_LE(fg_share(with, 70, 10, 86, 60), 0.005);
  EXPECT_LE(fg_share(with, 51, 10, 70, 60), 0.01);
  // Over a textured floor the band is not entered: the faint tiles' shadow touching the body
  // (cue_scene) is left as the cue outside the band leaves it.
  const CueScene t = cue_scene(rng);
  vc_subtract_params q;
  vc_subtract_params_default(&q);
  ModelPtr tiles_on = model_of(t.bg, q);
  q.grow_flat = 0;
  ModelPtr tiles_off = model_of(t.bg, q);
  const std::vector<uint8_t> t_with = run_frame(tiles_on, t.frame), t_without = run_frame(tiles_off, t.frame);
  EXPECT_EQ(fg_share(t_with, 14, 10, 30, 60), fg_share(t_without, 14, 10, 30, 60));
  // (1.25 %, 10 of its 800 pixels: the subtraction's specks of 2 or more pixels joined to the body's
  // edge, which the thin-part rule gives back as it gives back a finger; within 1 % before it)
  EXPECT_LE(fg_share(t_with, 14, 10, 30, 60), 0.015);
  // ... nor over wood grain: a shadow of 0.6 touching a body block
  const std::vector<uint8_t> bg = wood(rng);
  const std::vector<uint8_t> frame = render_frame(rng, [&](int x, int y, int c) {
    const double b = bg[(static_cast<size_t>(y) * kW + x) * 3 + c];
    if (y < 10 || y >= 60) return b;
    if (x >= 30 && x < 46) return std::array<double, 3>{60, 90, 200}[static_cast<size_t>(c)];
    if (x >= 14 && x < 30) return 0.6 * b;
    return b;
  });
  vc_subtract_params r;
  vc_subtract_params_default(&r);
  ModelPtr wood_on = model_of(bg, r);
  r.grow_flat = 0;
  ModelPtr wood_off = model_of(bg, r);
  EXPECT_EQ(run_frame(wood_on, frame), run_frame(wood_off, frame));
}

TEST_P(SubtractVariants, LimbScaleCueEqualsItsPlainReference) {
  std::mt19937 rng(43);
  for (int round = 0; round < 8; round++) {
    const CueScene s = round < 6 ? cue_scene(rng) : paint_scene(rng);
    vc_subtract_params p;
    vc_subtract_params_default(&p);
    p.grow_px = 0;
    ModelPtr off = model_of(s.bg, p);
    const std::vector<uint8_t> base = run_frame(off, s.frame);  // subtracted and cleaned, no cue
    p.grow_px = 1 + round % 5;
    p.grow_sigma = round < 3 || round >= 6 ? 1.5 : 0.8 + 0.4 * round;
    p.grow_flat = round == 5 ? 0.0 : round == 4 ? 3.0 : VC_SUBTRACT_GROW_FLAT;
    ModelPtr on = model_of(s.bg, p);
    vc_subtract_stats st{};
    const std::vector<uint8_t> mask = run_frame(on, s.frame, &st);
    const std::vector<uint8_t> ref = reference_grow(on.get(), p, s.frame, base, run(off, s.frame));
    EXPECT_EQ(mask, ref) << "round " << round;
    size_t grown = 0;
    for (size_t i = 0; i < mask.size(); i++) grown += mask[i] != base[i];
    EXPECT_EQ(st.grown, grown);
    EXPECT_GT(grown, 0u);
    // The cue's pixels are VC_MASK_GROWN, the clean mask's VC_MASK_FG; without the cue's, the mask
    // is the clean one (what the edge's tracker gets), in place or not.
    std::vector<uint8_t> ungrown(mask.size(), 0x5A);
    vc_mask_ungrown(mask.data(), mask.size(), ungrown.data());
    EXPECT_EQ(ungrown, base) << "round " << round;
    std::vector<uint8_t> in_place = mask;
    vc_mask_ungrown(in_place.data(), in_place.size(), in_place.data());
    EXPECT_EQ(in_place, base) << "round " << round;
  }
}

// Thin parts joined to the body (session 15): over oak boards (textured: the cue does not enter the
// shadow band there), a body block and two limbs of a colour darker than the boards and off their hue
// by 10.6 degrees, so every pixel of them is in the shadow band and foreground by eq. 2 alone (not a
// weak pixel of the cue): a forearm 2 pixels wide and 16 long, a quarter of whose pixels the
// subtraction misses (drawn as the boards), and a finger 1 pixel wide and 4 long. Apart from the body,
// specks of the same colour: single pixels, pairs, and a line 1 pixel wide and 8 long.
struct ThinScene {
  std::vector<uint8_t> bg, frame;
  std::vector<uint8_t> limb;  // 1 where the frame shows a limb pixel (not a missed one)
};
ThinScene thin_scene(std::mt19937& rng) {
  ThinScene s;
  s.bg = wood(rng);
  s.limb.assign(static_cast<size_t>(kW) * kH, 0);
  auto body = [](int x, int y) { return x >= 20 && x < 40 && y >= 10 && y < 60; };
  auto forearm = [](int x, int y) {
    return x >= 40 && x < 56 && (y == 30 || y == 31) && (x * 7 + y * 3) % 4 != 0;
  };
  auto finger = [](int x, int y) { return x >= 40 && x < 44 && y == 45; };
  auto speck = [](int x, int y) {
    return ((x == 70 || x == 80) && y == 20) || (x >= 74 && x < 76 && y == 40) ||
           (x >= 66 && x < 74 && y == 55);
  };
  for (int y = 0; y < kH; y++)
    for (int x = 0; x < kW; x++) s.limb[static_cast<size_t>(y) * kW + x] = forearm(x, y) || finger(x, y);
  s.frame = render_frame(rng, [&](int x, int y, int c) {
    const double b = s.bg[(static_cast<size_t>(y) * kW + x) * 3 + c];
    const double gain[3] = {0.55, 0.8, 0.8};
    return body(x, y) || forearm(x, y) || finger(x, y) || speck(x, y) ? gain[c] * b : b;
  });
  return s;
}

TEST_P(SubtractVariants, CleanupGivesBackThinPartsJoinedToTheBodyNotSpecks) {
  std::mt19937 rng(53);
  const ThinScene s = thin_scene(rng);
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  ModelPtr on = model_of(s.bg, p);
  p.grow_px = 0;  // the clean-up alone
  ModelPtr off = model_of(s.bg, p);
  const std::vector<uint8_t> raw = run(on, s.frame), with = run_frame(on, s.frame),
                             without = run_frame(off, s.frame);
  size_t limb = 0, raw_fg = 0, kept_with = 0, kept_without = 0;
  for (size_t i = 0; i < raw.size(); i++) {
    if (!s.limb[i]) continue;
    limb++;
    raw_fg += raw[i] != 0;
    kept_with += raw[i] != 0 && with[i] != 0;
    kept_without += raw[i] != 0 && without[i] != 0;
  }
  // The subtraction sees the limbs (eq. 2: off the boards' hue) ...
  ASSERT_EQ(limb, 24u + 4u);
  EXPECT_GE(raw_fg, limb - 1);
  // ... the 3x3 majority takes nearly half of them away (the finger but its root, the gapped forearm's
  // pixels with fewer than 5 of 9: 15 of 28 kept here) ...
  EXPECT_LE(kept_without, raw_fg * 6 / 10);
  EXPECT_LE(fg_share(without, 40, 45, 44, 46), 0.25);
  // ... and the cue gives every one of them back, as its pixels (the tracker's mask keeps the filter's)
  EXPECT_EQ(kept_with, raw_fg);
  EXPECT_EQ(fg_share(with, 40, 45, 44, 46), 1.0);
  EXPECT_EQ(with[static_cast<size_t>(45) * kW + 43], VC_MASK_GROWN);
  // The specks apart from the body stay removed: single pixels, the pair, the thin line ...
  EXPECT_EQ(fg_share(with, 60, 0, kW, kH), 0.0);
  EXPECT_EQ(fg_share(without, 60, 0, kW, kH), 0.0);
  EXPECT_GE(fg_share(raw, 66, 55, 74, 56), 0.99);  // (the subtraction did see the line)
  // ... and the body itself is what the filter keeps, the boards around it background.
  EXPECT_GE(fg_share(with, 21, 11, 39, 59), 0.99);
  EXPECT_LE(fg_share(with, 0, 0, 18, kH), 0.005);
}

// Every radius of the clean-up (0 normalises, 1 the vectorised 3x3, 2 and 3 the running sums) leaves
// the subtraction's mask for the cue where it keeps its originals' rows: the cue equals its plain
// reference on that radius's clean mask and the subtraction's.
TEST_P(SubtractVariants, CleanupGivesBackWhatEachRadiusTookAway) {
  std::mt19937 rng(59);
  for (int radius = 0; radius <= 3; radius++) {
    const ThinScene s = thin_scene(rng);
    vc_subtract_params p;
    vc_subtract_params_default(&p);
    ModelPtr m = model_of(s.bg, p);
    const std::vector<uint8_t> raw = run(m, s.frame);
    std::vector<uint8_t> base = raw, mask = raw;
    std::vector<uint8_t> scratch(vc_cleanup_radius_scratch_size(kW, 3));
    ASSERT_EQ(vc_cleanup_radius(base.data(), kW, kH, radius, scratch.data(), scratch.size()), 0);
    uint32_t grown = 0;
    ASSERT_EQ(vc_cleanup_grow(m.get(), s.frame.data(), 3 * kW, mask.data(), radius, scratch.data(),
                              scratch.size(), &grown),
              0);
    EXPECT_EQ(mask, reference_grow(m.get(), p, s.frame, base, raw)) << "radius " << radius;
    if (radius >= 1) EXPECT_GT(grown, 0u) << "radius " << radius;
  }
}

TEST(SubtractParams, LimbScaleCueRanges) {
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  EXPECT_EQ(p.grow_px, VC_SUBTRACT_GROW_PX);
  EXPECT_EQ(p.grow_sigma, VC_SUBTRACT_GROW_SIGMA);
  char why[160];
  p.grow_px = 2.5;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), -EINVAL);
  EXPECT_NE(std::string(why).find("grow_px"), std::string::npos) << why;
  p.grow_px = VC_SUBTRACT_GROW_PX_MAX + 1;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), -EINVAL);
  p.grow_px = 3;
  p.grow_sigma = 0;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), -EINVAL);
  EXPECT_NE(std::string(why).find("grow_sigma"), std::string::npos) << why;
  p.grow_sigma = 2;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), 0);
  EXPECT_EQ(p.grow_flat, VC_SUBTRACT_GROW_FLAT);
  p.grow_flat = -0.5;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), -EINVAL);
  EXPECT_NE(std::string(why).find("grow_flat"), std::string::npos) << why;
  p.grow_flat = VC_SUBTRACT_GROW_FLAT_MAX + 1;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), -EINVAL);
  p.grow_flat = 0;
  EXPECT_EQ(vc_subtract_params_check(&p, why, sizeof why), 0);
}

INSTANTIATE_TEST_SUITE_P(Kernels, SubtractVariants, ::testing::Values("generic", "avx2", "neon"),
                         [](const auto& p) { return std::string(p.param); });

TEST(EdgeKernels, SelectRejectsUnknownNames) {
  EXPECT_EQ(vc_edge_kernel_select("sse9"), -EINVAL);
  EXPECT_EQ(vc_edge_kernel_select(nullptr), -EINVAL);
  EXPECT_EQ(vc_edge_kernel_select("auto"), 0);
}

}  // namespace
