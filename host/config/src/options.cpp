// Self-validation of the rig.toml option structs. Messages start with the key path relative to the
// struct's table, then say what is wanted and what was found.
#include "voxcap/config/options.hpp"
#include "voxcap/proto.h"

#include <arpa/inet.h>

#include <charconv>
#include <cmath>
#include <set>

#include <fmt/format.h>

namespace vc::config {
namespace {

bool fail(std::string* why, std::string message) {
  if (why) *why = std::move(message);
  return false;
}

bool is_id_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
}

bool is_ipv4(const std::string& text) {
  in_addr addr{};
  return inet_pton(AF_INET, text.c_str(), &addr) == 1;
}

// RFC 1123 host name: dot-separated labels of letters, digits and inner hyphens.
bool is_hostname(std::string_view text) {
  if (text.empty() || text.size() > 253) return false;
  size_t label = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '.') {
      if (label == 0 || text[i - 1] == '-') return false;
      label = 0;
      continue;
    }
    const bool alnum = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9');
    if (!alnum && !(c == '-' && label > 0)) return false;
    if (++label > 63) return false;
  }
  return label > 0 && text.back() != '-';
}

}  // namespace

bool Endpoint::parse(std::string_view text, Endpoint* out, std::string* why) {
  const size_t colon = text.rfind(':');
  if (colon == std::string_view::npos || colon == 0 || colon + 1 == text.size())
    return fail(why, fmt::format("expected \"host:port\", got \"{}\"", text));
  const std::string host(text.substr(0, colon));
  const std::string_view port_text = text.substr(colon + 1);
  unsigned port = 0;
  const auto [end, ec] = std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
  if (ec != std::errc() || end != port_text.data() + port_text.size() || port == 0 || port > 65535)
    return fail(why, fmt::format("port must be 1-65535, got \"{}\" in \"{}\"", port_text, text));
  if (host != "localhost" && !is_ipv4(host))
    return fail(why, fmt::format("host must be a numeric IPv4 address or localhost, got \"{}\"", host));
  out->host = host;
  out->port = static_cast<uint16_t>(port);
  return true;
}

bool Endpoint::is_loopback() const {
  if (host == "localhost") return true;
  in_addr addr{};
  if (inet_pton(AF_INET, host.c_str(), &addr) != 1) return false;
  return (ntohl(addr.s_addr) >> 24) == 127;
}

std::string Endpoint::str() const {
  return fmt::format("{}:{}", host, port);
}

bool SubtractionOptions::valid(std::string* why) const {
  if (!(t_lower > 0.0) || !std::isfinite(t_lower))
    return fail(why, fmt::format("t_lower: must be > 0, got {}", t_lower));
  if (!(t_upper > t_lower) || !std::isfinite(t_upper))
    return fail(why, fmt::format("t_upper: must be greater than t_lower ({}), got {}", t_lower, t_upper));
  if (!(shadow_angle_deg > 0.0 && shadow_angle_deg < 90.0))
    return fail(why, fmt::format("shadow_angle_deg: must be in (0, 90), got {}", shadow_angle_deg));
  // The edge runs the majority filter up to this radius and rejects a CONFIG beyond it.
  if (cleanup_radius_px < 0 || cleanup_radius_px > VC_CLEANUP_RADIUS_MAX_PX)
    return fail(why, fmt::format("cleanup_radius_px: must be in [0, {}], got {}", VC_CLEANUP_RADIUS_MAX_PX,
                                 cleanup_radius_px));
  if (background_frames < VC_BACKGROUND_FRAMES_MIN || background_frames > VC_BACKGROUND_FRAMES_MAX)
    return fail(why, fmt::format("background_frames: must be in [{}, {}], got {}", VC_BACKGROUND_FRAMES_MIN,
                                 VC_BACKGROUND_FRAMES_MAX, background_frames));
  return true;
}

std::string_view to_string(CarveRule rule) {
  switch (rule) {
    case CarveRule::Centre:
      return "centre";
    case CarveRule::Footprint:
      return "footprint";
    case CarveRule::Subpixel:
      return "subpixel";
  }
  return "?";
}

bool parse_carve_rule(std::string_view name, CarveRule* out) {
  for (CarveRule r : {CarveRule::Centre, CarveRule::Footprint, CarveRule::Subpixel}) {
    if (name == to_string(r)) {
      *out = r;
      return true;
    }
  }
  return false;
}

