// load_rig_config: a complete valid rig, then every kind of invalid input, each of which must be
// rejected with a message naming the file and the key.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <fstream>

#include "test_rig.hpp"
#include "voxcap/camera_model.h"
#include "voxcap/config/rig_config.hpp"

namespace vc::config {
namespace {

using testing::edit;
using ::testing::HasSubstr;
using testing::TempRig;
using testing::valid_toml;

RigConfig parse(const TempRig& rig, const std::string& text) {
  return parse_rig_config(text, rig.toml_path());
}

TEST(LoadRigConfig, ValidConfigFillsEverySection) {
  TempRig rig;
  std::ofstream(rig.toml_path()) << valid_toml();
  const RigConfig c = load_rig_config(rig.toml_path());

  EXPECT_EQ(c.name, "test");
  EXPECT_EQ(c.calibration_path, rig.dir() / "rig.yaml");  // relative to the rig.toml
  ASSERT_EQ(c.calibration.cameras.size(), 6u);
  EXPECT_EQ(c.grid_source, GridSource::Config);  // [grid] wins over the calibration's grid
  EXPECT_DOUBLE_EQ(c.grid.voxel_m, 0.025);
  EXPECT_EQ(c.grid.nx, 80);
  EXPECT_EQ(c.grid.nz, 90);
  EXPECT_DOUBLE_EQ(c.grid.min_m[0], -1.0);

  ASSERT_EQ(c.nodes.size(), 3u);
  EXPECT_EQ(c.nodes[0].id, "node0");
  EXPECT_EQ(c.nodes[0].address, "127.0.0.1");
  EXPECT_EQ(c.nodes[0].cameras, (std::vector<std::string>{"cam0", "cam1"}));
  EXPECT_EQ(c.nodes[0].role, NodeRole::Front);
  EXPECT_EQ(c.nodes[1].address, "any");  // default
  EXPECT_EQ(c.nodes[1].role, NodeRole::Side);
  ASSERT_EQ(c.front_nodes().size(), 1u);
  EXPECT_EQ(c.front_nodes()[0]->id, "node0");
  EXPECT_EQ(c.node("node2"), &c.nodes[2]);
  EXPECT_EQ(c.node("node9"), nullptr);
  EXPECT_EQ(c.camera_index("cam4"), 4);
  EXPECT_EQ(c.camera_index("cam6"), -1);

  EXPECT_DOUBLE_EQ(c.subtraction.t_upper, 4.5);
  EXPECT_DOUBLE_EQ(c.subtraction.t_lower, 2.5);
  EXPECT_DOUBLE_EQ(c.subtraction.shadow_angle_deg, 6.0);  // an integer is accepted for a number
  EXPECT_EQ(c.subtraction.cleanup_radius_px, 2);
  EXPECT_EQ(c.subtraction.background_frames, 40);
  EXPECT_TRUE(c.features.enabled);

  EXPECT_EQ(c.trigger.backend, TriggerBackend::Udp);
  EXPECT_DOUBLE_EQ(c.trigger.rate_hz, 60.0);
  EXPECT_DOUBLE_EQ(c.trigger.pulse_width_us, 200.0);
  EXPECT_EQ(c.trigger.rt_priority, 40);
  EXPECT_DOUBLE_EQ(c.trigger.late_threshold_us, 300.0);
  ASSERT_EQ(c.trigger.udp.targets.size(), 3u);
  EXPECT_EQ(c.trigger.udp.targets[2], (Endpoint{"127.0.0.1", 7703}));
  EXPECT_EQ(c.trigger.gpiod.chip_path(), "/dev/gpiochip0");
  EXPECT_EQ(c.trigger.gpiod.line_offset, 18);
  EXPECT_EQ(c.trigger.ftdi.vid, 0x0403);
  EXPECT_EQ(c.trigger.ftdi.pid, 0x6014);
  EXPECT_EQ(c.trigger.ftdi.serial, "FT1234");
  EXPECT_EQ(c.trigger.ftdi.pin, 3);
  EXPECT_EQ(c.trigger.ftdi.sample_rate_hz, 200000u);
  EXPECT_EQ(c.trigger.ftdi.buffer_ms, 60);

  EXPECT_DOUBLE_EQ(c.assembly.deadline_ms, 40.0);
  EXPECT_EQ(c.assembly.missing_node_policy, MissingNodePolicy::Degraded);
  EXPECT_EQ(c.recording.dir, "takes");
  EXPECT_EQ(c.network.listen, "any");
  EXPECT_EQ(c.network.port, 7650);
  EXPECT_EQ(c.network.heartbeat_interval_ms, 100);
  EXPECT_EQ(c.network.heartbeat_timeout_ms, 1500);
  EXPECT_TRUE(c.warnings.empty()) << c.warnings.front();
  std::string why;
  EXPECT_TRUE(c.valid(&why)) << why;
}

TEST(LoadRigConfig, DefaultsFillWhatIsLeftOut) {
  TempRig rig;
  const RigConfig c = parse(rig, R"(calibration = "rig.yaml"
[[nodes]]
id = "a"
number = 1
cameras = ["cam0", "cam1"]
role = "front"
[trigger.udp]
targets = ["127.0.0.1:7700"]
)");
  EXPECT_EQ(c.name, "rig");  // the file's stem
  EXPECT_EQ(c.grid_source, GridSource::Calibration);
  EXPECT_EQ(c.grid.nx, 100);
  EXPECT_EQ(c.trigger.backend, TriggerBackend::Udp);
  EXPECT_DOUBLE_EQ(c.trigger.rate_hz, TriggerOptions{}.rate_hz);
  EXPECT_DOUBLE_EQ(c.subtraction.t_upper, SubtractionOptions{}.t_upper);
  EXPECT_EQ(c.assembly.missing_node_policy, MissingNodePolicy::Drop);
  EXPECT_EQ(c.network.port, 7600);
  EXPECT_EQ(c.network.heartbeat_interval_ms, 250);  // host/session's defaults
  EXPECT_EQ(c.network.heartbeat_timeout_ms, 2000);
  EXPECT_EQ(c.recording.dir, "recordings");
  // Legal but worth a word: calibrated cameras no node drives.
  EXPECT_THAT(c.warnings,
              ::testing::Contains(HasSubstr("calibration camera cam2 (cam2) is not driven by any node")));
  EXPECT_EQ(c.warnings.size(), 4u);  // cam2..cam5
}

// [carving] and [silhouettes]: defaults (footprint, no silhouettes), the values given, and every bad one
// named by its key.
TEST(LoadRigConfig, CarvingAndSilhouettes) {
  TempRig rig;
  const std::string head = R"(calibration = "rig.yaml"
[[nodes]]
id = "a"
number = 1
cameras = ["cam0", "cam1"]
role = "front"
[trigger.udp]
targets = ["127.0.0.1:7700"]
)";
  const RigConfig d = parse(rig, head);
  EXPECT_EQ(d.carving.rule, CarveRule::Subpixel);
  EXPECT_EQ(d.carving.wire_value(), VC_CARVE_SUBPIXEL);
  EXPECT_EQ(d.silhouettes.every, 0);
  EXPECT_EQ(d.silhouettes.scale, 1);
  EXPECT_FALSE(d.silhouettes.enabled());
  const RigConfig c =
      parse(rig, head + "[carving]\nrule = \"centre\"\n[silhouettes]\nevery = 5\nscale = 4\n");
  EXPECT_EQ(c.carving.rule, CarveRule::Centre);
  EXPECT_EQ(c.carving.wire_value(), VC_CARVE_CENTRE);
  EXPECT_EQ(c.silhouettes.every, 5);
  EXPECT_EQ(c.silhouettes.scale, 4);
  EXPECT_TRUE(c.silhouettes.enabled());
  EXPECT_EQ(parse(rig, head + "[carving]\nrule = \"footprint\"\n").carving.rule, CarveRule::Footprint);
  EXPECT_EQ(parse(rig, head + "[carving]\nrule = \"footprint\"\n").carving.wire_value(), VC_CARVE_FOOTPRINT);
  EXPECT_EQ(parse(rig, head + "[carving]\nrule = \"subpixel\"\n").carving.rule, CarveRule::Subpixel);
  const std::pair<std::string, std::string> bad[] = {
      {"[carving]\nrule = \"center\"\n",
       "carving.rule: must be \"subpixel\", \"footprint\" or \"centre\", got \"center\""},
      {"[carving]\nrul = \"centre\"\n", "carving.rul"},
      {"[silhouettes]\nevery = 256\n", "silhouettes.every: must be in [0, 255] (0: never), got 256"},
      {"[silhouettes]\nevery = -1\n", "silhouettes.every"},
      {"[silhouettes]\nscale = 0\n", "silhouettes.scale: must be in [1, 16], got 0"},
      {"[silhouettes]\nscale = 17\n", "silhouettes.scale: must be in [1, 16], got 17"},
      {"[silhouettes]\nevery = \"2\"\n", "silhouettes.every"},
  };
  for (const auto& [text, expect] : bad) {
    SCOPED_TRACE(text);
    try {
      parse(rig, head + text);
      ADD_FAILURE() << "accepted";
    } catch (const ConfigError& e) {
      EXPECT_THAT(std::string(e.what()), HasSubstr(expect));
    }
  }
  // The structs check themselves too (a RigConfig built in code).
  SilhouetteOptions s;
  s.scale = 0;
  std::string why;
  EXPECT_FALSE(s.valid(&why));
  EXPECT_EQ(why, "scale: must be in [1, 16], got 0");
  EXPECT_TRUE(CarvingOptions{}.valid(&why));
  CarveRule r{};
  EXPECT_TRUE(parse_carve_rule("centre", &r));
  EXPECT_EQ(r, CarveRule::Centre);
  EXPECT_FALSE(parse_carve_rule("Centre", &r));
  EXPECT_EQ(to_string(CarveRule::Footprint), "footprint");
  EXPECT_EQ(to_string(CarveRule::Subpixel), "subpixel");
  EXPECT_TRUE(parse_carve_rule("subpixel", &r));
  EXPECT_EQ(r, CarveRule::Subpixel);
}

TEST(LoadRigConfig, FittingDefaultsKeysAndErrors) {
  TempRig rig;
  const std::string head = R"(calibration = "rig.yaml"
[[nodes]]
id = "a"
number = 1
cameras = ["cam0", "cam1"]
role = "front"
[trigger.udp]
targets = ["127.0.0.1:7700"]
)";
  const RigConfig d = parse(rig, head);
  EXPECT_TRUE(d.fitting.enabled);
  EXPECT_EQ(d.fitting.samples, 256);
  EXPECT_EQ(d.fitting.steps, 15);
  EXPECT_DOUBLE_EQ(d.fitting.k, 4);
  EXPECT_EQ(d.fitting.smoothing, Smoothing::None);
  EXPECT_TRUE(d.fitting.body.empty());
  const RigConfig c = parse(rig, head + R"([fitting]
enabled = false
samples = 128
steps = 9
span_deg = 30
k = 2
straight_deg = 5
smoothing = "one-euro"
one_euro_min_cutoff = 2.5
one_euro_beta = 0.1
body = "bodies/me.toml"
init_frames = 4
reinit_after_frames = 7
predict_frames = 12
)");
  EXPECT_FALSE(c.fitting.enabled);
  EXPECT_EQ(c.fitting.samples, 128);
  EXPECT_EQ(c.fitting.steps, 9);
  EXPECT_DOUBLE_EQ(c.fitting.span_deg, 30);
  EXPECT_DOUBLE_EQ(c.fitting.k, 2);
  EXPECT_DOUBLE_EQ(c.fitting.straight_deg, 5);
  EXPECT_EQ(c.fitting.smoothing, Smoothing::OneEuro);
  EXPECT_DOUBLE_EQ(c.fitting.one_euro_min_cutoff, 2.5);
  EXPECT_DOUBLE_EQ(c.fitting.one_euro_beta, 0.1);
  // Relative to the rig.toml's folder.
  EXPECT_EQ(c.fitting.body,
            std::filesystem::absolute(rig.toml_path().parent_path() / "bodies/me.toml").lexically_normal());
  EXPECT_EQ(c.fitting.init_frames, 4);
  EXPECT_EQ(c.fitting.reinit_after_frames, 7);
  EXPECT_EQ(c.fitting.predict_frames, 12);
  const std::pair<std::string, std::string> bad[] = {
      {"[fitting]\nsmoothing = \"kalman\"\n",
       "fitting.smoothing: must be \"none\" or \"one-euro\", got \"kalman\""},
      {"[fitting]\nsamples = 4\n", "fitting.samples: must be in [8, 4096], got 4 (line 10)"},
      {"[fitting]\nsteps = 0\n", "fitting.steps: must be in [1, 360], got 0 (line 10)"},
      {"[fitting]\nspan_deg = 0\n", "fitting.span_deg: must be in"},
      {"[fitting]\nk = 0.5\n", "fitting.k: must be in"},
      {"[fitting]\nstraight_deg = 90\n", "fitting.straight_deg: must be in"},
      {"[fitting]\none_euro_min_cutoff = 0\n", "fitting.one_euro_min_cutoff: must be in"},
      {"[fitting]\ninit_frames = 0\n", "fitting.init_frames: must be in"},
      {"[fitting]\nsample = 3\n", "fitting.sample"},
      {"[fitting]\nenabled = 1\n", "fitting.enabled"},
  };
  for (const auto& [text, expect] : bad) {
    SCOPED_TRACE(text);
    try {
      parse(rig, head + text);
      ADD_FAILURE() << "accepted";
    } catch (const ConfigError& e) {
      EXPECT_THAT(std::string(e.what()), HasSubstr(expect));
    }
  }
  FittingOptions f;
  f.predict_frames = -1;
  std::string why;
  EXPECT_FALSE(f.valid(&why));
  EXPECT_EQ(why, "predict_frames: must be in [0, 100000], got -1");
}

