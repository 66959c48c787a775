// voxcap-edge: the edge node daemon. Thin: options from edge.toml and the command line, then the run
// loop of edged.c until SIGINT/SIGTERM. Exit codes: 0 ok, 1 runtime failure, 2 bad configuration or
// command line (one line; every numeric flag is range-checked, so --node-id -5 is refused, not node 0).
#include <csignal>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>

#include <CLI/CLI.hpp>

#include "config.hpp"
#include "edged.h"
#include "log.h"
#include "voxcap/auth.h"
#include "voxcap/edge/track/producer.hpp"

namespace {

// node.h's features hook over edge/track's Producer (the tracker of head, hands and feet).
int track_features(void* user, uint64_t seq, const uint8_t* const rgb[VC_NODE_CAMS],
                   const size_t stride[VC_NODE_CAMS], const uint8_t* const mask[VC_NODE_CAMS],
                   const vc_node_camera cams[VC_NODE_CAMS], vc_features out[VC_NODE_CAMS]) {
  const int width[VC_NODE_CAMS] = {cams[0].width, cams[1].width};
  const int height[VC_NODE_CAMS] = {cams[0].height, cams[1].height};
  return static_cast<vc::track::Producer*>(user)->track(seq, rgb, stride, mask, width, height, out);
}
void reset_features(void* user) {
  static_cast<vc::track::Producer*>(user)->reset();
}

// "WxH", each side 1..16384 and nothing else (sscanf took "640x480junk" and overflowed on 99999999999).
bool parse_size(const std::string& s, int* w, int* h) {
  const std::size_t x = s.find('x');
  if (x == std::string::npos) return false;
  auto side = [](std::string_view t, int* out) {
    if (t.empty() || t.size() > 5) return false;
    int v = 0;
    for (char c : t) {
      if (c < '0' || c > '9') return false;
      v = v * 10 + (c - '0');
    }
    *out = v;
    return v >= 1 && v <= 16384;
  };
  return side(std::string_view(s).substr(0, x), w) && side(std::string_view(s).substr(x + 1), h);
}

// --prove-key HEX: the proof voxcap deploy asks for over ssh (host/deploy/README.md, "Keys"), made
// with the key this configuration names: BLAKE2b over a nonce of ours and deploy's, for the proof role
// 3, which neither side of a rig connection ever accepts (node 1, host 2), so the answer cannot stand
// in for a node's proof on the wire. Prints "node_id=N nonce=HEX proof=HEX", and a second such line
// ending " key=next" for edge.toml's next_key during a rotation. 0, or 2 (bad nonce).
constexpr uint16_t kDeployProofRole = 3;

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::string to_hex(const uint8_t* p, std::size_t n) {
  static const char* digits = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < n; ++i) {
    out += digits[p[i] >> 4];
    out += digits[p[i] & 15];
  }
  return out;
}

int prove_key(const vc::edge::EdgeSettings& s, const std::string& nonce_hex) {
  uint8_t theirs[VC_AUTH_NONCE_SIZE], ours[VC_AUTH_NONCE_SIZE], proof[VC_AUTH_PROOF_SIZE];
  if (nonce_hex.size() != 2 * VC_AUTH_NONCE_SIZE) {
    vc_log(VC_LOG_ERROR, "--prove-key: expected %d hex digits", 2 * VC_AUTH_NONCE_SIZE);
    return 2;
  }
  for (std::size_t i = 0; i < VC_AUTH_NONCE_SIZE; ++i) {
    const int hi = hex_digit(nonce_hex[2 * i]), lo = hex_digit(nonce_hex[2 * i + 1]);
    if (hi < 0 || lo < 0) {
      vc_log(VC_LOG_ERROR, "--prove-key: not a hex nonce");
      return 2;
    }
    theirs[i] = static_cast<uint8_t>(hi * 16 + lo);
  }
  if (s.key_bytes.size() != VC_AUTH_KEY_SIZE) {
    vc_log(VC_LOG_ERROR, "--prove-key: the configuration names no rig key (keyless node)");
    return 2;
  }
  if (vc_auth_init() < 0) return 1;
  // One line per key held: the key, then (a rotation under way) the next key, marked "key=next".
  for (const std::vector<uint8_t>* k : {&s.key_bytes, &s.next_key_bytes}) {
    if (k->size() != VC_AUTH_KEY_SIZE) continue;
    vc_auth_random(ours, sizeof ours);
    vc_auth_prove(proof, k->data(), kDeployProofRole, static_cast<uint16_t>(s.node_id), ours, theirs);
    std::printf("node_id=%d nonce=%s proof=%s%s\n", s.node_id, to_hex(ours, sizeof ours).c_str(),
                to_hex(proof, sizeof proof).c_str(), k == &s.key_bytes ? "" : " key=next");
  }
  return 0;
}

void on_signal(int) {
  vc_edged_request_stop();
}

// "BACKEND" or "BACKEND:DEVICE".
void apply_camera(const std::string& spec, vc::edge::CameraSettings& c) {
  auto colon = spec.find(':');
  c.backend = spec.substr(0, colon);
  if (colon != std::string::npos) c.device = spec.substr(colon + 1);
}