bool CarvingOptions::valid(std::string* why) const {
  if (rule != CarveRule::Centre && rule != CarveRule::Footprint && rule != CarveRule::Subpixel)
    return fail(why, fmt::format("rule: must be \"subpixel\", \"footprint\" or \"centre\", got {}",
                                 static_cast<int>(rule)));
  return true;
}

uint16_t CarvingOptions::wire_value() const {
  switch (rule) {
    case CarveRule::Centre:
      return VC_CARVE_CENTRE;
    case CarveRule::Footprint:
      return VC_CARVE_FOOTPRINT;
    case CarveRule::Subpixel:
      return VC_CARVE_SUBPIXEL;
  }
  return VC_CARVE_SUBPIXEL;
}

bool SilhouetteOptions::valid(std::string* why) const {
  if (every < 0 || every > 255)
    return fail(why, fmt::format("every: must be in [0, 255] (0: never), got {}", every));
  if (scale < 1 || scale > VC_PROTO_MAX_SILHOUETTE_SCALE)
    return fail(why, fmt::format("scale: must be in [1, {}], got {}", VC_PROTO_MAX_SILHOUETTE_SCALE, scale));
  return true;
}

std::string_view to_string(TriggerBackend backend) {
  switch (backend) {
    case TriggerBackend::Udp:
      return "udp";
    case TriggerBackend::Gpiod:
      return "gpiod";
    case TriggerBackend::Ftdi:
      return "ftdi";
  }
  return "?";
}

bool parse_trigger_backend(std::string_view name, TriggerBackend* out) {
  for (TriggerBackend b : {TriggerBackend::Udp, TriggerBackend::Gpiod, TriggerBackend::Ftdi}) {
    if (name == to_string(b)) {
      *out = b;
      return true;
    }
  }
  return false;
}

bool UdpTriggerOptions::valid(std::string* why) const {
  if (targets.empty()) return fail(why, "targets: at least one \"host:port\" is needed");
  std::set<std::string> seen;
  for (size_t i = 0; i < targets.size(); ++i) {
    const Endpoint& t = targets[i];
    if (!t.is_loopback())
      return fail(why, fmt::format("targets[{}]: must be a loopback address (the udp trigger is the "
                                   "emulated rig's; real rigs use gpiod or ftdi), got {}",
                                   i, t.str()));
    if (t.port == 0) return fail(why, fmt::format("targets[{}]: port must be 1-65535", i));
    if (!seen.insert(t.str()).second)
      return fail(why, fmt::format("targets[{}]: {} is listed twice", i, t.str()));
  }
  return true;
}

bool GpiodTriggerOptions::valid(std::string* why) const {
  if (chip.empty()) return fail(why, "chip: must name a gpiochip (\"/dev/gpiochip0\" or \"gpiochip0\")");
  const bool by_offset = line_offset >= 0;
  const bool by_name = !line_name.empty();
  if (by_offset == by_name)
    return fail(why, "line: give either a line offset (18) or a line name (\"GPIO18\")");
  if (by_offset && line_offset > 1023)
    return fail(why, fmt::format("line: offset must be in [0, 1023], got {}", line_offset));
  return true;
}

std::filesystem::path GpiodTriggerOptions::chip_path() const {
  if (chip.find('/') == std::string::npos) return std::filesystem::path("/dev") / chip;
  return chip;
}

std::string GpiodTriggerOptions::line_str() const {
  return line_name.empty() ? std::to_string(line_offset) : line_name;
}

bool FtdiTriggerOptions::valid(std::string* why) const {
  if (vid == 0) return fail(why, "vid: must be a USB vendor id (0x0403 for FTDI)");
  if (pid == 0) return fail(why, "pid: must be a USB product id (0x6014 for the FT232H)");
  if (interface < 'A' || interface > 'D')
    return fail(why, fmt::format("interface: must be \"A\", \"B\", \"C\" or \"D\", got \"{}\"", interface));
  if (pin < 0 || pin > 7) return fail(why, fmt::format("pin: must be an ADBUS bit 0-7, got {}", pin));
  if (sample_rate_hz < 10000 || sample_rate_hz > 1000000)
    return fail(why, fmt::format("sample_rate_hz: must be in [10000, 1000000], got {}", sample_rate_hz));
  if (buffer_ms < 10 || buffer_ms > 500)
    return fail(why, fmt::format("buffer_ms: must be in [10, 500], got {}", buffer_ms));
  return true;
}

std::string FtdiTriggerOptions::device_str() const {
  std::string s = fmt::format("{:04x}:{:04x}", vid, pid);
  if (!serial.empty()) s += fmt::format(" serial {}", serial);
  return s;
}