TEST(LoadRigConfig, TrackingRolesEveryNodeByDefaultFrontOnlyOnRequestAndPerNodeOverrides) {
  TempRig rig;
  const std::string nodes = R"(calibration = "rig.yaml"
[[nodes]]
id = "node0"
cameras = ["cam0", "cam1"]
role = "front"
[[nodes]]
id = "node1"
cameras = ["cam2", "cam3"]
[[nodes]]
id = "node2"
cameras = ["cam4", "cam5"]
track = false
[trigger.udp]
targets = ["127.0.0.1:7700", "127.0.0.1:7701", "127.0.0.1:7702"]
)";
  const RigConfig all = parse(rig, nodes);
  EXPECT_EQ(all.tracking.nodes, TrackingNodes::All);
  EXPECT_TRUE(all.tracks(all.nodes[0]));
  EXPECT_TRUE(all.tracks(all.nodes[1]));   // a side node tracks too: every view counts
  EXPECT_FALSE(all.tracks(all.nodes[2]));  // its own `track = false`
  EXPECT_EQ(all.tracking_nodes().size(), 2u);

  const RigConfig front = parse(rig, nodes + "[tracking]\nnodes = \"front\"\n");
  EXPECT_EQ(front.tracking.nodes, TrackingNodes::Front);
  EXPECT_TRUE(front.tracks(front.nodes[0]));
  EXPECT_FALSE(front.tracks(front.nodes[1]));
  EXPECT_FALSE(front.tracks(front.nodes[2]));

  std::string with_override = nodes;
  with_override.replace(with_override.find("track = false"), 13, "track = true");
  const RigConfig over = parse(rig, with_override + "[tracking]\nnodes = \"front\"\n");
  EXPECT_TRUE(over.tracks(over.nodes[2]));  // a side node that asks to track, in front-only mode
  EXPECT_FALSE(over.tracks(over.nodes[1]));

  const RigConfig off = parse(rig, nodes + "[features]\nenabled = false\n");
  EXPECT_TRUE(off.tracking_nodes().empty());  // features off: nobody tracks, whatever the roles
}

