// The trigger box's stream loop (FtdiGenerator::run) against a simulated FT232H: what reaches the pins
// is exactly the pattern, pulses are counted and timed, stop drains and leaves the pin idle, and chip
// pauses, unplugging and a stuck pin are reported.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

#include "backends.hpp"
#include "sim_ft232h.hpp"

namespace vc::trigger {
namespace {

using ::testing::HasSubstr;
using namespace std::chrono_literals;
using testing::SimLog;
using testing::SimOptions;

config::TriggerOptions box_options() {
  config::TriggerOptions o;
  o.backend = config::TriggerBackend::Ftdi;
  o.ftdi.pin = 3;
  o.ftdi.sample_rate_hz = 100000;
  o.ftdi.buffer_ms = 50;
  o.rt_priority = 0;
  return o;
}

// Leading edges (idle -> active) of the trigger pin in the chip's output, as sample indexes.
std::vector<size_t> edges(const SimLog& log, uint8_t mask, bool active_low) {
  std::vector<size_t> out;
  bool prev = false;
  for (size_t i = 0; i < log.driven.size(); ++i) {
    const bool active = ((log.driven[i] & mask) != 0) != active_low;
    if (active && !prev) out.push_back(i);
    prev = active;
  }
  return out;
}

struct BoxRun {
  std::shared_ptr<SimLog> log = std::make_shared<SimLog>();
  std::unique_ptr<detail::FtdiGenerator> gen;
  std::mutex m;
  std::vector<Pulse> pulses;

