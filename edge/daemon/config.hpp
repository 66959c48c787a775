// The edge node's configuration: a small TOML file (edge.toml) plus command-line overrides, turned
// into the daemon's vc_edged_options in one place. C++ only because toml++ and CLI11 are C++ APIs.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "edged.h"

namespace vc::edge {

// Bad configuration: the message names the file and the key.
struct ConfigError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct CameraSettings {
  std::string backend = "sim";  // v4l2 | libcamera | file | sim
  std::string device;           // /dev/video0, libcamera id/index, folder, or sim scene spec
  int index = -1;               // the camera's number in the rig (cam<index>); default: node_id*2 + k
  int width = 0, height = 0;
  std::string format = "default";  // v4l2: yuyv | uyvy | rgb24 | bgr24 | grey
  double fps = 0;
  int64_t exposure_us = 0;
  bool external_trigger = true;
  double latency_us = 0;  // frame timestamp − trigger edge
  std::string options;    // backend-specific "key=value,..." (file, sim: pace, loop, scene, seq_base)
};

struct EdgeSettings {
  int node_id = 0;
  std::string host = "127.0.0.1";
  int port = 7600;
  std::array<CameraSettings, 2> cameras;
  std::string trigger_backend = "udp";  // udp | gpiod
  std::string trigger_bind = "127.0.0.1";
  int trigger_port = 0;  // udp; default 47000 + node_id
  std::string gpio_chip = "gpiochip0";
  int gpio_line = -1;
  std::string gpio_line_name;
  bool gpio_active_low = false;
  std::string gpio_bias = "as-is";  // as-is | disabled | pull-up | pull-down
  int gpio_debounce_us = 0;
  std::string gpio_event_clock = "monotonic";
  double pair_tolerance_us = 4000;
  double pair_max_delay_ms = 50;
  int queue_messages = 64;
  int queue_mib = 32;
  int heartbeat_ms = 250;
  int host_timeout_ms = 3000;
  int reconnect_min_ms = 100;
  int reconnect_max_ms = 5000;
  int stats_ms = 1000;
  int camera_timeout_ms = 2000;
  int verbosity = 1;
  std::string state_dir;  // where the learnt background model is kept across restarts ("" = not kept)
  std::string key;        // the rig key file (`key`, relative to edge.toml's folder); "" = keyless
  std::vector<uint8_t> key_bytes;  // the key read from it (load_key), VC_AUTH_KEY_SIZE bytes or empty
  // `next_key`: during a rotation, the rig's new key file (relative like key; "" = none); the host may
  // prove either (host/deploy/README.md "Keys"). Needs key.
  std::string next_key;
  std::vector<uint8_t> next_key_bytes;  // read by load_key

  // Throws ConfigError naming the key.
  void validate() const;
};

// What an edge.toml may hold (a real one is under 2 KB).
inline constexpr std::size_t kMaxEdgeTomlBytes = std::size_t{1} << 20;

// Reads edge.toml into s (keys not in the file keep their values). Unknown keys are errors, and so
// are integers out of their type's range and numbers that are not finite. Only a regular file of at
// most kMaxEdgeTomlBytes is read (a FIFO or a device is refused at once).
void load_edge_toml(const std::string& path, EdgeSettings& s);
// The same over a file's text in memory (`path` names it in messages): tests and fuzzing.
void parse_edge_toml(const std::string& text, const std::string& path, EdgeSettings& s);

// Reads s.key into s.key_bytes and s.next_key into s.next_key_bytes (nothing without a key file). Throws
// ConfigError with the one-line reason: a missing file, one that group or others may read, not one line of 64
// hex digits.
void load_key(EdgeSettings& s);

// The daemon's options; strings point into s, which must outlive them.
vc_edged_options to_options(const EdgeSettings& s);

}  // namespace vc::edge
