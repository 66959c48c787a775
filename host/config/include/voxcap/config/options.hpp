// The option structs of a rig configuration (rig.toml), one per concern. Each checks itself with
// `bool valid(std::string* why) const`; `why` then starts with the offending key path relative to the
// struct's own TOML table ("rate_hz: must be in (0, 1000], got 0"), which the loader prefixes with the
// table's path and the file name. They are filled from TOML in one place, load_rig_config()
// (rig_config.hpp); none of them depends on the rig model, so lower layers (trigger) can use them alone.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "voxcap/subtraction.h"

namespace vc::config {

// A UDP endpoint given as "host:port" with a numeric IPv4 host or "localhost".
struct Endpoint {
  std::string host;  // as written ("127.0.0.1", "localhost")
  uint16_t port = 0;

  // Parses "host:port"; returns false and says why for anything else.
  static bool parse(std::string_view text, Endpoint* out, std::string* why);
  bool is_loopback() const;  // 127.0.0.0/8 or "localhost"
  std::string str() const;   // "host:port"
  bool operator==(const Endpoint&) const = default;
};

// Background subtraction on the edges (paper sec. 5, eq. 1-2). Defaults and ranges are the ones of
// proto/include/voxcap/subtraction.h, shared with the edge; CONFIG carries these values as they are.
struct SubtractionOptions {
  double t_upper = VC_SUBTRACT_T_UPPER;  // T_u: foreground when |p - mu| > T_u * sigma in any channel
  double t_lower = VC_SUBTRACT_T_LOWER;  // T_l: surely background when below T_l * sigma in all channels
  double shadow_angle_deg = VC_SUBTRACT_SHADOW_ANGLE_DEG;  // T_angular: in-between pixels with a smaller
                                                           // colour angle are shadow
  int cleanup_radius_px = VC_CLEANUP_RADIUS_PX;  // radius of the edge's majority filter, 0..8; 0 = none
  int background_frames = VC_BACKGROUND_FRAMES;  // empty-scene frames learnt for mu and sigma

  bool valid(std::string* why) const;
};

// Trigger generation on the host (see host/trigger). Only the selected backend's table is checked.
enum class TriggerBackend { Udp, Gpiod, Ftdi };
std::string_view to_string(TriggerBackend backend);
bool parse_trigger_backend(std::string_view name, TriggerBackend* out);

struct UdpTriggerOptions {
  // One datagram per pulse to each target: one per edge in node order; extra targets are extra
  // listeners (e.g. `voxcap trigger listen`). Loopback only: t_ns is this host's CLOCK_MONOTONIC.
  std::vector<Endpoint> targets;
  // The rig key (VC_AUTH_KEY_SIZE bytes), filled by the host from RigConfig::key_path, not from the
  // file: with it every datagram carries a MAC and a counter (version 2, proto/SPEC.md).
  std::vector<uint8_t> key;

  bool valid(std::string* why) const;
};

struct GpiodTriggerOptions {
  std::string chip = "/dev/gpiochip0";  // a path, or a bare name such as "gpiochip4" (under /dev)
  int line_offset = -1;                 // the output line by offset ...
  std::string line_name;                // ... or by name ("GPIO18"); exactly one of the two is set

  bool valid(std::string* why) const;
  std::filesystem::path chip_path() const;  // "/dev/" + chip when chip is a bare name
  std::string line_str() const;             // "18" or "GPIO18", for messages
};

struct FtdiTriggerOptions {
  uint16_t vid = 0x0403;
  uint16_t pid = 0x6014;             // FT232H
  std::string serial;                // empty: the first matching device
  std::string description;           // USB product string to match; empty: any
  char interface = 'A';              // A for FT232H; A-D on FT2232H/FT4232H
  int pin = 3;                       // ADBUS bit driving the trigger buffer (hw/triggerbox)
  uint32_t sample_rate_hz = 100000;  // bit-bang clock: pulse timing resolution is 1 / this
  int buffer_ms = 50;                // pattern queued ahead of the chip (underrun margin)

  bool valid(std::string* why) const;
  std::string device_str() const;  // "0403:6014" (+ " serial X")
};

struct TriggerOptions {
  TriggerBackend backend = TriggerBackend::Udp;
  double rate_hz = 60.0;             // pulses per second, (0, 1000]
  double pulse_width_us = 100.0;     // active time of each pulse, less than half the period
  bool active_low = false;           // the line idles high and pulses low
  int rt_priority = 50;              // SCHED_FIFO priority of the pulse thread; 0 = normal thread
  double late_threshold_us = 500.0;  // a pulse emitted later than this after its slot counts as late
  UdpTriggerOptions udp;
  GpiodTriggerOptions gpiod;
  FtdiTriggerOptions ftdi;

