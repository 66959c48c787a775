// Test helpers: a temporary folder holding a small calibration file (6 cameras in a ring, with or
// without a grid) next to which rig.toml texts can be parsed.
#pragma once

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>

#include "voxcap/rig/calibration.hpp"

namespace vc::config::testing {

class TempRig {
 public:
  explicit TempRig(bool with_grid = true) {
    dir_ = std::filesystem::temp_directory_path() /
           ("voxcap-config-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter()++));
    std::filesystem::create_directories(dir_);
    rig::Calibration cal;
    for (int k = 0; k < 6; ++k) {
      const double a = 2.0 * std::numbers::pi * k / 6.0;
      cal.cameras.push_back(rig::Camera::look_at("cam" + std::to_string(k), 640, 480, 600.0,
                                                 {3.5 * std::cos(a), 3.5 * std::sin(a), 2.0}, {0, 0, 1}));
    }
    if (with_grid) {
      rig::VoxelGrid g;
      g.min_m = {-1.0, -1.0, 0.0};
      g.voxel_m = 0.02;
      g.nx = g.ny = 100;
      g.nz = 110;
      cal.grid = g;
    }
    rig::write_calibration((dir_ / "rig.yaml").string(), cal);
  }
  ~TempRig() {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  const std::filesystem::path& dir() const { return dir_; }
  std::filesystem::path toml_path() const { return dir_ / "rig.toml"; }

 private:
  static int& counter() {
    static int n = 0;
    return n;
  }
  std::filesystem::path dir_;
};

// A complete, valid emulated rig: 3 nodes, node0 in front, udp trigger.
inline std::string valid_toml() {
  return R"(# test rig
version = 1
name = "test"
calibration = "rig.yaml"
key = "rig.key"

[grid]
min_m = [-1.0, -1.0, 0.0]
voxel_m = 0.025
nx = 80
ny = 80
nz = 90

[[nodes]]
id = "node0"
address = "127.0.0.1"
cameras = ["cam0", "cam1"]
role = "front"

[[nodes]]
id = "node1"
cameras = ["cam2", "cam3"]

[[nodes]]
id = "node2"
address = "any"
cameras = ["cam4", "cam5"]
role = "side"

[subtraction]
t_upper = 4.5
t_lower = 2.5
shadow_angle_deg = 6
cleanup_radius_px = 2
background_frames = 40

[features]
enabled = true

[trigger]
backend = "udp"
rate_hz = 60
pulse_width_us = 200
active_low = false
rt_priority = 40
late_threshold_us = 300

[trigger.udp]
targets = ["127.0.0.1:7701", "127.0.0.1:7702", "127.0.0.1:7703"]

[trigger.gpiod]
chip = "gpiochip0"
line = 18

[trigger.ftdi]
vid = 0x0403
pid = 0x6014
serial = "FT1234"
interface = "A"
pin = 3
sample_rate_hz = 200000
buffer_ms = 60

[assembly]
deadline_ms = 40
missing_node_policy = "degraded"

[recording]
dir = "takes"

[network]
listen = "any"
port = 7650
heartbeat_interval_ms = 100
heartbeat_timeout_ms = 1500
)";
}

// valid_toml() with the first occurrence of `from` replaced by `to` (which must exist).
inline std::string edit(const std::string& from, const std::string& to, std::string text = valid_toml()) {
  const size_t at = text.find(from);
  if (at == std::string::npos) throw std::logic_error("test edit: \"" + from + "\" not in the TOML");
  return text.replace(at, from.size(), to);
}

}  // namespace vc::config::testing
