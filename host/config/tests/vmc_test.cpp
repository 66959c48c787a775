// [vmc], the live pose stream out (host/stream): defaults, the values given, every bad one named by its
// key, and a target off this machine allowed with a warning.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_rig.hpp"
#include "voxcap/config/rig_config.hpp"

namespace vc::config {
namespace {

using ::testing::Contains;
using ::testing::HasSubstr;
using ::testing::Not;
using testing::TempRig;

const std::string kHead = R"(calibration = "rig.yaml"
[[nodes]]
id = "a"
number = 1
cameras = ["cam0", "cam1"]
role = "front"
[trigger.udp]
targets = ["127.0.0.1:7700"]
)";

RigConfig parse(const TempRig& rig, const std::string& text) {
  return parse_rig_config(text, rig.toml_path());
}

TEST(VmcConfig, OffByDefaultToVmcsUsualPortAt60Hz) {
  TempRig rig;
  const RigConfig c = parse(rig, kHead);
  EXPECT_FALSE(c.vmc.enabled);
  EXPECT_EQ(c.vmc.target.str(), "127.0.0.1:39539");
  EXPECT_DOUBLE_EQ(c.vmc.rate_hz, 60);
  std::string why;
  EXPECT_TRUE(VmcOptions{}.valid(&why)) << why;
}

TEST(VmcConfig, ReadsEveryKey) {
  TempRig rig;
  const RigConfig c =
      parse(rig, kHead + "[vmc]\nenabled = true\ntarget = \"localhost:39540\"\nrate_hz = 30\n");
  EXPECT_TRUE(c.vmc.enabled);
  EXPECT_EQ(c.vmc.target.host, "localhost");
  EXPECT_EQ(c.vmc.target.port, 39540);
  EXPECT_DOUBLE_EQ(c.vmc.rate_hz, 30);
  EXPECT_THAT(c.warnings, Not(Contains(HasSubstr("vmc"))));
}

// The animation tool often runs on another PC: allowed (even in a keyless rig, whose own addresses
// must be loopback), and said once in the warnings.
TEST(VmcConfig, ATargetOffThisMachineIsAllowedWithAWarning) {
  TempRig rig;
  const RigConfig c = parse(rig, kHead + "[vmc]\nenabled = true\ntarget = \"192.168.1.20:39539\"\n");
  EXPECT_EQ(c.vmc.target.str(), "192.168.1.20:39539");
  EXPECT_THAT(c.warnings, Contains(HasSubstr("vmc.target: 192.168.1.20:39539 is not on this machine")));
  const RigConfig off = parse(rig, kHead + "[vmc]\ntarget = \"192.168.1.20:39539\"\n");
  EXPECT_THAT(off.warnings, Not(Contains(HasSubstr("vmc"))));  // not sending: nothing to say
}

TEST(VmcConfig, BadValuesAreRefusedNamingTheKey) {
  TempRig rig;
  const std::pair<std::string, std::string> cases[] = {
      {"target = \"127.0.0.1\"", "vmc.target: expected \"host:port\", got \"127.0.0.1\""},
      {"target = \"127.0.0.1:0\"", "vmc.target: port must be 1-65535"},
      {"target = \"127.0.0.1:70000\"", "vmc.target: port must be 1-65535"},
      {"target = \"vmc.example:39539\"", "vmc.target: host must be a numeric IPv4 address or localhost"},
      {"target = 39539", "vmc.target: expected a string, got an integer"},
      {"rate_hz = 0", "vmc.rate_hz: must be in (0, 240], got 0"},
      {"rate_hz = -5", "vmc.rate_hz: must be in (0, 240], got -5"},
      {"rate_hz = 241", "vmc.rate_hz: must be in (0, 240], got 241"},
      {"rate_hz = nan", "vmc.rate_hz"},
      {"enabled = 1", "vmc.enabled: expected true or false"},
      {"port = 39539", "vmc.port: unknown key"},
  };
  for (const auto& [line, expect] : cases) {
    try {
      std::string text = kHead;
      text += "[vmc]\n" + line + "\n";
      parse(rig, text);
      ADD_FAILURE() << "accepted: " << line;
    } catch (const ConfigError& e) {
      EXPECT_THAT(e.what(), HasSubstr(expect)) << line;
    }
  }
}

TEST(VmcOptions, ValidNamesTheKey) {
  VmcOptions o;
  std::string why;
  o.rate_hz = VmcOptions::kMaxRateHz;
  EXPECT_TRUE(o.valid(&why)) << why;
  o.rate_hz = 1e-3;
  EXPECT_TRUE(o.valid(&why)) << why;
  o.rate_hz = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(o.valid(&why));
  EXPECT_THAT(why, HasSubstr("rate_hz: must be in (0, 240]"));
  o = VmcOptions{};
  o.target.port = 0;
  EXPECT_FALSE(o.valid(&why));
  EXPECT_THAT(why, HasSubstr("target: port must be 1-65535"));
  o = VmcOptions{};
  o.target.host = "not a host";
  EXPECT_FALSE(o.valid(&why));
  EXPECT_THAT(why, HasSubstr("target: host must be"));
}

}  // namespace
}  // namespace vc::config