int run(int argc, char** argv) {
  CLI::App app{
      "voxcap-edge — the edge node of a voxcap rig: captures two cameras on the trigger, subtracts the "
      "background, carves the partial visual hull and streams it to the host.\n"
      "Configuration: edge.toml (see edge/daemon/README.md for every key) with command-line overrides."};
  std::string config_path;
  bool check = false, no_tracking = false;
  int node_id = -1, port = -1, trigger_port = -1, gpio_line = -1, verbosity = -1;
  std::string host, trigger, gpio_chip, camera0, camera1, size, state_dir, key;
  app.add_option("-c,--config", config_path, "edge.toml to read (keys not given keep their defaults)");
  app.add_option("--node-id", node_id, "this node's id, 0..65535 (overrides node_id)")
      ->check(CLI::Range(0, 65535));
  app.add_option("--host", host, "host address (overrides host.address)");
  app.add_option("--port", port, "host TCP port, 1..65535 (overrides host.port; default 7600)")
      ->check(CLI::Range(1, 65535));
  app.add_option("--trigger", trigger, "trigger input backend: udp | gpiod (overrides trigger.backend)");
  app.add_option("--trigger-port", trigger_port,
                 "udp trigger port, 1..65535 (overrides trigger.port; default 47000+node id)")
      ->check(CLI::Range(1, 65535));
  app.add_option("--gpio-chip", gpio_chip, "gpiod: chip, e.g. gpiochip0 (overrides trigger.chip)");
  app.add_option("--gpio-line", gpio_line, "gpiod: line offset, 0..65535 (overrides trigger.line)")
      ->check(CLI::Range(0, 65535));
  app.add_option("--camera0", camera0,
                 "first camera as BACKEND[:DEVICE], e.g. v4l2:/dev/video0, sim, file:DIR");
  app.add_option("--camera1", camera1, "second camera as BACKEND[:DEVICE]");
  app.add_option("--size", size, "both cameras' size WxH (overrides cameras[].width/height)");
  app.add_option("-v,--verbosity", verbosity, "0 warnings, 1 info, 2 debug")->check(CLI::Range(0, 2));
  app.add_option(
      "--state-dir", state_dir,
      "keep the learnt background model here and restore it after a restart (overrides state_dir)");
  app.add_option(
      "--key", key,
      "the rig key file (overrides key; made by `voxcap key new`, mode 0600): prove it to the host "
      "and obey only a host that proves it");
  app.add_flag("--no-tracking", no_tracking,
               "do not offer feature tracking to the host (by default the node tracks head, hands and feet "
               "when the host's rig.toml gives it the tracking role)");
  app.add_flag("--check", check,
               "validate the configuration, open the cameras and the trigger, report, and exit");
  std::string prove_nonce;
  app.add_option("--prove-key", prove_nonce,
                 "print a proof that this configuration's rig key is the one voxcap deploy holds, over "
                 "deploy's 64-hex-digit nonce and one of ours (a role no rig connection accepts), and exit; "
                 "with next_key (a rotation under way) a second line, ending key=next, for that key");
  app.set_version_flag("--version", "voxcap-edge " VOXCAP_VERSION, "print the release and exit");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);  // --help
    // Bad input, whatever CLI11 calls it (an unknown option, -5 for --node-id): one line, exit 2.
    std::string msg = e.what();
    for (char& c : msg)
      if (c == '\n') c = ' ';
    vc_log(VC_LOG_ERROR, "%s (see --help)", msg.c_str());
    return 2;
  }

  vc::edge::EdgeSettings s;
  try {
    if (!config_path.empty()) vc::edge::load_edge_toml(config_path, s);
    if (node_id >= 0) s.node_id = node_id;
    if (!host.empty()) s.host = host;
    if (port >= 0) s.port = port;
    if (!trigger.empty()) s.trigger_backend = trigger;
    if (trigger_port >= 0) s.trigger_port = trigger_port;
    if (!gpio_chip.empty()) s.gpio_chip = gpio_chip;
    if (gpio_line >= 0) s.gpio_line = gpio_line;
    if (!camera0.empty()) apply_camera(camera0, s.cameras[0]);
    if (!camera1.empty()) apply_camera(camera1, s.cameras[1]);
    if (!size.empty()) {
      int w = 0, h = 0;
      if (!parse_size(size, &w, &h))
        throw vc::edge::ConfigError("--size: expected WxH with each side in 1..16384, got '" + size + "'");
      for (auto& c : s.cameras) c.width = w, c.height = h;
    }
    if (verbosity >= 0) s.verbosity = verbosity;
    if (!state_dir.empty()) s.state_dir = state_dir;
    if (!key.empty()) s.key = key;
    s.validate();
    vc::edge::load_key(s);
  } catch (const std::exception& e) {
    vc_log(VC_LOG_ERROR, "%s", e.what());
    return 2;
  }
  if (!prove_nonce.empty()) return prove_key(s, prove_nonce);
  vc_edged_options opt = vc::edge::to_options(s);
  if (check) return vc_edged_check(&opt) == 0 ? 0 : 1;
  std::optional<vc::track::Producer> tracker;
  try {
    tracker.emplace();
  } catch (const std::exception& e) {
    vc_log(VC_LOG_ERROR, "feature tracker: %s", e.what());
    return 1;
  }
  const vc_features_producer hook = {track_features, &*tracker, reset_features};
  if (!no_tracking) opt.features = &hook;

  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
  int rc = vc_edged_run(&opt);
  if (rc < 0) {
    vc_log(VC_LOG_ERROR, "stopped: %s", strerror(-rc));
    return 1;
  }
  return 0;
}

}  // namespace

// Anything that escapes run() (an allocation failure while building the tracker or the options) is
// one line and exit code 1, not std::terminate.
int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    vc_log(VC_LOG_ERROR, "%s", e.what());
  } catch (...) {
    vc_log(VC_LOG_ERROR, "unexpected failure");
  }
  return 1;
}
