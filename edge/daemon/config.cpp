#include "config.hpp"

#include <filesystem>

#include "voxcap/auth.h"

#include <fmt/core.h>

#include <toml++/toml.h>
#include <cmath>
#include <limits>
#include <set>

#include "voxcap/edge/clock.h"
#include "voxcap/rig/input_file.hpp"

namespace vc::edge {
namespace {

std::string one_line(std::string m) {
  for (char& c : m)
    if (c == '\n' || c == '\r') c = ' ';
  return m;
}

struct Reader {
  std::string file;

  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw ConfigError(one_line(fmt::format("{}: {}: {}", file, key, what)));  // a quoted key may hold '\n'
  }

  void check_keys(const toml::table& t, const std::string& prefix, const std::set<std::string>& known) const {
    for (const auto& [k, v] : t) {
      std::string key(k.str());
      if (!known.count(key)) fail(prefix + key, "unknown key");
    }
  }

  template <typename T>
  void get(const toml::table& t, const std::string& prefix, const char* key, T& out) const {
    const toml::node* n = t.get(key);
    if (!n) return;
    if constexpr (std::is_same_v<T, std::string>) {
      if (!n->is_string()) fail(prefix + key, "must be a string");
      out = **n->as_string();
    } else if constexpr (std::is_same_v<T, bool>) {
      if (!n->is_boolean()) fail(prefix + key, "must be true or false");
      out = **n->as_boolean();
    } else if constexpr (std::is_integral_v<T>) {
      if (!n->is_integer()) fail(prefix + key, "must be an integer");
      const int64_t v = **n->as_integer();  // range-checked before the cast: 4294967296 is not node 0
      if (v < std::numeric_limits<T>::min() || v > std::numeric_limits<T>::max())
        fail(prefix + key, fmt::format("{} is out of range", v));
      out = static_cast<T>(v);
    } else {
      if (n->is_integer())
        out = static_cast<T>(**n->as_integer());
      else if (n->is_floating_point())
        out = static_cast<T>(**n->as_floating_point());
      else
        fail(prefix + key, "must be a number");
      if (!std::isfinite(out)) fail(prefix + key, "must be a finite number");
    }
  }

  const toml::table* table(const toml::table& t, const char* key) const {
    const toml::node* n = t.get(key);
    if (!n) return nullptr;
    if (!n->is_table()) fail(key, "must be a table");
    return n->as_table();
  }
};

}  // namespace

void load_edge_toml(const std::string& path, EdgeSettings& s) {
  std::string text;
  try {
    text = vc::rig::read_input_file(path, kMaxEdgeTomlBytes);  // a FIFO or a device: refused, not waited on
  } catch (const std::runtime_error& e) {
    throw ConfigError(e.what());
  }
  parse_edge_toml(text, path, s);
}

