// The trigger box's pure logic: clock plan, pulse pattern, echo edge counting, underrun ledger and
// timebase — everything around the libftdi calls.
#include "voxcap/trigger/bitbang.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace vc::trigger {
namespace {

// The whole stream of a finite pattern, generated in chunks of `chunk` bytes.
std::vector<uint8_t> generate(BitbangPattern& p, size_t chunk, size_t max = 10'000'000) {
  std::vector<uint8_t> out;
  std::vector<uint8_t> buf(chunk);
  while (out.size() < max) {
    const size_t n = p.fill(buf.data(), buf.size());
    if (n == 0) break;
    out.insert(out.end(), buf.begin(), buf.begin() + static_cast<long>(n));
  }
  return out;
}

struct Run {
  size_t start, length;
};

// Active runs of `mask` in a stream.
std::vector<Run> active_runs(const std::vector<uint8_t>& s, uint8_t mask, bool active_low) {
  std::vector<Run> runs;
  for (size_t i = 0; i < s.size();) {
    const bool active = ((s[i] & mask) != 0) != active_low;
    if (!active) {
      ++i;
      continue;
    }
    size_t j = i;
    while (j < s.size() && (((s[j] & mask) != 0) != active_low)) ++j;
    runs.push_back({i, j - i});
    i = j;
  }
  return runs;
}

TEST(BitbangClock, PlansExactRatesThatDivideTheClock) {
  std::string why;
  auto c = plan_bitbang_clock(100000, &why);
  ASSERT_TRUE(c) << why;
  EXPECT_EQ(c->libftdi_baudrate, 5000);  // libftdi makes 20000 baud of it; 5 x 20000 = 100 kHz
  EXPECT_EQ(c->divisor8, 4800u);         // 96 MHz / 4800 = 20000 baud
  EXPECT_DOUBLE_EQ(c->sample_rate_hz(), 100000.0);
  c = plan_bitbang_clock(1000000, &why);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->libftdi_baudrate, 50000);
  EXPECT_DOUBLE_EQ(c->sample_rate_hz(), 1000000.0);
}

TEST(BitbangClock, RoundsLikeLibftdiAndReportsTheTrueRate) {
  // 70 kHz: libftdi gets 3500 -> 14000 baud -> divisor 192e6/14000 = 13714 sixteenths -> 6857 eighths.
  std::string why;
  const auto c = plan_bitbang_clock(70000, &why);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->divisor8, 6857u);
  EXPECT_EQ(c->fs_num, 480'000'000u);
  EXPECT_EQ(c->fs_den, 6857u);
  EXPECT_NEAR(c->sample_rate_hz(), 70001.458, 1e-3);
}

TEST(BitbangClock, RejectsRatesOutsideTheSupportedRange) {
  std::string why;
  EXPECT_FALSE(plan_bitbang_clock(9999, &why));
  EXPECT_NE(why.find("10000"), std::string::npos);
  EXPECT_FALSE(plan_bitbang_clock(2000000, &why));
}

TEST(BitbangPattern, PulsesSitOnTheIntegerGridWithTheRequestedWidth) {
  PatternOptions o;  // 100 kHz, 60 Hz -> 1666.67 samples per period; 100 us -> 10 samples
  o.count = 600;
  BitbangPattern p(o);
  EXPECT_EQ(p.width_samples(), 10u);
  const std::vector<uint8_t> s = generate(p, 777);
  const auto runs = active_runs(s, o.pin_mask, false);
  ASSERT_EQ(runs.size(), 600u);
  for (size_t k = 0; k < runs.size(); ++k) {
    // Start = lead + floor(k * 100000 / 60) exactly.
    EXPECT_EQ(runs[k].start, 1 + (k * 100000) / 60) << "pulse " << k;
    EXPECT_EQ(runs[k].length, 10u);
    EXPECT_EQ(p.pulse_start(k), runs[k].start);
  }
  // 600 pulses at 60 Hz span exactly 9.99 s + one pulse: no drift.
  EXPECT_EQ(runs.back().start, 1u + 599u * 100000u / 60u);
  // The stream ends idle, one sample after the last pulse.
  EXPECT_EQ(s.size(), runs.back().start + 10 + 1);
  EXPECT_EQ(s.back() & o.pin_mask, 0);
  ASSERT_TRUE(p.total_samples());
  EXPECT_EQ(*p.total_samples(), s.size());
  EXPECT_TRUE(p.finished());
  EXPECT_EQ(p.fill(nullptr, 0), 0u);
}

TEST(BitbangPattern, ChunkingDoesNotChangeTheStream) {
  PatternOptions o;
  o.rate_hz = 123.4;
  o.pulse_width_us = 250;
  o.count = 50;
  BitbangPattern whole(o);
  const std::vector<uint8_t> ref = generate(whole, 1 << 20);
  for (size_t chunk : {1u, 7u, 64u, 1000u}) {
    BitbangPattern p(o);
    EXPECT_EQ(generate(p, chunk), ref) << "chunk " << chunk;
  }
}