bool TriggerOptions::valid(std::string* why) const {
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0))
    return fail(why, fmt::format("rate_hz: must be in (0, 1000], got {}", rate_hz));
  if (!(pulse_width_us > 0.0) || !std::isfinite(pulse_width_us))
    return fail(why, fmt::format("pulse_width_us: must be > 0, got {}", pulse_width_us));
  // Below half a period two pulses can never merge, even when one is emitted late (scheduler.hpp).
  const double half_period_us = 0.5 * period_us();
  if (pulse_width_us >= half_period_us)
    return fail(why, fmt::format("pulse_width_us: must be less than half the period ({:.6g} us at {} Hz), "
                                 "got {}",
                                 half_period_us, rate_hz, pulse_width_us));
  if (rt_priority < 0 || rt_priority > 99)
    return fail(
        why, fmt::format("rt_priority: must be in [0, 99] (0 = no real-time thread), got {}", rt_priority));
  if (!(late_threshold_us >= 0.0) || !std::isfinite(late_threshold_us))
    return fail(why, fmt::format("late_threshold_us: must be >= 0, got {}", late_threshold_us));
  std::string sub;
  switch (backend) {
    case TriggerBackend::Udp:
      if (!udp.valid(&sub)) return fail(why, "udp." + sub);
      break;
    case TriggerBackend::Gpiod:
      if (!gpiod.valid(&sub)) return fail(why, "gpiod." + sub);
      break;
    case TriggerBackend::Ftdi: {
      if (!ftdi.valid(&sub)) return fail(why, "ftdi." + sub);
      // The chip times the pulse in whole samples: the width must be at least one sample.
      const double sample_us = 1e6 / ftdi.sample_rate_hz;
      if (pulse_width_us < sample_us)
        return fail(why, fmt::format("pulse_width_us: {} us is shorter than one bit-bang sample ({:.6g} us "
                                     "at ftdi.sample_rate_hz = {})",
                                     pulse_width_us, sample_us, ftdi.sample_rate_hz));
      break;
    }
  }
  return true;
}

std::string_view to_string(MissingNodePolicy policy) {
  return policy == MissingNodePolicy::Drop ? "drop" : "degraded";
}

bool AssemblyOptions::valid(std::string* why) const {
  if (!(deadline_ms > 0.0 && deadline_ms <= 10000.0))
    return fail(why, fmt::format("deadline_ms: must be in (0, 10000], got {}", deadline_ms));
  return true;
}

bool RecordingOptions::valid(std::string* why) const {
  if (dir.empty()) return fail(why, "dir: must not be empty");
  return true;
}

bool NetworkOptions::valid(std::string* why) const {
  if (listen != "any" && !is_ipv4(listen))
    return fail(why, fmt::format("listen: must be a numeric IPv4 address or \"any\", got \"{}\"", listen));
  if (port == 0) return fail(why, "port: must be 1-65535");
  if (heartbeat_interval_ms < 10 || heartbeat_interval_ms > kMaxHeartbeatIntervalMs)
    return fail(why, fmt::format("heartbeat_interval_ms: must be in [10, {}] (proto/SPEC.md: a HEARTBEAT at "
                                 "least once per second), got {}",
                                 kMaxHeartbeatIntervalMs, heartbeat_interval_ms));
  if (heartbeat_timeout_ms <= heartbeat_interval_ms || heartbeat_timeout_ms > kMaxHeartbeatTimeoutMs)
    return fail(why,
                fmt::format("heartbeat_timeout_ms: must be larger than heartbeat_interval_ms ({}) and at "
                            "most {}, got {}",
                            heartbeat_interval_ms, kMaxHeartbeatTimeoutMs, heartbeat_timeout_ms));
  return true;
}

bool VmcOptions::valid(std::string* why) const {
  if (target.port == 0) return fail(why, "target: port must be 1-65535");
  if (target.host != "localhost" && !is_ipv4(target.host))
    return fail(why, fmt::format("target: host must be a numeric IPv4 address or localhost, got \"{}\"",
                                 target.host));
  if (!(rate_hz > 0 && rate_hz <= kMaxRateHz))
    return fail(why, fmt::format("rate_hz: must be in (0, {}], got {}", kMaxRateHz, rate_hz));
  return true;
}