void parse_edge_toml(const std::string& text, const std::string& path, EdgeSettings& s) {
  Reader r{path};
  toml::table root;
  try {
    root = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    throw ConfigError(fmt::format("{}:{}:{}: {}", path, e.source().begin.line, e.source().begin.column,
                                  one_line(std::string(e.description()))));
  }
  r.check_keys(root, "",
               {"node_id", "state_dir", "key", "next_key", "host", "cameras", "trigger", "link", "log"});
  r.get(root, "", "node_id", s.node_id);
  if (root.contains("key")) {
    std::string key;
    r.get(root, "", "key", key);
    std::filesystem::path kp(key);
    if (!key.empty() && kp.is_relative()) kp = std::filesystem::path(path).parent_path() / kp;
    s.key = key.empty() ? std::string() : kp.string();
  }
  if (root.contains("next_key")) {
    std::string key;
    r.get(root, "", "next_key", key);
    std::filesystem::path kp(key);
    if (!key.empty() && kp.is_relative()) kp = std::filesystem::path(path).parent_path() / kp;
    s.next_key = key.empty() ? std::string() : kp.string();
  }
  r.get(root, "", "state_dir", s.state_dir);
  if (auto* h = r.table(root, "host")) {
    r.check_keys(*h, "host.", {"address", "port"});
    r.get(*h, "host.", "address", s.host);
    r.get(*h, "host.", "port", s.port);
  }
  if (const toml::node* cams = root.get("cameras")) {
    const toml::array* arr = cams->as_array();
    if (!arr || arr->size() != 2) r.fail("cameras", "must be an array of exactly two [[cameras]] tables");
    for (size_t k = 0; k < 2; k++) {
      const toml::table* c = arr->get(k)->as_table();
      std::string p = fmt::format("cameras[{}].", k);
      if (!c) r.fail(p.substr(0, p.size() - 1), "must be a table");
      r.check_keys(*c, p,
                   {"backend", "device", "index", "width", "height", "format", "fps", "exposure_us",
                    "external_trigger", "latency_us", "options"});
      CameraSettings& cs = s.cameras[k];
      r.get(*c, p, "backend", cs.backend);
      r.get(*c, p, "device", cs.device);
      r.get(*c, p, "index", cs.index);
      r.get(*c, p, "width", cs.width);
      r.get(*c, p, "height", cs.height);
      r.get(*c, p, "format", cs.format);
      r.get(*c, p, "fps", cs.fps);
      r.get(*c, p, "exposure_us", cs.exposure_us);
      r.get(*c, p, "external_trigger", cs.external_trigger);
      r.get(*c, p, "latency_us", cs.latency_us);
      r.get(*c, p, "options", cs.options);
    }
  }
  if (auto* t = r.table(root, "trigger")) {
    r.check_keys(*t, "trigger.",
                 {"backend", "bind", "port", "chip", "line", "line_name", "active_low", "bias", "debounce_us",
                  "event_clock", "tolerance_us", "max_delay_ms"});
    r.get(*t, "trigger.", "backend", s.trigger_backend);
    r.get(*t, "trigger.", "bind", s.trigger_bind);
    r.get(*t, "trigger.", "port", s.trigger_port);
    r.get(*t, "trigger.", "chip", s.gpio_chip);
    r.get(*t, "trigger.", "line", s.gpio_line);
    r.get(*t, "trigger.", "line_name", s.gpio_line_name);
    r.get(*t, "trigger.", "active_low", s.gpio_active_low);
    r.get(*t, "trigger.", "bias", s.gpio_bias);
    r.get(*t, "trigger.", "debounce_us", s.gpio_debounce_us);
    r.get(*t, "trigger.", "event_clock", s.gpio_event_clock);
    r.get(*t, "trigger.", "tolerance_us", s.pair_tolerance_us);
    r.get(*t, "trigger.", "max_delay_ms", s.pair_max_delay_ms);
  }
  if (auto* l = r.table(root, "link")) {
    r.check_keys(*l, "link.",
                 {"queue_messages", "queue_mib", "heartbeat_ms", "host_timeout_ms", "reconnect_min_ms",
                  "reconnect_max_ms", "stats_ms", "camera_timeout_ms"});
    r.get(*l, "link.", "queue_messages", s.queue_messages);
    r.get(*l, "link.", "queue_mib", s.queue_mib);
    r.get(*l, "link.", "heartbeat_ms", s.heartbeat_ms);
    r.get(*l, "link.", "host_timeout_ms", s.host_timeout_ms);
    r.get(*l, "link.", "reconnect_min_ms", s.reconnect_min_ms);
    r.get(*l, "link.", "reconnect_max_ms", s.reconnect_max_ms);
    r.get(*l, "link.", "stats_ms", s.stats_ms);
    r.get(*l, "link.", "camera_timeout_ms", s.camera_timeout_ms);
  }
  if (auto* lg = r.table(root, "log")) {
    r.check_keys(*lg, "log.", {"verbosity"});
    r.get(*lg, "log.", "verbosity", s.verbosity);
  }
}

