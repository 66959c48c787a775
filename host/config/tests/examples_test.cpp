// The example rigs in hw/rigs/ must all load, with their calibration files, and be what their names say;
// their subtraction settings, and host/config/README.md's table, agree with the one source of the
// defaults (proto/include/voxcap/subtraction.h); their calibrations make a CONFIG the protocol accepts.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "voxcap/config/rig_config.hpp"
#include "voxcap/proto.h"
#include "voxcap/rig/c_models.hpp"
#include "voxcap/subtraction.h"

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

std::vector<std::filesystem::path> rig_files() {
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(kRigs))
    if (entry.path().extension() == ".toml") files.push_back(entry.path());
  return files;
}

TEST(ExampleRigs, SubtractionAgreesWithTheDefaults) {
  const SubtractionOptions d;
  EXPECT_EQ(d.t_upper, VC_SUBTRACT_T_UPPER);
  EXPECT_EQ(d.t_lower, VC_SUBTRACT_T_LOWER);
  EXPECT_EQ(d.shadow_angle_deg, VC_SUBTRACT_SHADOW_ANGLE_DEG);
  EXPECT_EQ(d.cleanup_radius_px, VC_CLEANUP_RADIUS_PX);
  EXPECT_EQ(d.background_frames, VC_BACKGROUND_FRAMES);
  std::string why;
  EXPECT_TRUE(d.valid(&why)) << why;
  for (const auto& file : rig_files()) {
    SCOPED_TRACE(file.string());
    const SubtractionOptions s = load_rig_config(file).subtraction;
    EXPECT_EQ(s.t_upper, d.t_upper);
    EXPECT_EQ(s.t_lower, d.t_lower);
    EXPECT_EQ(s.shadow_angle_deg, d.shadow_angle_deg);
    EXPECT_EQ(s.cleanup_radius_px, d.cleanup_radius_px);
    EXPECT_EQ(s.background_frames, d.background_frames);
  }
}

// Every example rig says [carving] and [silhouettes] with their defaults: subpixel, none.
TEST(ExampleRigs, CarvingAndSilhouettesAreTheDefaults) {
  for (const auto& file : rig_files()) {
    SCOPED_TRACE(file.string());
    const RigConfig rig = load_rig_config(file);
    EXPECT_EQ(rig.carving.rule, CarvingOptions{}.rule);
    EXPECT_EQ(rig.carving.rule, CarveRule::Subpixel);
    EXPECT_EQ(rig.silhouettes.every, SilhouetteOptions{}.every);
    EXPECT_EQ(rig.silhouettes.scale, SilhouetteOptions{}.scale);
    std::ifstream in(file);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("[carving]"), std::string::npos);
    EXPECT_NE(text.find("[silhouettes]"), std::string::npos);
  }
}

// The README's [subtraction] rows quote the header's defaults and ranges.
TEST(ExampleRigs, ReadmeQuotesTheDefaults) {
  std::ifstream in(std::filesystem::path(VOXCAP_SOURCE_DIR) / "host" / "config" / "README.md");
  ASSERT_TRUE(in.good());
  std::map<std::string, std::string> rows;  // first cell -> second cell
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("| `", 0) != 0) continue;
    const size_t a = line.find(" | "), b = line.find(" | ", a + 3);
    if (a == std::string::npos || b == std::string::npos) continue;
    rows[line.substr(2, a - 2)] = line.substr(a + 3, b - a - 3);
  }
  auto num = [](double v) { return (std::ostringstream() << v).str(); };
  EXPECT_EQ(rows["`[subtraction]` `t_upper`, `t_lower`"],
            "numbers, " + num(VC_SUBTRACT_T_UPPER) + ", " + num(VC_SUBTRACT_T_LOWER));
  EXPECT_EQ(rows["`shadow_angle_deg`"], "number, " + num(VC_SUBTRACT_SHADOW_ANGLE_DEG));
  EXPECT_EQ(rows["`cleanup_radius_px`"], "int, " + num(VC_CLEANUP_RADIUS_PX));
  EXPECT_EQ(rows["`background_frames`"], "int, " + num(VC_BACKGROUND_FRAMES));
  std::ifstream again(std::filesystem::path(VOXCAP_SOURCE_DIR) / "host" / "config" / "README.md");
  const std::string text((std::istreambuf_iterator<char>(again)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("0.." + num(VC_CLEANUP_RADIUS_MAX_PX) + " (0 = off)"), std::string::npos);
  EXPECT_NE(text.find(num(VC_BACKGROUND_FRAMES_MIN) + ".." + num(VC_BACKGROUND_FRAMES_MAX)),
            std::string::npos);
}

// Every node of every example rig gets a CONFIG the protocol accepts: its calibration's cameras and the
// grid convert to the C structs (hw/rig c_models.hpp) and the encoder's checks pass, clean-up included.
TEST(ExampleRigs, EveryNodeGetsAValidConfig) {
  for (const auto& file : rig_files()) {
    SCOPED_TRACE(file.string());
    const RigConfig rig = load_rig_config(file);
    for (const NodeConfig& node : rig.nodes) {
      SCOPED_TRACE(node.id);
      vc_config c{};
      c.grid_id = 1;
      ASSERT_NO_THROW(c.grid = rig::to_c_grid(rig.grid));
      c.t_upper = static_cast<float>(rig.subtraction.t_upper);
      c.t_lower = static_cast<float>(rig.subtraction.t_lower);
      c.shadow_angle_deg = static_cast<float>(rig.subtraction.shadow_angle_deg);
      c.cleanup_radius_px = static_cast<uint32_t>(rig.subtraction.cleanup_radius_px);
      c.background_frames = static_cast<uint32_t>(rig.subtraction.background_frames);
      c.carve_rule = rig.carving.wire_value();
      c.silhouette_every = static_cast<uint8_t>(rig.silhouettes.every);
      c.silhouette_scale = static_cast<uint8_t>(rig.silhouettes.scale);
      c.camera_count = static_cast<uint16_t>(node.cameras.size());
      for (size_t k = 0; k < node.cameras.size(); k++) {
        const int idx = rig.camera_index(node.cameras[k]);
        ASSERT_GE(idx, 0);
        ASSERT_NO_THROW(c.cameras[k] = rig::to_c_camera(rig.calibration.cameras[static_cast<size_t>(idx)]));
      }
      std::vector<uint8_t> buf(VC_PROTO_HEADER_SIZE + 4096);
      size_t len = 0;
      vc_header hdr{};
      EXPECT_EQ(vc_encode_config(buf.data(), buf.size(), &len, &hdr, &c), 0);
    }
  }
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