TEST(BitbangPattern, ActiveLowInvertsThePinOnly) {
  PatternOptions o;
  o.pin_mask = 0x01;
  o.active_low = true;
  o.count = 3;
  BitbangPattern p(o);
  EXPECT_EQ(p.idle_byte(), 0x01);
  EXPECT_EQ(p.active_byte(), 0x00);
  const std::vector<uint8_t> s = generate(p, 4096);
  EXPECT_EQ(s.front(), 0x01);  // lead sample idle (high)
  EXPECT_EQ(s.back(), 0x01);   // ends idle
  EXPECT_EQ(active_runs(s, 0x01, true).size(), 3u);
}

TEST(BitbangPattern, PulsesStartedBeforeMatchesTheStream) {
  PatternOptions o;
  o.fs_num = 480'000'000;  // the 70 kHz plan: a non-integer sample rate
  o.fs_den = 6857;
  o.rate_hz = 59.94;
  o.count = 200;
  BitbangPattern p(o);
  const std::vector<uint8_t> s = generate(p, 4096);
  uint64_t started = 0;
  bool prev = false;
  for (size_t c = 0; c <= s.size(); ++c) {
    ASSERT_EQ(p.pulses_started_before(c), started) << "after " << c << " samples";
    if (c < s.size()) {
      const bool now = (s[c] & o.pin_mask) != 0;
      if (now && !prev) ++started;
      prev = now;
    }
  }
  EXPECT_EQ(started, 200u);
  EXPECT_EQ(p.pulses_started_before(UINT64_MAX / 2), 200u);  // capped at count
}

TEST(BitbangPattern, FinishEndsAfterThePulseInProgress) {
  PatternOptions o;
  o.rate_hz = 100;         // 1000 samples per period
  o.pulse_width_us = 300;  // 30 samples
  BitbangPattern p(o);
  std::vector<uint8_t> buf(1015);  // stops inside pulse 1 (starts at 1001)
  ASSERT_EQ(p.fill(buf.data(), buf.size()), buf.size());
  EXPECT_FALSE(p.total_samples());
  p.finish();
  ASSERT_TRUE(p.total_samples());
  EXPECT_EQ(*p.total_samples(), 1001u + 30u + 1u);
  std::vector<uint8_t> rest = generate(p, 8);
  EXPECT_EQ(rest.size(), 1001u + 30u + 1u - 1015u);
  for (size_t i = 0; i + 1 < rest.size(); ++i) EXPECT_EQ(rest[i], o.pin_mask);  // pulse completes
  EXPECT_EQ(rest.back(), 0);
  EXPECT_TRUE(p.finished());
}

TEST(BitbangPattern, FinishWhileIdleEndsAtOnce) {
  PatternOptions o;
  o.rate_hz = 100;
  BitbangPattern p(o);
  std::vector<uint8_t> buf(500);
  p.fill(buf.data(), buf.size());
  p.finish();
  EXPECT_TRUE(p.finished());
  EXPECT_EQ(*p.total_samples(), 500u);
}

TEST(BitbangPattern, RejectsAWidthThatLeavesNoIdleSample) {
  PatternOptions o;
  o.rate_hz = 1000;        // 100 samples per period at 100 kHz
  o.pulse_width_us = 995;  // 100 samples (rounded)
  EXPECT_THROW(BitbangPattern{o}, std::invalid_argument);
  o.pulse_width_us = 2;  // below one sample: rounds up to one sample
  BitbangPattern p(o);
  EXPECT_EQ(p.width_samples(), 1u);
  o.pin_mask = 0x03;
  EXPECT_THROW(BitbangPattern{o}, std::invalid_argument);
}

TEST(EchoEdges, CountsLeadingEdgesAcrossChunks) {
  const std::vector<uint8_t> echo = {0, 0, 8, 8, 0, 8, 0, 0, 8, 8, 8};
  bool active = false;
  EXPECT_EQ(count_leading_edges(echo.data(), 3, 0x08, false, &active), 1u);
  EXPECT_TRUE(active);
  EXPECT_EQ(count_leading_edges(echo.data() + 3, echo.size() - 3, 0x08, false, &active), 2u);
  bool low = false;
  EXPECT_EQ(count_leading_edges(echo.data(), echo.size(), 0x08, true, &low), 3u);  // idle high: 8->0 edges
  bool other = false;
  EXPECT_EQ(count_leading_edges(echo.data(), echo.size(), 0x01, false, &other), 0u);
}