  bool valid(std::string* why) const;
  double period_us() const { return 1e6 / rate_hz; }
};

// Frame assembly on the host: how long to wait for every node's HULL of a frame.
enum class MissingNodePolicy { Drop, Degraded };
std::string_view to_string(MissingNodePolicy policy);

struct AssemblyOptions {
  double deadline_ms = 50.0;                                        // after the pulse; (0, 10000]
  MissingNodePolicy missing_node_policy = MissingNodePolicy::Drop;  // drop the frame, or merge what came

  bool valid(std::string* why) const;
};

struct RecordingOptions {
  std::filesystem::path dir = "recordings";  // relative paths are relative to the working directory

  bool valid(std::string* why) const;
};

// Where the host listens for the edges' TCP connections, and how it watches them (host/session's
// ServerOptions takes these). The host sends HEARTBEAT every heartbeat_interval_ms and drops a node
// silent for heartbeat_timeout_ms. The edges keep their own clock (edge.toml [link] heartbeat_ms, 250,
// and host_timeout_ms, 3000: an edge reconnects when the host is silent that long), so the interval
// stays at most a second (proto/SPEC.md: HEARTBEAT at least once per second; within the edges'
// 3 s), and the timeout must exceed the interval (session::ServerOptions::valid's rule).
struct NetworkOptions {
  static constexpr int kMaxHeartbeatIntervalMs = 1000;
  static constexpr int kMaxHeartbeatTimeoutMs = 600'000;  // edge.toml's host_timeout_ms bound

  std::string listen = "127.0.0.1";  // IPv4 address or "any" (0.0.0.0)
  uint16_t port = 7600;
  int heartbeat_interval_ms = 250;  // [10, 1000]
  int heartbeat_timeout_ms = 2000;  // (interval, 600000]

  bool valid(std::string* why) const;
};

// The live pose stream out over the VMC protocol ([vmc], host/stream): OSC bundles over UDP to an
// animation tool (VSeeFace, Unity's EVMC4U, Blender's VMC add-ons). Off by default; a target off this
// machine is allowed (the tool often runs on another PC) and is the user's explicit choice.
struct VmcOptions {
  static constexpr double kMaxRateHz = 240;
  bool enabled = false;
  Endpoint target{"127.0.0.1", 39539};  // the receiver ("Marionette"); 39539 is VMC's usual port
  double rate_hz = 60;                  // bundles per second, (0, 240]; at most the rig's trigger rate

  bool valid(std::string* why) const;
};

// The live viewer (host/view): the page and its WebSockets, served by voxcap-host and `voxcap rig`.
struct ViewerOptions {
  bool enabled = true;
  std::string bind = "127.0.0.1";  // IPv4 address or "any" (0.0.0.0): the page has no login, keep it local
  uint16_t port = 8080;
  std::filesystem::path assets;  // the page's files; empty: share/voxcap/web beside the binary's bin/

  bool valid(std::string* why) const;
};

enum class NodeRole { Side, Front };  // front nodes also track head, hands and feet (paper sec. 6)
std::string_view to_string(NodeRole role);

struct NodeConfig {
  std::string id;                    // [A-Za-z0-9_-]+, unique; the edge says it in HELLO
  std::string address = "any";       // the edge's IPv4 address/host name, or "any"
  std::vector<std::string> cameras;  // exactly two camera names of the calibration (cam0 ... camN-1)
  NodeRole role = NodeRole::Side;
  // The protocol's node id (what the edge says in HELLO): the node's `number` key, else the number `id`
  // is or ends in ("node3" → 3), set once by load_rig_config (parse_node_number); a node with neither
  // does not load. Unset only in a RigConfig built in code without it (config::node_number() says why).
  std::optional<uint16_t> number;
  // The node's own say on tracking ([[nodes]] track = true|false), over [tracking] nodes; unset: that
  // rule decides (RigConfig::tracks).
  std::optional<bool> track;

