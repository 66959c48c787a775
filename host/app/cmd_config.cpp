// `voxcap config check [rig.toml] [--json]`: loads a rig configuration with its calibration, reports the
// first error naming the key (exit 2), or prints what the rig resolves to and any warnings. It runs
// every check the host runs before it starts: the file's (load_rig_config, RigConfig::valid, the
// protocol's limits) and the aggregator's own, each node's CONFIG encoded for every protocol minor.
#include <cstdio>
#include <memory>
#include <string>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "voxcap/aggregator/aggregator.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/proto.h"

namespace vc::cli {
namespace {

using config::RigConfig;

nlohmann::json to_json(const RigConfig& c) {
  using nlohmann::json;
  json nodes = json::array();
  for (const config::NodeConfig& n : c.nodes)
    nodes.push_back({{"id", n.id},
                     {"address", n.address},
                     {"cameras", n.cameras},
                     {"role", to_string(n.role)},
                     {"tracks", c.tracks(n)}});
  json targets = json::array();
  for (const config::Endpoint& e : c.trigger.udp.targets) targets.push_back(e.str());
  const config::TriggerOptions& t = c.trigger;
  return {
      {"source", c.source.string()},
      {"name", c.name},
      {"calibration", {{"path", c.calibration_path.string()}, {"cameras", c.calibration.cameras.size()}}},
      {"grid",
       {{"min_m", {c.grid.min_m[0], c.grid.min_m[1], c.grid.min_m[2]}},
        {"voxel_m", c.grid.voxel_m},
        {"nx", c.grid.nx},
        {"ny", c.grid.ny},
        {"nz", c.grid.nz},
        {"source", c.grid_source == config::GridSource::Config ? "rig.toml" : "calibration"}}},
      {"nodes", nodes},
      {"subtraction",
       {{"t_upper", c.subtraction.t_upper},
        {"t_lower", c.subtraction.t_lower},
        {"shadow_angle_deg", c.subtraction.shadow_angle_deg},
        {"cleanup_radius_px", c.subtraction.cleanup_radius_px},
        {"background_frames", c.subtraction.background_frames}}},
      {"features", {{"enabled", c.features.enabled}}},
      {"tracking", {{"nodes", std::string(config::to_string(c.tracking.nodes))}}},
      {"carving", {{"rule", std::string(config::to_string(c.carving.rule))}}},
      {"silhouettes", {{"every", c.silhouettes.every}, {"scale", c.silhouettes.scale}}},
      {"trigger",
       {{"backend", to_string(t.backend)},
        {"rate_hz", t.rate_hz},
        {"pulse_width_us", t.pulse_width_us},
        {"active_low", t.active_low},
        {"rt_priority", t.rt_priority},
        {"late_threshold_us", t.late_threshold_us},
        {"udp", {{"targets", targets}}},
        {"gpiod", {{"chip", t.gpiod.chip_path().string()}, {"line", t.gpiod.line_str()}}},
        {"ftdi",
         {{"device", t.ftdi.device_str()},
          {"interface", std::string(1, t.ftdi.interface)},
          {"pin", t.ftdi.pin},
          {"sample_rate_hz", t.ftdi.sample_rate_hz},
          {"buffer_ms", t.ftdi.buffer_ms}}}}},
      {"assembly",
       {{"deadline_ms", c.assembly.deadline_ms},
        {"missing_node_policy", to_string(c.assembly.missing_node_policy)}}},
      {"recording", {{"dir", c.recording.dir.string()}}},
      {"network", {{"listen", c.network.listen}, {"port", c.network.port}}},
      {"key", c.key_path.empty() ? json(nullptr) : json(c.key_path.string())},
      {"warnings", c.warnings},
  };
}

std::string trigger_summary(const config::TriggerOptions& t) {
  std::string s = fmt::format("{} {} Hz, {} us{}: ", to_string(t.backend), t.rate_hz, t.pulse_width_us,
                              t.active_low ? " active low" : "");
  switch (t.backend) {
    case config::TriggerBackend::Udp:
      for (size_t i = 0; i < t.udp.targets.size(); ++i) s += (i ? ", " : "") + t.udp.targets[i].str();
      break;
    case config::TriggerBackend::Gpiod:
      s += fmt::format("{} line {}", t.gpiod.chip_path().string(), t.gpiod.line_str());
      break;
    case config::TriggerBackend::Ftdi:
      s += fmt::format("{} ADBUS{} at {} Hz", t.ftdi.device_str(), t.ftdi.pin, t.ftdi.sample_rate_hz);
      break;
  }
  return s;
}

void print_summary(const RigConfig& c) {
  fmt::print("{}: ok, rig \"{}\"\n", c.source.string(), c.name);
  fmt::print("  calibration  {} ({} cameras)\n", c.calibration_path.string(), c.calibration.cameras.size());
  fmt::print("  grid         {} x {} x {} voxels of {} mm from [{}, {}, {}] m ({})\n", c.grid.nx, c.grid.ny,
             c.grid.nz, c.grid.voxel_m * 1000.0, c.grid.min_m[0], c.grid.min_m[1], c.grid.min_m[2],
             c.grid_source == config::GridSource::Config ? "rig.toml" : "calibration");
  for (size_t i = 0; i < c.nodes.size(); ++i) {
    const config::NodeConfig& n = c.nodes[i];
    fmt::print("  {:<12} {} (node {}, {}) from {}: {} {}\n", i == 0 ? "nodes" : "", n.id,
               config::node_number(n, i, c.source.string()), to_string(n.role), n.address, n.cameras[0],
               n.cameras[1]);
  }
  fmt::print("  subtraction  T_u {} T_l {} shadow {} deg, clean-up {} px, {} background frames\n",
             c.subtraction.t_upper, c.subtraction.t_lower, c.subtraction.shadow_angle_deg,
             c.subtraction.cleanup_radius_px, c.subtraction.background_frames);
  if (c.features.enabled) {
    std::string who;
    for (const config::NodeConfig* n : c.tracking_nodes()) who += (who.empty() ? "" : ", ") + n->id;
    fmt::print("  features     head, hands, feet tracked on {} ([tracking] nodes = \"{}\"{})\n", who,
               config::to_string(c.tracking.nodes),
               c.tracking.nodes == config::TrackingNodes::All ? ": every view" : ": the front nodes");
  } else {
    fmt::print("  features     off\n");
  }
  fmt::print("  carving      {} rule\n", config::to_string(c.carving.rule));
  if (c.silhouettes.every > 0)
    fmt::print("  silhouettes  every {}th frame, 1/{} scale\n", c.silhouettes.every, c.silhouettes.scale);
  else
    fmt::print("  silhouettes  not sent\n");
  fmt::print("  trigger      {}\n", trigger_summary(c.trigger));
  fmt::print("  assembly     deadline {} ms, missing node: {}\n", c.assembly.deadline_ms,
             to_string(c.assembly.missing_node_policy));
  fmt::print("  recording    {}\n", c.recording.dir.string());
  fmt::print("  network      listen {}:{}\n", c.network.listen, c.network.port);
  if (c.key_path.empty())
    fmt::print("  key          none: control not authenticated (every address is loopback)\n");
  else
    fmt::print("  key          {} (a valid rig key, mode 0600)\n", c.key_path.string());
}

// What host/aggregator's constructor does with the configuration before the rig starts: a CONFIG
// message per node and protocol minor, encoded with the protocol's own checks (vc_encode_config).
void check_like_the_host(const RigConfig& c) {
  try {
    aggregator::load_rig_key(c);  // the key file named by `key =`: missing, too open, malformed
  } catch (const config::ConfigError& e) {
    throw UsageError(e.what());
  }
  // nodes[].address: resolved at start, and a HELLO from elsewhere is refused; one that does not
  // resolve stops the host.
  for (size_t k = 0; k < c.nodes.size(); ++k)
    if (c.nodes[k].address != "any" && aggregator::resolve_ipv4(c.nodes[k].address).empty())
      throw UsageError(fmt::format("{}: nodes[{}].address: \"{}\" does not resolve to an IPv4 address",
                                   c.source.string(), k, c.nodes[k].address));
  const uint32_t gid = aggregator::grid_id(c.grid);
  std::vector<uint8_t> msg(VC_PROTO_HEADER_SIZE + 4096);
  for (size_t k = 0; k < c.nodes.size(); ++k) {
    for (uint8_t minor = 0; minor <= VC_PROTO_VERSION_MINOR; ++minor) {
      const vc_config m = aggregator::make_config_message(c, c.nodes[k], gid, minor);
      size_t len = 0;
      vc_header hdr{};
      const int rc = vc_encode_config(msg.data(), msg.size(), &len, &hdr, &m);
      if (rc < 0)
        throw UsageError(fmt::format("{}: nodes[{}]: the host cannot encode its CONFIG: {}",
                                     c.source.string(), k, vc_proto_strerror(rc)));
    }
  }
}

}  // namespace

void add_config_commands(CLI::App& app) {
  CLI::App* group = app.add_subcommand("config", "Rig configuration (rig.toml) tools");
  group->require_subcommand(1, 1);

  struct CheckArgs {
    std::string path;
    bool json = false;
  };
  auto args = std::make_shared<CheckArgs>();
  CLI::App* check = group->add_subcommand(
      "check", "Load a rig.toml and its calibration; print what it resolves to, or the first error (exit 2)");
  check->add_option("rig", args->path,
                    "The rig.toml (default: $VOXCAP_RIG, else ./rig.toml, else hw/rigs/emulated.toml)");
  check->add_flag("--json", args->json, "Print the resolved configuration as JSON (keys as in rig.toml)");
  check->callback([args] {
    const std::filesystem::path path =
        args->path.empty() ? config::default_rig_config_path() : std::filesystem::path(args->path);
    RigConfig c;
    try {
      c = config::load_rig_config(path);
    } catch (const config::ConfigError& e) {
      throw UsageError(e.what());
    }
    check_like_the_host(c);
    if (args->json) {
      fmt::print("{}\n", to_json(c).dump(2));
    } else {
      print_summary(c);
    }
    for (const std::string& w : c.warnings) fmt::print(stderr, "warning: {}\n", w);
  });
}

}  // namespace vc::cli