  BoxRun(const config::TriggerOptions& o, SimOptions so) {
    gen = std::make_unique<detail::FtdiGenerator>(o, testing::sim_factory(so, log));
    gen->set_observer([this](const Pulse& p) {
      std::lock_guard<std::mutex> lock(m);
      pulses.push_back(p);
    });
  }
};

TEST(FtdiStream, ThePinsCarryExactlyThePatternAndEveryPulseIsCounted) {
  BoxRun r(box_options(), SimOptions{});
  r.gen->start(PulseTrain{100.0, 500.0, 50, 7});
  ASSERT_TRUE(r.gen->wait_done(20s));
  EXPECT_EQ(r.gen->last_error(), "");
  const Stats s = r.gen->stats();
  EXPECT_EQ(s.pulses_sent, 50u);
  EXPECT_EQ(s.pin_edges, 50u);  // the echo shows every pulse on the pin
  EXPECT_EQ(s.underruns, 0u);
  EXPECT_NEAR(s.sample_rate_hz, 100000.0, 100.0);

  // On the pins: pulse k starts at sample 1 + 1000 k (100 kHz / 100 Hz), 50 samples (500 us) wide,
  // and the chip clocked without a pause, so edges are exactly 10 ms apart on the chip's clock.
  const std::vector<size_t> e = edges(*r.log, 0x08, false);
  ASSERT_EQ(e.size(), 50u);
  for (size_t k = 0; k < e.size(); ++k) {
    EXPECT_EQ(e[k], 1 + 1000 * k);
    for (size_t i = e[k]; i < e[k] + 50; ++i) ASSERT_EQ(r.log->driven[i], 0x08) << "pulse " << k;
    EXPECT_EQ(r.log->driven[e[k] + 50], 0x00);
    if (k > 0) {
      EXPECT_EQ(r.log->driven_t[e[k]] - r.log->driven_t[e[k - 1]], 10'000'000);
    }
  }
  EXPECT_EQ(r.log->driven.back(), 0x00);  // left idle

  // The observer saw seq first_seq.. in order; host times estimate the chip's edge times to within
  // the echo's USB delay, never earlier than the edge.
  std::lock_guard<std::mutex> lock(r.m);
  ASSERT_EQ(r.pulses.size(), 50u);
  for (size_t k = 0; k < r.pulses.size(); ++k) {
    EXPECT_EQ(r.pulses[k].seq, 7 + k);
    const int64_t truth = r.log->driven_t[e[k]];
    EXPECT_GE(r.pulses[k].t_ns, truth - 10'000);  // one sample of slack for the echo's offset
    EXPECT_LE(r.pulses[k].t_ns, truth + 2'000'000);
  }
}

TEST(FtdiStream, ActiveLowIdlesHighAndPulsesLow) {
  config::TriggerOptions o = box_options();
  o.active_low = true;
  o.ftdi.pin = 0;
  BoxRun r(o, SimOptions{});
  r.gen->start(PulseTrain{60.0, 1000.0, 12, 0});
  ASSERT_TRUE(r.gen->wait_done(20s));
  EXPECT_EQ(r.gen->stats().pin_edges, 12u);
  EXPECT_EQ(edges(*r.log, 0x01, true).size(), 12u);
  EXPECT_EQ(r.log->driven.front(), 0x01);  // the lead sample: idle high
  EXPECT_EQ(r.log->driven.back(), 0x01);
}

TEST(FtdiStream, StopFinishesThePulseInProgressAndLeavesThePinIdle) {
  BoxRun r(box_options(), SimOptions{});
  r.gen->start(100.0, 2000.0);  // unlimited, 2 ms pulses
  while (r.gen->pulses_sent() < 20) std::this_thread::sleep_for(1ms);
  r.gen->stop();
  EXPECT_FALSE(r.gen->running());
  EXPECT_EQ(r.gen->last_error(), "");
  const std::vector<size_t> e = edges(*r.log, 0x08, false);
  EXPECT_EQ(r.gen->pulses_sent(), e.size());  // drained: everything on the pins was echoed and counted
  EXPECT_EQ(r.gen->stats().pin_edges, e.size());
  ASSERT_GE(e.size(), 20u);
  EXPECT_GE(r.log->driven.size(), e.back() + 200 + 1);  // the last pulse has its full 200 samples
  EXPECT_EQ(r.log->driven.back(), 0x00);
}

TEST(FtdiStream, AHostStallLongerThanTheQueueIsAnUnderrun) {
  SimOptions so;
  so.stall_at_ns = so.start_ns + 200'000'000;
  so.stall_ns = 120'000'000;  // the queue holds 50 ms
  BoxRun r(box_options(), so);
  r.gen->start(PulseTrain{100.0, 500.0, 60, 0});
  ASSERT_TRUE(r.gen->wait_done(20s));
  const Stats s = r.gen->stats();
  EXPECT_EQ(s.pulses_sent, 60u);  // every pulse still goes out, some late
  EXPECT_EQ(s.underruns, 1u);
  // The chip's own record: one interval stretched by the pause, which the stats measured.
  const std::vector<size_t> e = edges(*r.log, 0x08, false);
  ASSERT_EQ(e.size(), 60u);
  int64_t longest = 0;
  for (size_t k = 1; k < e.size(); ++k)
    longest = std::max(longest, r.log->driven_t[e[k]] - r.log->driven_t[e[k - 1]]);
  const int64_t pause = longest - 10'000'000;
  EXPECT_GT(pause, 50'000'000);
  EXPECT_NEAR(static_cast<double>(s.paused_ns), static_cast<double>(pause), 2e6);
}

TEST(FtdiStream, AHostStallThatStarvesTheEchoIsAnUnderrunToo) {
  // The queue holds 300 ms, far more than the stall, but nobody reads the echo for 40 ms: the 1 KiB
  // echo FIFO fills after ~10 ms and synchronous mode stops the clock.
  config::TriggerOptions o = box_options();
  o.ftdi.buffer_ms = 300;
  SimOptions so;
  so.stall_at_ns = so.start_ns + 100'000'000;
  so.stall_ns = 40'000'000;
  BoxRun r(o, so);
  r.gen->start(PulseTrain{100.0, 500.0, 40, 0});
  ASSERT_TRUE(r.gen->wait_done(20s));
  const Stats s = r.gen->stats();
  EXPECT_EQ(s.pulses_sent, 40u);
  EXPECT_EQ(s.underruns, 1u);
  EXPECT_GT(s.paused_ns, 20'000'000);
}

TEST(FtdiStream, AShortStallIsAbsorbedByTheQueue) {
  SimOptions so;
  so.stall_at_ns = so.start_ns + 100'000'000;
  so.stall_ns = 8'000'000;  // less than the echo FIFO's 10 ms and the 50 ms queue
  BoxRun r(box_options(), so);
  r.gen->start(PulseTrain{100.0, 500.0, 30, 0});
  ASSERT_TRUE(r.gen->wait_done(20s));
  EXPECT_EQ(r.gen->stats().underruns, 0u);
  const std::vector<size_t> e = edges(*r.log, 0x08, false);
  ASSERT_EQ(e.size(), 30u);
  for (size_t k = 1; k < e.size(); ++k)
    EXPECT_EQ(r.log->driven_t[e[k]] - r.log->driven_t[e[k - 1]], 10'000'000);
}

TEST(FtdiStream, UnpluggingStopsWithAClearErrorAndStartReopens) {
  SimOptions so;
  so.unplug_at_ns = so.start_ns + 150'000'000;
  BoxRun r(box_options(), so);
  r.gen->start(100.0, 500.0);
  ASSERT_TRUE(r.gen->wait_done(20s));  // ends by itself
  EXPECT_FALSE(r.gen->running());
  const std::string error = r.gen->last_error();
  EXPECT_THAT(error, HasSubstr("ftdi: "));
  EXPECT_THAT(error, HasSubstr("USB"));
  EXPECT_GT(r.gen->pulses_sent(), 0u);
  EXPECT_EQ(r.log->opens, 1);
  // The device was dropped after the failure; the next start opens it again (a fresh simulated chip,
  // good for another 150 ms).
  r.gen->start(PulseTrain{100.0, 500.0, 5, 0});
  ASSERT_TRUE(r.gen->wait_done(20s));
  EXPECT_EQ(r.gen->last_error(), "");
  EXPECT_EQ(r.gen->pulses_sent(), 5u);
  EXPECT_EQ(r.log->opens, 2);
}

TEST(FtdiStream, AStuckPinShowsInTheEchoedEdges) {
  SimOptions so;
  so.stuck_low_mask = 0x08;
  BoxRun r(box_options(), so);
  r.gen->start(PulseTrain{100.0, 500.0, 10, 0});
  ASSERT_TRUE(r.gen->wait_done(20s));
  EXPECT_EQ(r.gen->stats().pulses_sent, 10u);  // the chip clocked them out ...
  EXPECT_EQ(r.gen->stats().pin_edges, 0u);     // ... but the pin never rose
}

}  // namespace
}  // namespace vc::trigger
