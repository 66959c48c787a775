// The option structs' own checks, outside of any file.
#include "voxcap/config/options.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace vc::config {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

TEST(Endpoint, ParsesHostAndPort) {
  Endpoint e;
  std::string why;
  ASSERT_TRUE(Endpoint::parse("127.0.0.1:7700", &e, &why)) << why;
  EXPECT_EQ(e.host, "127.0.0.1");
  EXPECT_EQ(e.port, 7700);
  EXPECT_TRUE(e.is_loopback());
  EXPECT_EQ(e.str(), "127.0.0.1:7700");
  ASSERT_TRUE(Endpoint::parse("localhost:1", &e, &why));
  EXPECT_TRUE(e.is_loopback());
  ASSERT_TRUE(Endpoint::parse("127.1.2.3:65535", &e, &why));
  EXPECT_TRUE(e.is_loopback());
  ASSERT_TRUE(Endpoint::parse("192.168.1.20:7700", &e, &why));
  EXPECT_FALSE(e.is_loopback());
}

TEST(Endpoint, RejectsMalformedText) {
  Endpoint e;
  std::string why;
  for (const char* bad : {"", "7700", ":7700", "127.0.0.1:", "127.0.0.1:0", "127.0.0.1:65536",
                          "127.0.0.1:77x", "host.example:7700", "300.1.1.1:7700"}) {
    EXPECT_FALSE(Endpoint::parse(bad, &e, &why)) << bad;
    EXPECT_FALSE(why.empty());
  }
}

TEST(TriggerOptions, DefaultsAreValidAndLimitsNameTheKey) {
  TriggerOptions t;
  t.udp.targets = {{"127.0.0.1", 7700}};
  std::string why;
  EXPECT_TRUE(t.valid(&why)) << why;

  TriggerOptions bad = t;
  bad.rate_hz = 0;
  EXPECT_FALSE(bad.valid(&why));
  EXPECT_EQ(why, "rate_hz: must be in (0, 1000], got 0");

  bad = t;
  bad.pulse_width_us = bad.period_us() / 2;
  EXPECT_FALSE(bad.valid(&why));
  EXPECT_THAT(why, StartsWith("pulse_width_us: must be less than half the period"));

  // Only the selected backend's table is checked.
  bad = t;
  bad.gpiod.line_offset = -1;
  EXPECT_TRUE(bad.valid(&why));
  bad.backend = TriggerBackend::Gpiod;
  EXPECT_FALSE(bad.valid(&why));
  EXPECT_THAT(why, StartsWith("gpiod.line: "));

  bad = t;
  bad.udp.targets.clear();
  EXPECT_FALSE(bad.valid(&why));
  EXPECT_THAT(why, StartsWith("udp.targets: "));
}

TEST(TriggerOptions, BackendNamesRoundTrip) {
  for (TriggerBackend b : {TriggerBackend::Udp, TriggerBackend::Gpiod, TriggerBackend::Ftdi}) {
    TriggerBackend parsed{};
    ASSERT_TRUE(parse_trigger_backend(to_string(b), &parsed));
    EXPECT_EQ(parsed, b);
  }
  TriggerBackend parsed{};
  EXPECT_FALSE(parse_trigger_backend("usb", &parsed));
}

TEST(GpiodTriggerOptions, ChipPathAndLine) {
  GpiodTriggerOptions g;
  g.chip = "gpiochip4";
  g.line_name = "GPIO17";
  std::string why;
  EXPECT_TRUE(g.valid(&why)) << why;
  EXPECT_EQ(g.chip_path(), "/dev/gpiochip4");
  EXPECT_EQ(g.line_str(), "GPIO17");
  g.line_offset = 17;  // both given
  EXPECT_FALSE(g.valid(&why));
  EXPECT_THAT(why, StartsWith("line: "));
  g.line_name.clear();
  g.chip = "/dev/gpiochip0";
  EXPECT_TRUE(g.valid(&why));
  EXPECT_EQ(g.chip_path(), "/dev/gpiochip0");
  EXPECT_EQ(g.line_str(), "17");
}

TEST(FtdiTriggerOptions, Limits) {
  FtdiTriggerOptions f;
  std::string why;
  EXPECT_TRUE(f.valid(&why)) << why;
  EXPECT_EQ(f.device_str(), "0403:6014");
  f.serial = "FT99";
  EXPECT_EQ(f.device_str(), "0403:6014 serial FT99");
  f.interface = 'E';
  EXPECT_FALSE(f.valid(&why));
  EXPECT_THAT(why, StartsWith("interface: "));
  f.interface = 'B';
  f.buffer_ms = 5;
  EXPECT_FALSE(f.valid(&why));
  EXPECT_THAT(why, StartsWith("buffer_ms: "));
}

TEST(NodeConfig, Checks) {
  NodeConfig n;
  n.id = "pi-5_a";
  n.address = "pi5a.local";
  n.cameras = {"cam0", "cam1"};
  std::string why;
  EXPECT_TRUE(n.valid(&why)) << why;
  n.cameras = {"cam0", "cam0"};
  EXPECT_FALSE(n.valid(&why));
  EXPECT_THAT(why, HasSubstr("cameras: \"cam0\" is listed twice"));
  n.cameras = {"cam0", "cam1", "cam2"};
  EXPECT_FALSE(n.valid(&why));
  EXPECT_THAT(why, HasSubstr("exactly 2 cameras, got 3"));
  n.cameras = {"cam0", "cam1"};
  n.address = "bad..host";
  EXPECT_FALSE(n.valid(&why));
  EXPECT_THAT(why, StartsWith("address: "));
}

TEST(SubtractionAndAssembly, Limits) {
  SubtractionOptions s;
  std::string why;
  EXPECT_TRUE(s.valid(&why)) << why;
  s.shadow_angle_deg = 0;
  EXPECT_FALSE(s.valid(&why));
  EXPECT_THAT(why, StartsWith("shadow_angle_deg: "));
  AssemblyOptions a;
  EXPECT_TRUE(a.valid(&why));
  a.deadline_ms = 20000;
  EXPECT_FALSE(a.valid(&why));
  EXPECT_THAT(why, StartsWith("deadline_ms: "));
  NetworkOptions n;
  EXPECT_TRUE(n.valid(&why));
  n.listen = "0.0.0.0";
  EXPECT_TRUE(n.valid(&why));
  // The heartbeat: host/session's bounds (interval >= 10, timeout above it), the interval at most the
  // protocol's second (proto/SPEC.md), the timeout at most edge.toml's host_timeout_ms bound.
  EXPECT_EQ(n.heartbeat_interval_ms, 250);
  EXPECT_EQ(n.heartbeat_timeout_ms, 2000);
  n.heartbeat_interval_ms = 9;
  EXPECT_FALSE(n.valid(&why));
  EXPECT_THAT(why, StartsWith("heartbeat_interval_ms: "));
  n.heartbeat_interval_ms = 1001;
  EXPECT_FALSE(n.valid(&why));
  n.heartbeat_interval_ms = 1000;
  n.heartbeat_timeout_ms = 1000;
  EXPECT_FALSE(n.valid(&why));
  EXPECT_THAT(why, StartsWith("heartbeat_timeout_ms: "));
  n.heartbeat_timeout_ms = 1001;
  EXPECT_TRUE(n.valid(&why)) << why;
  n.heartbeat_timeout_ms = 600'001;
  EXPECT_FALSE(n.valid(&why));
}

}  // namespace
}  // namespace vc::config