TEST(LoadRigConfig, CamerasAreNamedByNameOrByCalibrationNode) {
  TempRig rig;
  const RigConfig c = parse(rig, edit("[\"cam0\", \"cam1\"]", "[\"cam1\", \"cam0\"]"));
  EXPECT_EQ(c.nodes[0].cameras[0], "cam1");
}

// Each case: an edit of the valid TOML and the text the error must contain (file, key, reason).
struct BadCase {
  const char* name;
  std::string toml;
  const char* expect;
};

class InvalidConfig : public ::testing::TestWithParam<BadCase> {};

TEST_P(InvalidConfig, IsRejectedNamingTheKey) {
  TempRig rig;
  try {
    parse(rig, GetParam().toml);
    FAIL() << "accepted: " << GetParam().name;
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_THAT(what, HasSubstr(GetParam().expect)) << what;
    EXPECT_EQ(what.rfind(rig.toml_path().string() + ": ", 0), 0u)
        << "message must start with the file: " << what;
  }
}

std::vector<BadCase> bad_cases() {
  return {
      {"rate zero", edit("rate_hz = 60", "rate_hz = 0"),
       "trigger.rate_hz: must be in (0, 1000], got 0 (line"},
      {"rate too high", edit("rate_hz = 60", "rate_hz = 1500"),
       "trigger.rate_hz: must be in (0, 1000], got 1500"},
      {"rate wrong type", edit("rate_hz = 60", "rate_hz = \"60\""),
       "trigger.rate_hz: expected a number, got a string"},
      {"width too wide", edit("pulse_width_us = 200", "pulse_width_us = 9000"),
       "trigger.pulse_width_us: must be less than half the period"},
      {"width negative", edit("pulse_width_us = 200", "pulse_width_us = -1"),
       "trigger.pulse_width_us: must be > 0"},
      {"unknown backend", edit("backend = \"udp\"", "backend = \"serial\""),
       "trigger.backend: must be \"udp\", \"gpiod\" or \"ftdi\", got \"serial\""},
      {"rt priority", edit("rt_priority = 40", "rt_priority = 120"),
       "trigger.rt_priority: must be in [0, 99], got 120"},
      {"late threshold", edit("late_threshold_us = 300", "late_threshold_us = -5"),
       "trigger.late_threshold_us: must be >= 0"},
      {"udp not loopback", edit("\"127.0.0.1:7702\"", "\"10.0.0.5:7702\""),
       "trigger.udp.targets[1]: must be a loopback address"},
      {"udp bad endpoint", edit("\"127.0.0.1:7702\"", "\"127.0.0.1\""),
       "trigger.udp.targets[1]: expected \"host:port\""},
      {"udp bad port", edit("\"127.0.0.1:7702\"", "\"127.0.0.1:99999\""),
       "trigger.udp.targets[1]: port must be 1-65535"},
      {"udp duplicate", edit("\"127.0.0.1:7703\"", "\"127.0.0.1:7701\""),
       "trigger.udp.targets[2]: 127.0.0.1:7701 is listed twice"},
      {"udp too few", edit(", \"127.0.0.1:7703\"", ""), "trigger.udp.targets: 2 targets for 3 nodes"},
      {"udp targets not array",
       edit("targets = [\"127.0.0.1:7701\", \"127.0.0.1:7702\", \"127.0.0.1:7703\"]",
            "targets = \"127.0.0.1:7701\""),
       "trigger.udp.targets: expected an array, got a string"},
      {"gpiod line missing", edit("backend = \"udp\"", "backend = \"gpiod\"", edit("line = 18\n", "")),
       "trigger.gpiod.line: give either a line offset"},
      {"gpiod line type", edit("line = 18", "line = 1.5"),
       "trigger.gpiod.line: expected a line offset (integer) or a line name (string), got a floating-point "
       "number"},
      {"gpiod line range", edit("line = 18", "line = 5000"),
       "trigger.gpiod.line: must be in [0, 1023], got 5000"},
      {"ftdi pin", edit("backend = \"udp\"", "backend = \"ftdi\"", edit("pin = 3", "pin = 9")),
       "trigger.ftdi.pin: must be an ADBUS bit 0-7, got 9"},
      {"ftdi vid range", edit("vid = 0x0403", "vid = 0x10000"),
       "trigger.ftdi.vid: must be in [0, 65535], got 65536"},
      {"ftdi interface", edit("interface = \"A\"", "interface = \"AB\""),
       "trigger.ftdi.interface: must be \"A\", \"B\", \"C\" or \"D\""},
      {"ftdi sample rate",
       edit("backend = \"udp\"", "backend = \"ftdi\"",
            edit("sample_rate_hz = 200000", "sample_rate_hz = 5000000")),
       "trigger.ftdi.sample_rate_hz: must be in [10000, 1000000]"},
      {"ftdi width below a sample",
       edit("backend = \"udp\"", "backend = \"ftdi\"", edit("pulse_width_us = 200", "pulse_width_us = 2")),
       "trigger.pulse_width_us: 2 us is shorter than one bit-bang sample"},
      {"t_lower", edit("t_lower = 2.5", "t_lower = 0"), "subtraction.t_lower: must be > 0, got 0"},
      {"t_upper below t_lower", edit("t_upper = 4.5", "t_upper = 2"),
       "subtraction.t_upper: must be greater than t_lower (2.5), got 2"},
      {"shadow angle", edit("shadow_angle_deg = 6", "shadow_angle_deg = 95"),
       "subtraction.shadow_angle_deg: must be in (0, 90), got 95"},
      {"cleanup", edit("cleanup_radius_px = 2", "cleanup_radius_px = 20"),
       "subtraction.cleanup_radius_px: must be in [0, 8], got 20"},
      {"cleanup type", edit("cleanup_radius_px = 2", "cleanup_radius_px = 2.5"),
       "subtraction.cleanup_radius_px: expected an integer, got a floating-point number"},
      {"background frames", edit("background_frames = 40", "background_frames = 1"),
       "subtraction.background_frames: must be in [2, 1000], got 1"},
      {"deadline", edit("deadline_ms = 40", "deadline_ms = 0"),
       "assembly.deadline_ms: must be in (0, 10000], got 0"},
      {"policy", edit("missing_node_policy = \"degraded\"", "missing_node_policy = \"wait\""),
       "assembly.missing_node_policy: must be \"drop\" or \"degraded\", got \"wait\""},
      {"recording dir", edit("dir = \"takes\"", "dir = \"\""), "recording.dir: must not be empty"},
      {"listen", edit("listen = \"any\"", "listen = \"example.org\""),
       "network.listen: must be a numeric IPv4 address or \"any\""},
      {"port", edit("port = 7650", "port = 0"), "network.port: must be in [1, 65535], got 0"},
      {"heartbeat interval too short", edit("heartbeat_interval_ms = 100", "heartbeat_interval_ms = 5"),
       "network.heartbeat_interval_ms: must be in [10, 1000] (proto/SPEC.md: a HEARTBEAT at least once per "
       "second), got 5 (line"},
      {"heartbeat interval too long", edit("heartbeat_interval_ms = 100", "heartbeat_interval_ms = 1500"),
       "network.heartbeat_interval_ms: must be in [10, 1000]"},
      {"heartbeat interval type", edit("heartbeat_interval_ms = 100", "heartbeat_interval_ms = 0.1"),
       "network.heartbeat_interval_ms: expected an integer, got a floating-point number"},
      {"heartbeat timeout not above interval",
       edit("heartbeat_timeout_ms = 1500", "heartbeat_timeout_ms = 100"),
       "network.heartbeat_timeout_ms: must be larger than heartbeat_interval_ms (100) and at most 600000, "
       "got "
       "100"},
      {"heartbeat timeout huge", edit("heartbeat_timeout_ms = 1500", "heartbeat_timeout_ms = 99999999999"),
       "network.heartbeat_timeout_ms: must be in [0, 600000], got 99999999999"},
      {"heartbeat timeout negative", edit("heartbeat_timeout_ms = 1500", "heartbeat_timeout_ms = -1"),
       "network.heartbeat_timeout_ms: must be in [0, 600000], got -1"},
      {"node id missing", edit("id = \"node1\"\n", ""), "nodes[1].id: missing"},
      {"node id chars", edit("id = \"node1\"", "id = \"node 1\""), "nodes[1].id: only letters, digits"},
      {"node id duplicate", edit("id = \"node2\"", "id = \"node0\""),
       "nodes[2].id: \"node0\" is already the id of nodes[0]"},
      {"node address", edit("address = \"127.0.0.1\"", "address = \"-bad-\""),
       "nodes[0].address: must be an IPv4 address, a host name or \"any\""},
      {"node cameras count", edit("[\"cam2\", \"cam3\"]", "[\"cam2\"]"),
       "nodes[1].cameras: an edge node drives exactly 2 cameras, got 1"},
      {"node cameras missing", edit("cameras = [\"cam2\", \"cam3\"]\n", ""), "nodes[1].cameras: missing"},
      {"node camera unknown", edit("\"cam3\"", "\"cam9\""),
       "nodes[1].cameras[1]: no camera \"cam9\" in the calibration (it has cam0..cam5)"},
      {"node camera twice", edit("\"cam4\"", "\"cam1\""),
       "nodes[2].cameras[0]: camera \"cam1\" is already driven by node node0"},
      {"node camera type", edit("\"cam3\"", "3"), "nodes[1].cameras[1]: expected a string, got an integer"},
      {"node role", edit("role = \"side\"", "role = \"back\""),
       "nodes[2].role: must be \"front\" or \"side\", got \"back\""},
      {"no nodes",
       edit("[[nodes]]\nid = \"node0\"\naddress = \"127.0.0.1\"\ncameras = [\"cam0\", \"cam1\"]\nrole = "
            "\"front\"\n\n[[nodes]]\nid = \"node1\"\ncameras = [\"cam2\", \"cam3\"]\n\n[[nodes]]\nid = "
            "\"node2\"\naddress = \"any\"\ncameras = [\"cam4\", \"cam5\"]\nrole = \"side\"\n",
            ""),
       "nodes: at least one [[nodes]] table is needed"},
      // Every node tracks by default ([tracking] nodes = "all"), so a rig without a front node tracks
      // too (TrackingRoles below); the old "no front node" error now needs the front-only mode.
      {"features without front", edit("role = \"front\"", "role = \"side\"\n[tracking]\nnodes = \"front\""),
       "features.enabled: feature tracking needs at least one tracking node ([tracking] nodes = \"front\" "
       "and no "
       "node with role = \"front\" or track = true; or set enabled = false)"},
      {"tracking nodes", edit("[[nodes]]", "[tracking]\nnodes = \"some\"\n\n[[nodes]]"),
       "tracking.nodes: must be \"all\" or \"front\", got \"some\""},
      {"node track type", edit("role = \"side\"", "role = \"side\"\ntrack = \"yes\""),
       "nodes[2].track: expected true or false, got a string"},
      {"grid voxel", edit("voxel_m = 0.025", "voxel_m = 0"), "grid: voxel_m must be a positive number"},
      {"grid min_m size", edit("min_m = [-1.0, -1.0, 0.0]", "min_m = [-1.0, 0.0]"),
       "grid.min_m: expected 3 numbers [x, y, z], got 2"},
      {"grid min_m type", edit("min_m = [-1.0, -1.0, 0.0]", "min_m = [-1.0, \"a\", 0.0]"),
       "grid.min_m[1]: expected a number, got a string"},
      {"grid nz missing", edit("nz = 90\n", ""), "grid.nz: missing"},
      {"calibration missing", edit("calibration = \"rig.yaml\"\n", ""), "calibration: missing"},
      {"calibration absent file", edit("calibration = \"rig.yaml\"", "calibration = \"nope.yaml\""),
       "calibration: file not found:"},
      {"version", edit("version = 1", "version = 2"),
       "version: this voxcap reads version 1 rig files, got 2"},
      {"unknown top-level key", edit("name = \"test\"", "name = \"test\"\nnmae = \"x\""),
       "nmae: unknown key (did you mean \"name\"?)"},
      {"unknown trigger key", edit("rate_hz = 60", "rate_hz = 60\nrate_hx = 61"),
       "trigger.rate_hx: unknown key (did you mean \"rate_hz\"?)"},
      {"unknown node key", edit("role = \"front\"", "role = \"front\"\ncamera = \"cam0\""),
       "nodes[0].camera: unknown key (did you mean \"cameras\"?)"},
      {"unknown nested key", edit("line = 18", "line = 18\nlabel = \"x\""),
       "trigger.gpiod.label: unknown key"},
      {"unknown section", edit("[network]", "[netwrk]"), "netwrk: unknown key (did you mean \"network\"?)"},
      {"section not a table",
       edit("[features]\nenabled = true\n", "", edit("name = \"test\"", "name = \"test\"\nfeatures = true")),
       "features: expected a table, got a boolean"},
      {"syntax error", edit("rate_hz = 60", "rate_hz = = 60"), "TOML syntax error"},
  };
}