TEST(StreamLedger, UnderrunIsReportedOncePerEpisodeAndNotAtTheEnd) {
  StreamLedger l;
  EXPECT_FALSE(l.check_underrun(false));  // nothing submitted yet: not started
  l.on_submitted(1000);
  l.on_echoed(400);
  EXPECT_FALSE(l.check_underrun(false));
  EXPECT_EQ(l.queued(), 600u);
  l.on_echoed(600);
  EXPECT_TRUE(l.check_underrun(false));   // everything clocked out, pattern goes on: the chip paused
  EXPECT_FALSE(l.check_underrun(false));  // same episode
  l.on_submitted(500);
  l.on_echoed(500);
  EXPECT_TRUE(l.check_underrun(false));
  EXPECT_EQ(l.underruns(), 2u);
  l.on_submitted(10);
  l.on_echoed(10);
  EXPECT_FALSE(l.check_underrun(true));  // drained at the end of the pattern: expected
}

TEST(StreamTimebase, EstimatesTheOriginFromTheLeastDelayedEcho) {
  // 100 kHz, true origin at 1 s; each echo arrives 0.2..3 ms after its last sample was clocked out.
  StreamTimebase tb(100000, 1, 8);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int64_t> delay(200'000, 3'000'000);
  const int64_t origin = 1'000'000'000;
  for (uint64_t echoed = 5000; echoed <= 2'000'000; echoed += 5000) {
    const int64_t clocked = origin + static_cast<int64_t>((echoed - 1) * 10'000);
    tb.observe(clocked + delay(rng), echoed);
  }
  ASSERT_TRUE(tb.ready());
  const int64_t t = tb.host_time_of(100000);         // 1 s of samples after the origin
  EXPECT_GE(t, origin + 1'000'000'000);              // never earlier than the truth (upper bounds)
  EXPECT_LE(t, origin + 1'000'000'000 + 3'000'000);  // within the worst echo delay
  EXPECT_NEAR(tb.measured_rate_hz(), 100000.0, 100000.0 * 0.002);
}

TEST(StreamTimebase, FollowsAClockThatRunsSlow) {
  // The chip's crystal 100 ppm slow: with a window of 4 the estimate tracks it instead of the oldest
  // (stale) bound.
  StreamTimebase tb(100000, 1, 4);
  const double true_fs = 100000.0 * (1 - 100e-6);
  for (uint64_t echoed = 1000; echoed <= 2'000'000; echoed += 1000) {
    const int64_t clocked = static_cast<int64_t>(std::llround((echoed - 1) / true_fs * 1e9));
    tb.observe(clocked + 500'000, echoed);
  }
  const int64_t truth = static_cast<int64_t>(std::llround(2'000'000 / true_fs * 1e9));
  // Windowed: 0.5 ms off (the echo delay). The oldest bound alone would be 1.5 ms off by now.
  EXPECT_NEAR(static_cast<double>(tb.host_time_of(2'000'000)), static_cast<double>(truth), 1.0e6);
}

TEST(StreamTimebase, APauseOfTheChipIsMeasuredAndCountedOnce) {
  // 100 kHz, echoes every 5 ms with 0.2..4 ms of delivery jitter (below the 5 ms threshold); after
  // 1 s the chip pauses 30 ms, so every later sample comes 30 ms late.
  StreamTimebase tb(100000, 1);
  std::mt19937 rng(3);
  std::uniform_int_distribution<int64_t> delay(200'000, 4'000'000);
  const int64_t origin = 5'000'000'000;
  int64_t detected = 0;
  int detections = 0;
  for (uint64_t echoed = 500; echoed <= 300'000; echoed += 500) {
    const int64_t pause = echoed > 100'000 ? 30'000'000 : 0;
    const int64_t clocked = origin + static_cast<int64_t>((echoed - 1) * 10'000) + pause;
    const int64_t p = tb.observe(clocked + delay(rng), echoed);
    if (p > 0) {
      detected = p;
      ++detections;
    }
  }
  EXPECT_EQ(detections, 1);
  EXPECT_EQ(tb.pauses(), 1u);
  EXPECT_NEAR(static_cast<double>(detected), 30e6, 4e6);
  EXPECT_EQ(tb.paused_ns(), detected);
  // Times after the pause are on the new timeline; the measured rate leaves the pause out.
  const int64_t t = tb.host_time_of(250'000);
  EXPECT_GE(t, origin + 2'500'000'000 + 30'000'000 - 10'000);
  EXPECT_LE(t, origin + 2'500'000'000 + 30'000'000 + 4'000'000);
  EXPECT_NEAR(tb.measured_rate_hz(), 100000.0, 100.0);
}

TEST(StreamTimebase, DeliveryJitterAloneIsNoPause) {
  StreamTimebase tb(100000, 1);
  std::mt19937 rng(11);
  std::uniform_int_distribution<int64_t> delay(0, 4'900'000);  // just below the threshold
  for (uint64_t echoed = 500; echoed <= 1'000'000; echoed += 500)
    tb.observe(static_cast<int64_t>((echoed - 1) * 10'000) + delay(rng), echoed);
  EXPECT_EQ(tb.pauses(), 0u);
}

}  // namespace
}  // namespace vc::trigger