  bool valid(std::string* why) const;
  bool is_front() const { return role == NodeRole::Front; }
};

// Feature tracking needs at least one tracking node; RigConfig::valid() checks that across sections.
struct FeatureOptions {
  bool enabled = true;  // track head, hands, feet on the tracking nodes ([tracking])
};

// Which nodes track head, hands and feet ([tracking], issue #11): every node by default, so the host
// can triangulate from every view that sees a feature; `front` keeps the paper's front pair only.
// A node's `track` key overrides this for that node. CONFIG's feature_role FRONT (1) means "track".
enum class TrackingNodes { All, Front };
std::string_view to_string(TrackingNodes nodes);                       // "all", "front"
bool parse_tracking_nodes(std::string_view name, TrackingNodes* out);  // false for anything else
struct TrackingOptions {
  TrackingNodes nodes = TrackingNodes::All;
};

// How the edges carve ([carving], CONFIG's carve_rule): what of a voxel must touch each silhouette —
// its centre's pixel, its whole projected footprint, or the one-pixel square at its centre's exact
// projection (vc_carve_rule, proto/include/voxcap/camera_model.h; proto/SPEC.md "Carve rules").
enum class CarveRule { Centre, Footprint, Subpixel };
std::string_view to_string(CarveRule rule);                    // "centre", "footprint", "subpixel"
bool parse_carve_rule(std::string_view name, CarveRule* out);  // false for anything else
struct CarvingOptions {
  // subpixel: keeps the hands and feet (the centre rule loses voxels at mask edges) without the
  // footprint rule's phantom volume; footprint: a superset of the body with exact silhouettes.
  CarveRule rule = CarveRule::Subpixel;

  bool valid(std::string* why) const;
  uint16_t wire_value() const;  // CONFIG's carve_rule: VC_CARVE_CENTRE, _FOOTPRINT or _SUBPIXEL
};

// The edges' own masks sent to the host ([silhouettes], CONFIG's silhouette_every/_scale, SILHOUETTE
// messages): for scoring against truth and for previews.
struct SilhouetteOptions {
  int every = 0;  // 0: never; N: every frame whose seq is a multiple of N, 0..255
  int scale = 1;  // downscale factor, 1..16

  bool valid(std::string* why) const;
  bool enabled() const { return every > 0; }
};

// [hil]: what `voxcap hil` tests on a real rig (tests/hil/README.md). A test whose lines or cameras
// are not named here is skipped with a message naming the keys; no [hil] at all: every test skips.
struct HilLine {         // [hil.loopback], [hil.edge_input]: a GPIO input on the machine running `voxcap hil`
  std::string chip;      // "gpiochip0" or a path; empty: the line is not configured
  int line_offset = -1;  // by offset ...
  std::string line_name;           // ... or by name ("GPIO17")
  std::optional<bool> active_low;  // unset: [trigger] active_low (the wire's polarity)
  int debounce_us = 0;             // the kernel's debounce, 0 = off, 0..100000

  bool configured() const { return !chip.empty(); }
  bool valid(std::string* why) const;
  std::string line_str() const;  // "17" or "GPIO17", for messages
};

struct HilCamera {                    // [[hil.cameras]]: an externally triggered camera on this machine
  std::string backend = "libcamera";  // "libcamera" | "v4l2"
  std::string device;                 // libcamera: id or index ("0"); v4l2: "/dev/video0"
  std::string format = "yuyv";        // v4l2 pixel format
  int width = 0, height = 0;          // 0: the driver's default
  int exposure_us = 0;                // fixed exposure, 0: the backend's
  double latency_us = 0;              // the sensor's frame time minus its trigger edge, expected

  bool valid(std::string* why) const;
};

struct HilOptions {
  bool present = false;            // the file has a [hil] table
  HilLine loopback;                // test 1: an input wired to [trigger]'s output
  HilLine edge_input;              // tests 2, 3: the edge's trigger input, fed by [trigger]'s output
  std::vector<HilCamera> cameras;  // test 3: their trigger inputs on the same wire
  uint64_t pulses = 600;           // pulses per train, 1..1000000
  std::vector<double> rates_hz = {60, 120};  // test 2's rates, each (0, 1000]
  double smoke_seconds = 0;                  // test 4: the rig runs this long; 0: not configured
  double max_jitter_us = 0;                  // tests 1, 2 fail above it; 0: reported only
  double max_offset_us = 0;  // test 3 fails when a frame strays more from its latency; 0: reported only

  bool valid(std::string* why) const;
};

}  // namespace vc::config