INSTANTIATE_TEST_SUITE_P(Cases, InvalidConfig, ::testing::ValuesIn(bad_cases()),
                         [](const ::testing::TestParamInfo<BadCase>& param_info) {
                           std::string n = param_info.param.name;
                           for (char& ch : n)
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return n;
                         });

TEST(LoadRigConfig, ErrorsCarryKeyAndLine) {
  TempRig rig;
  try {
    parse(rig, edit("rate_hz = 60", "rate_hz = 0"));
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "trigger.rate_hz");
    EXPECT_EQ(e.file(), rig.toml_path().string());
    // Line of `rate_hz` in valid_toml().
    const std::string text = valid_toml();
    const int line = 1 + static_cast<int>(std::count(
                             text.begin(), text.begin() + static_cast<long>(text.find("rate_hz")), '\n'));
    EXPECT_EQ(e.line(), line);
  }
}

TEST(LoadRigConfig, GridComesFromTheCalibrationWhenRigTomlHasNone) {
  TempRig rig(/*with_grid=*/true);
  const std::string no_grid =
      edit("[grid]\nmin_m = [-1.0, -1.0, 0.0]\nvoxel_m = 0.025\nnx = 80\nny = 80\nnz = 90\n", "");
  const RigConfig c = parse(rig, no_grid);
  EXPECT_EQ(c.grid_source, GridSource::Calibration);
  EXPECT_DOUBLE_EQ(c.grid.voxel_m, 0.02);
  EXPECT_EQ(c.grid.nz, 110);

  TempRig bare(/*with_grid=*/false);
  try {
    parse(bare, no_grid);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("grid: missing, and the calibration file rig.yaml has no grid either"));
  }
}

