// vc_clock: offset estimation from bracketed samples, and the converters.
#include <gtest/gtest.h>

#include <cerrno>
#include <cstdint>
#include <cstdlib>

#include "voxcap/edge/clock.h"

TEST(Clock, NamesRoundTrip) {
  for (vc_clock_id id : {VC_CLOCK_MONOTONIC, VC_CLOCK_BOOTTIME, VC_CLOCK_REALTIME}) {
    vc_clock_id back;
    ASSERT_EQ(vc_clock_from_name(vc_clock_name(id), &back), 0);
    EXPECT_EQ(back, id);
  }
  vc_clock_id out;
  EXPECT_EQ(vc_clock_from_name("tai", &out), -EINVAL);
}

TEST(Clock, OffsetUsesTheNarrowestBracket) {
  // other = mono + 1000 exactly; the wide samples would bias the midpoint
  const vc_clock_sample s[] = {
      {100, 1300, 900},    // wide: midpoint 500 -> offset 800
      {2000, 3010, 2020},  // narrow: midpoint 2010 -> offset 1000
      {5000, 6600, 5400},  // wide
  };
  int64_t off = 0;
  uint64_t unc = 0;
  ASSERT_EQ(vc_clock_offset_from_samples(s, 3, &off, &unc), 0);
  EXPECT_EQ(off, 1000);
  EXPECT_EQ(unc, 10u);
}

TEST(Clock, OffsetCanBeNegativeAndRejectsBadSamples) {
  const vc_clock_sample neg[] = {{10000, 4000, 10002}};
  int64_t off = 0;
  ASSERT_EQ(vc_clock_offset_from_samples(neg, 1, &off, nullptr), 0);
  EXPECT_EQ(off, 4000 - 10001);
  const vc_clock_sample bad[] = {{10, 5, 9}};  // after < before
  EXPECT_EQ(vc_clock_offset_from_samples(bad, 1, &off, nullptr), -EINVAL);
  EXPECT_EQ(vc_clock_offset_from_samples(bad, 0, &off, nullptr), -EINVAL);
}

TEST(Clock, ApplyOffsetClamps) {
  EXPECT_EQ(vc_clock_apply_offset(1000, 300), 700u);
  EXPECT_EQ(vc_clock_apply_offset(1000, -300), 1300u);
  EXPECT_EQ(vc_clock_apply_offset(100, 300), 0u);
  EXPECT_EQ(vc_clock_apply_offset(UINT64_MAX - 5, -10), UINT64_MAX);
  EXPECT_EQ(vc_clock_apply_offset(5, INT64_MIN), 5 + (uint64_t)INT64_MAX + 1);
}

TEST(Clock, BoottimeIsAtLeastMonotonic) {
  int64_t off = -1;
  uint64_t unc = 0;
  ASSERT_EQ(vc_clock_measure_offset(VC_CLOCK_BOOTTIME, 8, &off, &unc), 0);
  // BOOTTIME = MONOTONIC + time suspended (>= 0), up to the measurement's own uncertainty
  EXPECT_GE(off + (int64_t)unc, 0);
}

TEST(Clock, ConverterMapsBoottimeOntoMonotonic) {
  vc_clock_converter conv;
  ASSERT_EQ(vc_clock_converter_init(&conv, VC_CLOCK_BOOTTIME, 0), 0);
  uint64_t mono_before = vc_clock_monotonic_ns();
  uint64_t boot = vc_clock_now_ns(VC_CLOCK_BOOTTIME);
  uint64_t mono_after = vc_clock_monotonic_ns();
  uint64_t converted = vc_clock_to_monotonic(&conv, boot);
  // the converted instant lies in the bracket, widened by the offset's uncertainty (+1 ns rounding)
  EXPECT_GE(converted + conv.uncertainty_ns + 1, mono_before);
  EXPECT_LE(converted, mono_after + conv.uncertainty_ns + 1);
}

TEST(Clock, ConverterMapsRealtimeOntoMonotonic) {
  vc_clock_converter conv;
  ASSERT_EQ(vc_clock_converter_init(&conv, VC_CLOCK_REALTIME, 0), 0);
  uint64_t mono_before = vc_clock_monotonic_ns();
  uint64_t real = vc_clock_now_ns(VC_CLOCK_REALTIME);
  uint64_t mono_after = vc_clock_monotonic_ns();
  uint64_t converted = vc_clock_to_monotonic(&conv, real);
  EXPECT_GE(converted + conv.uncertainty_ns + 1, mono_before);
  EXPECT_LE(converted, mono_after + conv.uncertainty_ns + 1);
}

TEST(Clock, MonotonicPassesThroughUnchanged) {
  vc_clock_converter conv;
  ASSERT_EQ(vc_clock_converter_init(&conv, VC_CLOCK_MONOTONIC, 0), 0);
  EXPECT_EQ(vc_clock_to_monotonic(&conv, 123456789), 123456789u);
  EXPECT_EQ(vc_clock_converter_init(nullptr, VC_CLOCK_MONOTONIC, 0), -EINVAL);
}

TEST(Clock, StaleConverterIsRemeasured) {
  vc_clock_converter conv;
  ASSERT_EQ(vc_clock_converter_init(&conv, VC_CLOCK_BOOTTIME, 1), 0);  // refresh after 1 ns
  conv.offset_ns += 5000000000;  // pretend the system slept 5 s since the (now stale) measurement
  uint64_t boot = vc_clock_now_ns(VC_CLOCK_BOOTTIME);
  uint64_t mono = vc_clock_monotonic_ns();
  uint64_t converted = vc_clock_to_monotonic(&conv, boot);
  EXPECT_LT(std::llabs((long long)(converted - mono)), 1000000LL) << "the stale offset was used";
}

TEST(Clock, TimespecAndDeadline) {
  struct timespec ts = vc_clock_timespec(3'000'000'123ull);
  EXPECT_EQ(ts.tv_sec, 3);
  EXPECT_EQ(ts.tv_nsec, 123);
  const uint64_t before = vc_clock_monotonic_ns();
  struct timespec dl = vc_clock_deadline_ns(50'000'000ull);
  const uint64_t after = vc_clock_monotonic_ns();
  const uint64_t dl_ns = (uint64_t)dl.tv_sec * 1'000'000'000ull + (uint64_t)dl.tv_nsec;
  EXPECT_GE(dl_ns, before + 50'000'000ull);
  EXPECT_LE(dl_ns, after + 50'000'000ull);
  EXPECT_LT(dl.tv_nsec, 1'000'000'000L);
  // saturates instead of wrapping
  struct timespec far = vc_clock_deadline_ns(UINT64_MAX);
  EXPECT_EQ((uint64_t)far.tv_sec, UINT64_MAX / 1'000'000'000ull);
}