bool ViewerOptions::valid(std::string* why) const {
  if (bind != "any" && !is_ipv4(bind))
    return fail(why, fmt::format("bind: must be a numeric IPv4 address or \"any\", got \"{}\"", bind));
  if (port == 0) return fail(why, "port: must be 1-65535");
  return true;
}

std::string_view to_string(TrackingNodes nodes) {
  return nodes == TrackingNodes::All ? "all" : "front";
}

bool parse_tracking_nodes(std::string_view name, TrackingNodes* out) {
  if (name == "all")
    *out = TrackingNodes::All;
  else if (name == "front")
    *out = TrackingNodes::Front;
  else
    return false;
  return true;
}

std::string_view to_string(NodeRole role) {
  return role == NodeRole::Front ? "front" : "side";
}

bool NodeConfig::valid(std::string* why) const {
  if (id.empty()) return fail(why, "id: must not be empty");
  for (char c : id)
    if (!is_id_char(c))
      return fail(why, fmt::format("id: only letters, digits, '_' and '-' are allowed, got \"{}\"", id));
  if (address != "any" && !is_ipv4(address) && !is_hostname(address))
    return fail(why,
                fmt::format("address: must be an IPv4 address, a host name or \"any\", got \"{}\"", address));
  if (cameras.size() != 2)
    return fail(why, fmt::format("cameras: an edge node drives exactly 2 cameras, got {}", cameras.size()));
  if (cameras[0] == cameras[1]) return fail(why, fmt::format("cameras: \"{}\" is listed twice", cameras[0]));
  for (size_t i = 0; i < cameras.size(); ++i)
    if (cameras[i].empty()) return fail(why, fmt::format("cameras[{}]: must not be empty", i));
  return true;
}

bool HilLine::valid(std::string* why) const {
  if (!configured()) return true;
  if ((line_offset >= 0) == !line_name.empty())
    return fail(why, "line: give the input line by offset (17) or by name (\"GPIO17\")");
  if (debounce_us < 0 || debounce_us > 100000)
    return fail(why, fmt::format("debounce_us: must be in [0, 100000], got {}", debounce_us));
  return true;
}

std::string HilLine::line_str() const {
  return line_name.empty() ? std::to_string(line_offset) : line_name;
}

bool HilCamera::valid(std::string* why) const {
  if (backend != "libcamera" && backend != "v4l2")
    return fail(why, fmt::format("backend: must be \"libcamera\" or \"v4l2\", got \"{}\"", backend));
  if (device.empty()) return fail(why, "device: missing (libcamera: an id or index; v4l2: /dev/videoN)");
  if (width < 0 || height < 0 || width > 16384 || height > 16384)
    return fail(why, fmt::format("width, height: must be in [0, 16384], got {}x{}", width, height));
  if (exposure_us < 0 || exposure_us > 10000000)
    return fail(why, fmt::format("exposure_us: must be in [0, 10000000], got {}", exposure_us));
  if (std::fabs(latency_us) > 1e6)
    return fail(why, fmt::format("latency_us: must be within ±1 s, got {}", latency_us));
  return true;
}

bool HilOptions::valid(std::string* why) const {
  std::string sub;
  if (!loopback.valid(&sub)) return fail(why, "loopback." + sub);
  if (!edge_input.valid(&sub)) return fail(why, "edge_input." + sub);
  for (size_t i = 0; i < cameras.size(); ++i)
    if (!cameras[i].valid(&sub)) return fail(why, fmt::format("cameras[{}].{}", i, sub));
  if (cameras.size() > 16) return fail(why, fmt::format("cameras: at most 16, got {}", cameras.size()));
  if (pulses < 1 || pulses > 1000000)
    return fail(why, fmt::format("pulses: must be in [1, 1000000], got {}", pulses));
  if (rates_hz.empty() || rates_hz.size() > 8) return fail(why, "rates_hz: give 1 to 8 rates");
  for (double r : rates_hz)
    if (!(r > 0 && r <= 1000))
      return fail(why, fmt::format("rates_hz: each must be in (0, 1000], got {}", r));
  if (!(smoke_seconds >= 0 && smoke_seconds <= 86400))
    return fail(why, fmt::format("smoke_seconds: must be in [0, 86400], got {}", smoke_seconds));
  if (!(max_jitter_us >= 0))
    return fail(why, fmt::format("max_jitter_us: must be >= 0, got {}", max_jitter_us));
  if (!(max_offset_us >= 0))
    return fail(why, fmt::format("max_offset_us: must be >= 0, got {}", max_offset_us));
  return true;
}

}  // namespace vc::config
