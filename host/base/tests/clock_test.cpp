// vc::monotonic_ns is CLOCK_MONOTONIC: it never goes back, and it is the clock steady_clock reads (so
// a stamp from either compares with the other).
#include "voxcap/base/clock.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

namespace vc {
namespace {

uint64_t steady_ns() {
  return static_cast<uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                   std::chrono::steady_clock::now().time_since_epoch())
                                   .count());
}

TEST(HostClock, NeverGoesBack) {
  uint64_t last = monotonic_ns();
  for (int i = 0; i < 100000; ++i) {
    const uint64_t now = monotonic_ns();
    ASSERT_GE(now, last);
    last = now;
  }
}

TEST(HostClock, IsTheClockSteadyClockReads) {
  const uint64_t before = steady_ns();
  const uint64_t t = monotonic_ns();
  const uint64_t after = steady_ns();
  EXPECT_LE(before, t);
  EXPECT_LE(t, after);
}

TEST(HostClock, CountsNanoseconds) {
  const uint64_t t0 = monotonic_ns();
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const uint64_t dt = monotonic_ns() - t0;
  EXPECT_GE(dt, 20'000'000u);  // a sleep lasts at least as long as asked
}

}  // namespace
}  // namespace vc
