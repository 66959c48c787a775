// Cross-section validation of a rig configuration and its look-ups.
#include "voxcap/config/rig_config.hpp"

#include <fmt/format.h>

#include "voxcap/proto.h"

#include <cctype>
#include <string>

namespace vc::config {
namespace {

bool fail(std::string* why, std::string message) {
  if (why) *why = std::move(message);
  return false;
}

template <typename Options>
bool section_valid(const Options& o, const char* section, std::string* why) {
  std::string sub;
  if (o.valid(&sub)) return true;
  return fail(why, std::string(section) + "." + sub);
}

}  // namespace

std::optional<uint16_t> parse_node_number(std::string_view id, std::string* why) {
  size_t end = id.size(), begin = end;
  while (begin > 0 && std::isdigit(static_cast<unsigned char>(id[begin - 1]))) begin--;
  if (begin == end || end - begin > 5) {
    if (why) *why = fmt::format("'{}' must be or end in the node's number (0..65535)", id);
    return std::nullopt;
  }
  unsigned long v = std::stoul(std::string(id.substr(begin)));
  if (v > 65535) {
    if (why) *why = fmt::format("node number {} is over 65535", v);
    return std::nullopt;
  }
  return static_cast<uint16_t>(v);
}

uint16_t node_number(const NodeConfig& node, size_t k, const std::string& file) {
  if (node.number) return *node.number;
  std::string why;
  std::optional<uint16_t> n = parse_node_number(node.id, &why);
  if (!n) throw ConfigError(file, fmt::format("nodes[{}].id", k), why);
  return *n;
}

int RigConfig::camera_index(std::string_view camera_name) const {
  for (size_t k = 0; k < calibration.cameras.size(); ++k) {
    // A camera is named by its own name or by its node in the calibration file (cam<k>).
    if (calibration.cameras[k].name == camera_name || fmt::format("cam{}", k) == camera_name)
      return static_cast<int>(k);
  }
  return -1;
}

const NodeConfig* RigConfig::node(std::string_view id) const {
  for (const NodeConfig& n : nodes)
    if (n.id == id) return &n;
  return nullptr;
}

std::vector<const NodeConfig*> RigConfig::front_nodes() const {
  std::vector<const NodeConfig*> out;
  for (const NodeConfig& n : nodes)
    if (n.is_front()) out.push_back(&n);
  return out;
}

bool RigConfig::tracks(const NodeConfig& node) const {
  if (!features.enabled) return false;
  if (node.track) return *node.track;
  return tracking.nodes == TrackingNodes::All || node.is_front();
}

std::vector<const NodeConfig*> RigConfig::tracking_nodes() const {
  std::vector<const NodeConfig*> out;
  for (const NodeConfig& n : nodes)
    if (tracks(n)) out.push_back(&n);
  return out;
}

bool RigConfig::loopback_only() const {
  // An IPv4 literal in 127.0.0.0/8, or localhost; a host name such as "127.example.net" is not (it
  // may resolve anywhere).
  auto loopback = [](const std::string& a) {
    Endpoint e;
    e.host = a;
    return e.is_loopback();
  };
  if (!loopback(network.listen)) return false;
  for (const NodeConfig& n : nodes)
    if (n.address != "any" && !loopback(n.address)) return false;
  return true;
}

bool RigConfig::valid(std::string* why) const {
  std::string sub;
  if (!grid.valid(&sub)) return fail(why, "grid: " + sub);
  // The protocol's limits (proto/SPEC.md): the host could not encode a CONFIG for a larger grid.
  if (grid.count() > VC_PROTO_MAX_VOXELS)
    return fail(why, fmt::format("grid: {}x{}x{} = {} voxels is over the protocol's limit of {} (512^3)",
                                 grid.nx, grid.ny, grid.nz, grid.count(), VC_PROTO_MAX_VOXELS));
  if (nodes.empty()) return fail(why, "nodes: at least one [[nodes]] table is needed");
  if (key_path.empty() && !loopback_only())
    return fail(why,
                "key: a rig without a key may only use loopback addresses (network.listen, nodes[].address); "
                "make one with `voxcap key new rig.key` and add key = \"rig.key\"");

  const bool have_cameras = !calibration.cameras.empty();
  std::vector<std::string> driver(calibration.cameras.size());
  for (size_t i = 0; i < nodes.size(); ++i) {
    const NodeConfig& n = nodes[i];
    if (!n.valid(&sub)) return fail(why, fmt::format("nodes[{}].{}", i, sub));
    for (size_t j = 0; j < i; ++j)
      if (nodes[j].id == n.id)
        return fail(why, fmt::format("nodes[{}].id: \"{}\" is already the id of nodes[{}]", i, n.id, j));
    const std::optional<uint16_t> from_id = parse_node_number(n.id);
    if (!n.number || (from_id && *from_id != *n.number))
      return fail(why, fmt::format("nodes[{}].number: {} does not match its id \"{}\"", i,
                                   n.number ? std::to_string(*n.number) : "unset", n.id));
    for (size_t j = 0; j < i; ++j)
      if (n.number && nodes[j].number == n.number)
        return fail(why, fmt::format("nodes[{}].id: node number {} is used twice", i, *n.number));
    if (!have_cameras) continue;  // calibration not loaded: names cannot be checked
    for (size_t c = 0; c < n.cameras.size(); ++c) {
      const int k = camera_index(n.cameras[c]);
      if (k < 0)
        return fail(
            why,
            fmt::format("nodes[{}].cameras[{}]: no camera \"{}\" in the calibration (it has cam0..cam{})", i,
                        c, n.cameras[c], calibration.cameras.size() - 1));
      std::string& owner = driver[static_cast<size_t>(k)];
      if (!owner.empty())
        return fail(why, fmt::format("nodes[{}].cameras[{}]: camera \"{}\" is already driven by node {}", i,
                                     c, n.cameras[c], owner));
      owner = n.id;
    }
  }

  if (!section_valid(subtraction, "subtraction", why)) return false;
  if (!section_valid(carving, "carving", why)) return false;
  if (!section_valid(silhouettes, "silhouettes", why)) return false;
  if (!section_valid(trigger, "trigger", why)) return false;
  if (!section_valid(assembly, "assembly", why)) return false;
  if (!section_valid(recording, "recording", why)) return false;
  if (!section_valid(network, "network", why)) return false;
  if (!section_valid(vmc, "vmc", why)) return false;
  if (!section_valid(viewer, "viewer", why)) return false;

  if (features.enabled && tracking_nodes().empty())
    return fail(why,
                fmt::format("features.enabled: feature tracking needs at least one tracking node ([tracking] "
                            "nodes = \"{}\" and no node with {}track = true; or set enabled = false)",
                            to_string(tracking.nodes),
                            tracking.nodes == TrackingNodes::Front ? "role = \"front\" or " : ""));
  if (trigger.backend == TriggerBackend::Udp && trigger.udp.targets.size() < nodes.size())
    return fail(why,
                fmt::format("trigger.udp.targets: {} targets for {} nodes: the emulated trigger needs one "
                            "endpoint per node, in node order",
                            trigger.udp.targets.size(), nodes.size()));
  return true;
}

}  // namespace vc::config
