// The host's trigger outputs on real hardware (label hil). Skipped unless named:
//   VOXCAP_HIL_TRIGGER_OUT_CHIP=gpiochip0 VOXCAP_HIL_TRIGGER_OUT_LINE=18   the gpiod backend's output line
//   VOXCAP_HIL_FTDI=0403:6014[:serial]                                    the USB trigger box (hw/triggerbox)
// Optionally an input wired to the output closes the loop through the edge's own trigger input
// (edge/trigger, gpiod): VOXCAP_HIL_GPIO_CHIP=gpiochip0 VOXCAP_HIL_GPIO_LINE=17; then every pulse must
// arrive, in order, with the right period. VOXCAP_HIL_TRIGGER_HZ (default 60 for gpiod, 100 for ftdi)
// and VOXCAP_HIL_ACTIVE_LOW=1 (idle-high line) apply to both sides.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <string>
#include <vector>

#include "hil_env.hpp"
#include "voxcap/edge/trigger.h"
#include "voxcap/trigger/generator.hpp"

namespace {

using namespace std::chrono_literals;
using vc::hil::env;
using vc::hil::env_long;

bool active_low() {
  return env("VOXCAP_HIL_ACTIVE_LOW") == "1";
}

// The edge's gpiod trigger input on the loopback line, or nullptr when none is configured.
vc_trigger* open_loopback() {
  static std::string chip;
  chip = env("VOXCAP_HIL_GPIO_CHIP");
  if (chip.empty() || env("VOXCAP_HIL_GPIO_LINE").empty()) return nullptr;
  vc_trigger_config cfg;
  vc_trigger_config_init(&cfg);
  cfg.backend = "gpiod";
  cfg.chip = chip.c_str();
  cfg.line_offset = static_cast<unsigned>(env_long("VOXCAP_HIL_GPIO_LINE", 0));
  cfg.active_low = active_low();
  vc_trigger* t = nullptr;
  char why[320];
  EXPECT_EQ(vc_trigger_open(&cfg, &t, why, sizeof why), 0) << why;
  return t;
}

// Reads `n` pulses from the loopback input and checks count, order and period (the span over all of
// them, allowing for slots the host-timed generator skipped).
void check_loopback(vc_trigger* in, uint64_t n, double rate_hz, uint64_t missed, double period_tolerance) {
  std::vector<vc_pulse> got;
  vc_pulse p{};
  while (got.size() < n && vc_trigger_wait(in, 1000, &p) == 0) got.push_back(p);
  ASSERT_EQ(got.size(), n) << "pulses sent but not seen on the wire";
  vc_pulse extra{};
  EXPECT_NE(vc_trigger_wait(in, 200, &extra), 0) << "more pulses on the wire than sent";
  double max_err_us = 0;
  const double period_ns = 1e9 / rate_hz;
  for (size_t i = 1; i < got.size(); ++i) {
    EXPECT_EQ(got[i].seq, got[i - 1].seq + 1);
    const double interval = static_cast<double>(got[i].t_ns - got[i - 1].t_ns);
    max_err_us =
        std::max(max_err_us, std::fabs(interval - period_ns * std::round(interval / period_ns)) / 1e3);
  }
  const double span = static_cast<double>(got.back().t_ns - got.front().t_ns);
  const double expected = period_ns * static_cast<double>(n - 1 + missed);
  EXPECT_NEAR(span, expected, expected * period_tolerance);
  std::printf("loopback: %zu pulses, span %.3f ms (expected %.3f), max interval error %.1f us\n", got.size(),
              span / 1e6, expected / 1e6, max_err_us);
  vc_trigger_stats st;
  vc_trigger_get_stats(in, &st);
  EXPECT_EQ(st.lost, 0u);
}

TEST(HostTriggerHil, GpiodOutputEmitsTheTrain) {
  const std::string chip = env("VOXCAP_HIL_TRIGGER_OUT_CHIP");
  if (chip.empty() || env("VOXCAP_HIL_TRIGGER_OUT_LINE").empty())
    GTEST_SKIP()
        << "no rig configured: set VOXCAP_HIL_TRIGGER_OUT_CHIP and VOXCAP_HIL_TRIGGER_OUT_LINE (a free "
           "GPIO output) to run; add VOXCAP_HIL_GPIO_CHIP/LINE for an input wired to it";
  vc::config::TriggerOptions o;
  o.backend = vc::config::TriggerBackend::Gpiod;
  o.gpiod.chip = chip;
  o.gpiod.line_offset = static_cast<int>(env_long("VOXCAP_HIL_TRIGGER_OUT_LINE", 0));
  o.active_low = active_low();
  o.rate_hz = static_cast<double>(env_long("VOXCAP_HIL_TRIGGER_HZ", 60));
  vc_trigger* in = open_loopback();  // before the first pulse

  auto gen = vc::trigger::make_generator(o);
  const uint64_t n = 120;
  gen->start(vc::trigger::PulseTrain{o.rate_hz, 200.0, n, 0});
  ASSERT_TRUE(gen->wait_done(std::chrono::milliseconds(static_cast<long>(2000 + 2000.0 * n / o.rate_hz))));
  EXPECT_EQ(gen->last_error(), "");
  EXPECT_EQ(gen->pulses_sent(), n);
  const vc::trigger::Stats s = gen->stats();
  std::printf("gpiod: %llu pulses, late %llu, missed %llu, max lateness %.1f us\n",
              static_cast<unsigned long long>(s.pulses_sent), static_cast<unsigned long long>(s.late),
              static_cast<unsigned long long>(s.missed), static_cast<double>(s.max_lateness_ns) / 1e3);
  if (in) {
    check_loopback(in, n, o.rate_hz, s.missed, 0.01);
    vc_trigger_free(in);
  }
}

TEST(HostTriggerHil, FtdiBoxTimesTheTrainOnTheChip) {
  const std::string id = env("VOXCAP_HIL_FTDI");
  if (id.empty())
    GTEST_SKIP() << "no trigger box configured: set VOXCAP_HIL_FTDI=0403:6014[:serial] to run; add "
                    "VOXCAP_HIL_GPIO_CHIP/LINE for an input wired to one of its outputs";
  vc::config::TriggerOptions o;
  o.backend = vc::config::TriggerBackend::Ftdi;
  unsigned vid = 0, pid = 0;
  char serial[128] = "";
  ASSERT_GE(std::sscanf(id.c_str(), "%x:%x:%127s", &vid, &pid, serial), 2) << "VOXCAP_HIL_FTDI=" << id;
  o.ftdi.vid = static_cast<uint16_t>(vid);
  o.ftdi.pid = static_cast<uint16_t>(pid);
  o.ftdi.serial = serial;
  o.active_low = active_low();
  o.rate_hz = static_cast<double>(env_long("VOXCAP_HIL_TRIGGER_HZ", 100));
  vc_trigger* in = open_loopback();

  auto gen = vc::trigger::make_generator(o);
  std::mutex m;
  std::vector<int64_t> host_times;
  gen->set_observer([&](const vc::trigger::Pulse& p) {
    std::lock_guard<std::mutex> lock(m);
    host_times.push_back(p.t_ns);
  });
  const uint64_t n = 300;
  gen->start(vc::trigger::PulseTrain{o.rate_hz, 500.0, n, 0});
  ASSERT_TRUE(gen->wait_done(std::chrono::milliseconds(static_cast<long>(3000 + 1000.0 * n / o.rate_hz))));
  EXPECT_EQ(gen->last_error(), "");
  const vc::trigger::Stats s = gen->stats();
  EXPECT_EQ(s.pulses_sent, n);
  EXPECT_EQ(s.pin_edges, n) << "the echoed pin did not toggle for every pulse: output shorted or overloaded?";
  // The clock plan (5x the UART baud on H-series chips) against the chip: echoed samples per host second.
  EXPECT_NEAR(s.sample_rate_hz, static_cast<double>(o.ftdi.sample_rate_hz), o.ftdi.sample_rate_hz * 0.01);
  std::printf("ftdi: %llu pulses, %llu pin edges, bit-bang %.1f Hz (planned %u), underruns %llu\n",
              static_cast<unsigned long long>(s.pulses_sent), static_cast<unsigned long long>(s.pin_edges),
              s.sample_rate_hz, o.ftdi.sample_rate_hz, static_cast<unsigned long long>(s.underruns));
  {
    std::lock_guard<std::mutex> lock(m);
    EXPECT_EQ(host_times.size(), n);
    for (size_t i = 1; i < host_times.size(); ++i) EXPECT_GT(host_times[i], host_times[i - 1]);
  }
  if (in) {
    // Chip-timed: the period holds to the crystal, far tighter than the host-timed backends.
    check_loopback(in, n, o.rate_hz, 0, 0.001);
    vc_trigger_free(in);
  }
}

}  // namespace