void EdgeSettings::validate() const {
  auto bad = [](const std::string& name, const std::string& what) {  // what may quote a value with '\n'
    throw ConfigError(one_line(fmt::format("{}: {}", name, what)));
  };
  if (node_id < 0 || node_id > 65535) bad("node_id", fmt::format("must be in 0..65535, got {}", node_id));
  if (host.empty()) bad("host.address", "must not be empty");
  if (!next_key.empty() && key.empty())
    bad("next_key", "needs key (a rotation goes from one key to the next)");
  if (port <= 0 || port > 65535) bad("host.port", fmt::format("must be in 1..65535, got {}", port));
  for (size_t k = 0; k < 2; k++) {
    const CameraSettings& c = cameras[k];
    std::string p = fmt::format("cameras[{}].", k);
    if (c.backend != "v4l2" && c.backend != "libcamera" && c.backend != "file" && c.backend != "sim")
      bad(p + "backend", fmt::format("must be v4l2, libcamera, file or sim, got '{}'", c.backend));
    if (c.backend != "sim" && c.device.empty()) bad(p + "device", "must be set for backend " + c.backend);
    if (c.width < 0 || c.height < 0 || c.width > 16384 || c.height > 16384) bad(p + "width", "out of range");
    if (c.index < -1 || c.index > 65535) bad(p + "index", "must be in 0..65535 (or absent)");
    if (c.exposure_us < 0 || c.exposure_us > 10'000'000) bad(p + "exposure_us", "must be in 0..10000000");
    if (!(c.latency_us >= 0 && c.latency_us <= 1e6)) bad(p + "latency_us", "must be in 0..1000000");
    vc_pixfmt f;
    if (vc_pixfmt_from_name(c.format.c_str(), &f) < 0)
      bad(p + "format", fmt::format("unknown pixel format '{}'", c.format));
    if (c.fps < 0 || c.fps > 1000) bad(p + "fps", "must be in 0..1000");
  }
  if (trigger_backend != "udp" && trigger_backend != "gpiod")
    bad("trigger.backend", fmt::format("must be udp or gpiod, got '{}'", trigger_backend));
  if (trigger_port < 0 || trigger_port > 65535) bad("trigger.port", "must be in 0..65535");
  if (gpio_line < -1 || gpio_line > 65535) bad("trigger.line", "must be in 0..65535");
  if (gpio_debounce_us < 0 || gpio_debounce_us > 1'000'000)
    bad("trigger.debounce_us", "must be in 0..1000000");
  if (trigger_backend == "gpiod" && gpio_line < 0 && gpio_line_name.empty())
    bad("trigger.line", "set trigger.line (offset) or trigger.line_name for the gpiod backend");
  if (gpio_bias != "as-is" && gpio_bias != "disabled" && gpio_bias != "pull-up" && gpio_bias != "pull-down")
    bad("trigger.bias", "must be as-is, disabled, pull-up or pull-down");
  vc_clock_id clk;
  if (vc_clock_from_name(gpio_event_clock.c_str(), &clk) < 0 || clk == VC_CLOCK_BOOTTIME)
    bad("trigger.event_clock", "must be monotonic or realtime");
  if (!(pair_tolerance_us > 0 && pair_tolerance_us <= 1e6))
    bad("trigger.tolerance_us", "must be in (0, 1000000]");
  if (!(pair_max_delay_ms > 0 && pair_max_delay_ms <= 1e4))
    bad("trigger.max_delay_ms", "must be in (0, 10000]");
  if (queue_messages < 1 || queue_messages > 4096) bad("link.queue_messages", "must be in 1..4096");
  if (queue_mib < 1 || queue_mib > 1024) bad("link.queue_mib", "must be in 1..1024");
  if (heartbeat_ms < 10 || heartbeat_ms > 60'000) bad("link.heartbeat_ms", "must be in 10..60000");
  if (host_timeout_ms <= heartbeat_ms || host_timeout_ms > 600'000)
    bad("link.host_timeout_ms", "must be larger than link.heartbeat_ms and at most 600000");
  if (reconnect_min_ms < 1 || reconnect_max_ms < reconnect_min_ms || reconnect_max_ms > 600'000)
    bad("link.reconnect_min_ms", "need 1 <= reconnect_min_ms <= reconnect_max_ms <= 600000");
  if (stats_ms < 10 || stats_ms > 600'000) bad("link.stats_ms", "must be in 10..600000");
  if (camera_timeout_ms < 1 || camera_timeout_ms > 600'000)
    bad("link.camera_timeout_ms", "must be in 1..600000");
  if (verbosity < 0 || verbosity > 2) bad("log.verbosity", "must be 0, 1 or 2");
}

void load_key(EdgeSettings& s) {
  s.key_bytes.clear();
  if (s.key.empty()) return;
  std::vector<uint8_t> k(VC_AUTH_KEY_SIZE);
  char why[512];
  if (vc_key_load(s.key.c_str(), k.data(), why, sizeof why) < 0) throw ConfigError(why);
  s.key_bytes = std::move(k);
  s.next_key_bytes.clear();
  if (s.next_key.empty()) return;
  std::vector<uint8_t> n(VC_AUTH_KEY_SIZE);
  if (vc_key_load(s.next_key.c_str(), n.data(), why, sizeof why) < 0) throw ConfigError(why);
  s.next_key_bytes = std::move(n);
}

vc_edged_options to_options(const EdgeSettings& s) {
  vc_edged_options o{};
  o.node_id = static_cast<uint16_t>(s.node_id);
  for (int k = 0; k < 2; k++) {
    const CameraSettings& c = s.cameras[k];
    vc_camera_config& cc = o.cameras[k];
    vc_camera_config_init(&cc);
    cc.backend = c.backend.c_str();
    cc.device = c.device.empty() ? nullptr : c.device.c_str();
    cc.index = c.index >= 0 ? c.index : s.node_id * 2 + k;
    cc.width = c.width;
    cc.height = c.height;
    vc_pixfmt_from_name(c.format.c_str(), &cc.pixfmt);
    if (c.fps > 0) {
      cc.fps_num = static_cast<uint32_t>(c.fps * 1000.0 + 0.5);
      cc.fps_den = 1000;
    }
    cc.external_trigger = c.external_trigger;
    cc.exposure_us = c.exposure_us;
    cc.held_frames = 2;
    o.camera_latency_ns[k] = static_cast<int64_t>(c.latency_us * 1000.0);
    cc.trigger_latency_ns = o.camera_latency_ns[k];
    cc.options = c.options.empty() ? nullptr : c.options.c_str();
  }
  vc_trigger_config_init(&o.trigger);
  o.trigger.backend = s.trigger_backend.c_str();
  o.trigger.bind_address = s.trigger_bind.c_str();
  o.trigger.source_address = s.host.c_str();  // only the host pulses (udp; secnet, #13)
  o.trigger.port = static_cast<uint16_t>(s.trigger_port ? s.trigger_port : 47000 + s.node_id);
  o.trigger.chip = s.gpio_chip.c_str();
  o.trigger.line_name = s.gpio_line_name.empty() ? nullptr : s.gpio_line_name.c_str();
  o.trigger.line_offset = s.gpio_line >= 0 ? static_cast<unsigned>(s.gpio_line) : 0;
  o.trigger.active_low = s.gpio_active_low;
  o.trigger.bias = s.gpio_bias == "disabled"    ? VC_TRIGGER_BIAS_DISABLED
                   : s.gpio_bias == "pull-up"   ? VC_TRIGGER_BIAS_PULL_UP
                   : s.gpio_bias == "pull-down" ? VC_TRIGGER_BIAS_PULL_DOWN
                                                : VC_TRIGGER_BIAS_AS_IS;
  o.trigger.debounce_us = static_cast<unsigned>(s.gpio_debounce_us);
  vc_clock_from_name(s.gpio_event_clock.c_str(), &o.trigger.event_clock);
  o.pair_tolerance_ns = static_cast<uint64_t>(s.pair_tolerance_us * 1000.0);
  o.pair_max_delay_ns = static_cast<uint64_t>(s.pair_max_delay_ms * 1e6);
  o.link.host = s.host.c_str();
  o.link.port = static_cast<uint16_t>(s.port);
  o.link.node_id = o.node_id;
  o.link.queue_msgs = static_cast<unsigned>(s.queue_messages);
  o.link.queue_bytes = static_cast<size_t>(s.queue_mib) << 20;
  o.link.heartbeat_ms = s.heartbeat_ms;
  o.link.host_timeout_ms = s.host_timeout_ms;
  o.link.reconnect_min_ms = s.reconnect_min_ms;
  o.link.reconnect_max_ms = s.reconnect_max_ms;
  o.link.key = s.key_bytes.empty() ? nullptr : s.key_bytes.data();
  o.trigger.key = o.link.key;
  o.link.next_key = o.link.key && !s.next_key_bytes.empty() ? s.next_key_bytes.data() : nullptr;
  o.trigger.next_key = o.link.next_key;
  o.stats_ms = s.stats_ms;
  o.camera_timeout_ms = s.camera_timeout_ms;
  o.verbosity = s.verbosity;
  o.state_dir = s.state_dir.empty() ? nullptr : s.state_dir.c_str();
  return o;
}

}  // namespace vc::edge
