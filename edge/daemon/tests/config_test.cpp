#include "config.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>

namespace {

std::string write_tmp(const std::string& text) {
  char path[] = "/tmp/voxcap-edge-XXXXXX.toml";
  int fd = mkstemps(path, 5);
  EXPECT_GE(fd, 0);
  close(fd);
  std::ofstream(path) << text;
  return path;
}

std::string load_error(const std::string& text) {
  std::string p = write_tmp(text);
  vc::edge::EdgeSettings s;
  try {
    vc::edge::load_edge_toml(p, s);
    s.validate();
  } catch (const vc::edge::ConfigError& e) {
    std::remove(p.c_str());
    return e.what();
  }
  std::remove(p.c_str());
  return "";
}

TEST(EdgeConfig, FullFileLoads) {
  std::string p = write_tmp(R"(
node_id = 2
[host]
address = "10.0.0.1"
port = 7701
[[cameras]]
backend = "v4l2"
device = "/dev/video0"
width = 640
height = 480
format = "yuyv"
fps = 60
[[cameras]]
backend = "libcamera"
device = "0"
exposure_us = 4000
latency_us = 150
[trigger]
backend = "gpiod"
chip = "gpiochip4"
line = 17
bias = "pull-down"
[link]
queue_messages = 32
)");
  vc::edge::EdgeSettings s;
  vc::edge::load_edge_toml(p, s);
  s.validate();
  std::remove(p.c_str());
  vc_edged_options o = vc::edge::to_options(s);
  EXPECT_EQ(o.node_id, 2);
  EXPECT_STREQ(o.cameras[0].backend, "v4l2");
  EXPECT_EQ(o.cameras[0].pixfmt, VC_PIXFMT_YUYV);
  EXPECT_EQ(o.cameras[0].index, 4);  // node 2, camera 0
  EXPECT_EQ(o.cameras[1].exposure_us, 4000);
  EXPECT_EQ(o.camera_latency_ns[1], 150000);
  EXPECT_STREQ(o.trigger.backend, "gpiod");
  EXPECT_EQ(o.trigger.line_offset, 17u);
  EXPECT_EQ(o.trigger.bias, VC_TRIGGER_BIAS_PULL_DOWN);
  EXPECT_EQ(o.link.port, 7701);
  EXPECT_EQ(o.link.queue_msgs, 32u);
}

TEST(EdgeConfig, CameraOptionsGoToTheBackendAsGiven) {
  std::string p = write_tmp(R"(
[[cameras]]
backend = "file"
device = "/data/take1"
options = "pace=1,loop=1"
[[cameras]]
backend = "file"
device = "/data/take1"
)");
  vc::edge::EdgeSettings s;
  vc::edge::load_edge_toml(p, s);
  s.validate();
  std::remove(p.c_str());
  vc_edged_options o = vc::edge::to_options(s);
  EXPECT_STREQ(o.cameras[0].options, "pace=1,loop=1");
  EXPECT_EQ(o.cameras[1].options, nullptr);
}

TEST(EdgeConfig, ErrorsNameTheKey) {
  EXPECT_NE(load_error("nodeid = 1\n").find("nodeid: unknown key"), std::string::npos);
  EXPECT_NE(load_error("[host]\nport = 0\n").find("host.port"), std::string::npos);
  EXPECT_NE(load_error("[host]\nport = \"x\"\n").find("host.port: must be an integer"), std::string::npos);
  EXPECT_NE(load_error("[[cameras]]\nbackend=\"sim\"\n").find("exactly two"), std::string::npos);
  EXPECT_NE(
      load_error("[[cameras]]\nbackend=\"usb\"\ndevice=\"x\"\n[[cameras]]\n").find("cameras[0].backend"),
      std::string::npos);
  EXPECT_NE(load_error("[trigger]\nbackend = \"gpiod\"\n").find("trigger.line"), std::string::npos);
  EXPECT_NE(load_error("[link]\nheartbeat_ms = 100\nhost_timeout_ms = 50\n").find("link.host_timeout_ms"),
            std::string::npos);
  EXPECT_NE(load_error("[trigger\n").find(".toml:"), std::string::npos);  // parse error with position
}

TEST(EdgeConfig, DefaultsAreTheEmulatedNode) {
  vc::edge::EdgeSettings s;
  s.validate();
  vc_edged_options o = vc::edge::to_options(s);
  EXPECT_STREQ(o.trigger.backend, "udp");
  EXPECT_EQ(o.trigger.port, 47000);
  EXPECT_STREQ(o.cameras[0].backend, "sim");
}

}  // namespace