TEST(LoadRigConfig, CalibrationErrorsAreWrappedWithTheKey) {
  TempRig rig;
  std::ofstream(rig.dir() / "broken.yaml") << "%YAML:1.0\n---\ncam0:\n   width: 640\n";
  try {
    parse(rig, edit("calibration = \"rig.yaml\"", "calibration = \"broken.yaml\""));
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "calibration");
    EXPECT_THAT(e.what(), HasSubstr("broken.yaml"));
  }
}

TEST(LoadRigConfig, WithoutLoadingTheCalibrationCameraNamesAreNotChecked) {
  TempRig rig;
  LoadOptions lo;
  lo.load_calibration = false;
  const RigConfig c = parse_rig_config(edit("\"cam3\"", "\"cam9\""), rig.toml_path(), lo);
  EXPECT_TRUE(c.calibration.cameras.empty());
  EXPECT_EQ(c.calibration_path, rig.dir() / "rig.yaml");
}

TEST(LoadRigConfig, AbsoluteCalibrationPathsAreKept) {
  TempRig rig;
  const std::string abs = (rig.dir() / "rig.yaml").string();
  const RigConfig c = parse_rig_config(edit("calibration = \"rig.yaml\"", "calibration = \"" + abs + "\""),
                                       "/nonexistent/elsewhere/rig.toml");
  EXPECT_EQ(c.calibration_path, abs);
}

