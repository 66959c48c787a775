// The example rigs in hw/rigs/ must all load, with their calibration files, and be what their names say.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <map>

#include "voxcap/config/rig_config.hpp"

namespace vc::config {
namespace {

const std::filesystem::path kRigs = std::filesystem::path(VOXCAP_SOURCE_DIR) / "hw" / "rigs";

TEST(ExampleRigs, EveryRigTomlLoads) {
  int loaded = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kRigs)) {
    if (entry.path().extension() != ".toml") continue;
    SCOPED_TRACE(entry.path().string());
    RigConfig c;
    ASSERT_NO_THROW(c = load_rig_config(entry.path()));
    std::string why;
    EXPECT_TRUE(c.valid(&why)) << why;
    EXPECT_FALSE(c.calibration.cameras.empty());
    EXPECT_FALSE(c.nodes.empty());
    EXPECT_TRUE(c.warnings.empty()) << c.warnings.front();
    ++loaded;
  }
  EXPECT_GE(loaded, 3);
}

TEST(ExampleRigs, EachShowsItsTriggerBackend) {
  const std::map<std::string, TriggerBackend> expected = {
      {"emulated.toml", TriggerBackend::Udp},
      {"pi5-gpiod.toml", TriggerBackend::Gpiod},
      {"ftdi-box.toml", TriggerBackend::Ftdi},
  };
  for (const auto& [file, backend] : expected) {
    SCOPED_TRACE(file);
    const RigConfig c = load_rig_config(kRigs / file);
    EXPECT_EQ(c.trigger.backend, backend);
  }
  const RigConfig emulated = load_rig_config(kRigs / "emulated.toml");
  for (const Endpoint& t : emulated.trigger.udp.targets) EXPECT_TRUE(t.is_loopback());
  EXPECT_EQ(emulated.network.listen, "127.0.0.1");
}

TEST(ExampleRigs, DefaultPathIsTheEmulatedRig) {
  if (std::getenv("VOXCAP_RIG")) GTEST_SKIP() << "VOXCAP_RIG is set in this environment";
  const std::filesystem::path p = default_rig_config_path();
  if (p == "rig.toml") GTEST_SKIP() << "a rig.toml in the working directory takes precedence";
  EXPECT_EQ(p, kRigs / "emulated.toml");
  EXPECT_TRUE(std::filesystem::exists(p));
}

}  // namespace
}  // namespace vc::config
