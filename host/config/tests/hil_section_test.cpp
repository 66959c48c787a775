// [hil]: the lines and cameras `voxcap hil` tests. Absent: nothing configured; present: every key read,
// checked, and an unknown one named.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_rig.hpp"
#include "voxcap/config/rig_config.hpp"

namespace vc::config {
namespace {

using ::testing::HasSubstr;
using testing::TempRig;
using testing::valid_toml;

RigConfig parse(const TempRig& rig, const std::string& text) {
  return parse_rig_config(text, rig.toml_path());
}

TEST(HilSection, AbsentMeansNothingConfigured) {
  TempRig rig;
  const RigConfig c = parse(rig, valid_toml());
  EXPECT_FALSE(c.hil.present);
  EXPECT_FALSE(c.hil.loopback.configured());
  EXPECT_FALSE(c.hil.edge_input.configured());
  EXPECT_TRUE(c.hil.cameras.empty());
  EXPECT_EQ(c.hil.smoke_seconds, 0);
}

TEST(HilSection, EveryKeyIsRead) {
  TempRig rig;
  const RigConfig c = parse(rig, valid_toml() + R"(
[hil]
pulses = 240
rates_hz = [30, 90.5]
smoke_seconds = 12
max_jitter_us = 250
max_offset_us = 400

[hil.loopback]
chip = "gpiochip0"
line = 17

[hil.edge_input]
chip = "/dev/gpiochip4"
line = "GPIO27"
active_low = true
debounce_us = 5

[[hil.cameras]]
backend = "libcamera"
device = "0"
exposure_us = 4000
latency_us = 4100.5

[[hil.cameras]]
backend = "v4l2"
device = "/dev/video0"
format = "grey"
width = 1456
height = 1088
)");
  const HilOptions& h = c.hil;
  EXPECT_TRUE(h.present);
  EXPECT_EQ(h.pulses, 240u);
  EXPECT_EQ(h.rates_hz, (std::vector<double>{30, 90.5}));
  EXPECT_EQ(h.smoke_seconds, 12);
  EXPECT_EQ(h.max_jitter_us, 250);
  EXPECT_EQ(h.max_offset_us, 400);
  EXPECT_EQ(h.loopback.chip, "gpiochip0");
  EXPECT_EQ(h.loopback.line_offset, 17);
  EXPECT_FALSE(h.loopback.active_low.has_value());  // the trigger's polarity
  EXPECT_EQ(h.edge_input.line_name, "GPIO27");
  EXPECT_EQ(h.edge_input.line_str(), "GPIO27");
  EXPECT_EQ(h.edge_input.active_low, true);
  EXPECT_EQ(h.edge_input.debounce_us, 5);
  ASSERT_EQ(h.cameras.size(), 2u);
  EXPECT_EQ(h.cameras[0].backend, "libcamera");
  EXPECT_EQ(h.cameras[0].exposure_us, 4000);
  EXPECT_DOUBLE_EQ(h.cameras[0].latency_us, 4100.5);
  EXPECT_EQ(h.cameras[1].format, "grey");
  EXPECT_EQ(h.cameras[1].width, 1456);
}

TEST(HilSection, MistakesAreNamedByKey) {
  TempRig rig;
  auto error = [&](const std::string& hil) {
    try {
      parse(rig, valid_toml() + hil);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(error("[hil]\npulse = 5\n"), HasSubstr("hil.pulse: unknown key (did you mean \"pulses\"?)"));
  EXPECT_THAT(error("[hil.loopback]\nchip = \"gpiochip0\"\n"), HasSubstr("hil.loopback.line: missing"));
  EXPECT_THAT(error("[hil.loopback]\nline = 17\n"), HasSubstr("hil.loopback.chip: missing"));
  EXPECT_THAT(error("[hil]\nrates_hz = [60, 0]\n"), HasSubstr("hil.rates_hz: each must be in (0, 1000]"));
  EXPECT_THAT(error("[hil]\nsmoke_seconds = -1\n"), HasSubstr("hil.smoke_seconds"));
  EXPECT_THAT(error("[[hil.cameras]]\nbackend = \"usb\"\ndevice = \"0\"\n"),
              HasSubstr("hil.cameras[0].backend: must be \"libcamera\" or \"v4l2\""));
  EXPECT_THAT(error("[[hil.cameras]]\nbackend = \"v4l2\"\n"), HasSubstr("hil.cameras[0].device: missing"));
  EXPECT_THAT(error("[hil.edge_input]\nchip = \"gpiochip0\"\nline = 17\ndebounce_us = 200000\n"),
              HasSubstr("hil.edge_input.debounce_us"));
}

}  // namespace
}  // namespace vc::config