TEST(LoadRigConfig, MissingFileIsAClearError) {
  try {
    load_rig_config("/nonexistent/voxcap/rig.toml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("/nonexistent/voxcap/rig.toml: cannot open the rig configuration"));
  }
}

TEST(LoadRigConfig, ExtraUdpTargetsAreAWarningNotAnError) {
  TempRig rig;
  const RigConfig c = parse(rig, edit("\"127.0.0.1:7703\"", "\"127.0.0.1:7703\", \"127.0.0.1:7799\""));
  EXPECT_THAT(c.warnings, ::testing::Contains(HasSubstr("4 targets for 3 nodes")));
}

TEST(LoadRigConfig, GpiodLineByName) {
  TempRig rig;
  const RigConfig c =
      parse(rig, edit("backend = \"udp\"", "backend = \"gpiod\"", edit("line = 18", "line = \"GPIO18\"")));
  EXPECT_EQ(c.trigger.backend, TriggerBackend::Gpiod);
  EXPECT_EQ(c.trigger.gpiod.line_name, "GPIO18");
  EXPECT_EQ(c.trigger.gpiod.line_offset, -1);
}

}  // namespace
}  // namespace vc::config

namespace vc::config {
namespace {

// A keyless rig only on loopback (issue #13): the same rig with a key may listen anywhere.
TEST(RigKey, KeylessRigMustBeLoopbackOnlyAndKeyIsResolvedAgainstTheFile) {
  RigConfig c;
  c.nodes.resize(1);
  c.network.listen = "any";
  EXPECT_FALSE(c.loopback_only());
  c.network.listen = "127.0.0.1";
  c.nodes[0].address = "any";
  EXPECT_TRUE(c.loopback_only());
  c.nodes[0].address = "10.0.0.21";
  EXPECT_FALSE(c.loopback_only());
  c.nodes[0].address = "localhost";
  EXPECT_TRUE(c.loopback_only());
  c.nodes[0].address = "127.0.0.2";
  EXPECT_TRUE(c.loopback_only());
  // A name that merely starts like a loopback address may resolve anywhere: not loopback.
  c.nodes[0].address = "127.example.net";
  EXPECT_FALSE(c.loopback_only());
  c.nodes[0].address = "any";
  c.network.listen = "127.0.0.1.example.net";
  EXPECT_FALSE(c.loopback_only());
}

}  // namespace
}  // namespace vc::config
