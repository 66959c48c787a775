// `voxcap view SESSION [--view-port P] [--view-bind ADDR]`: the viewer's page (host/view) for a recorded
// session alone, no rig: every page that connects replays it, with the timeline and play/pause/step.
// The session is untrusted input: it is opened once before serving (host/record's reader: damaged
// records in the middle are skipped and named on stderr, a torn tail is dropped), and a folder that is
// no session, a rig.toml that does not load or a session without frames is one line and exit 2.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>

#include <fmt/core.h>
#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "session_rig.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/record/recorder.hpp"
#include "voxcap/rig/calibration.hpp"
#include "voxcap/view/viewer.hpp"

namespace vc::cli {
namespace {

namespace fs = std::filesystem;

std::atomic<bool> g_view_stop{false};
void on_view_signal(int) {
  g_view_stop = true;
}

struct ViewArgs {
  std::string session;
  int port = -1;
  std::string bind;
  double seconds = 0;
};

void run_view(const ViewArgs& a) {
  fs::path dir = fs::absolute(fs::path(a.session)).lexically_normal();
  if (dir.filename().empty()) dir = dir.parent_path();  // "SESSION/"
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw UsageError(fmt::format("view: {}: no such session folder", a.session));
  if (!fs::is_regular_file(dir / "records.vcr", ec))
    throw UsageError(fmt::format("view: {}: not a voxcap session (no records.vcr)", a.session));
  record::Reader::Summary sum;
  try {
    sum = record::Reader::open(dir).summary();
  } catch (const std::exception& e) {
    throw UsageError(fmt::format("view: {}", e.what()));
  }
  for (const std::string& d : sum.damage) std::fprintf(stderr, "voxcap: view: %s\n", d.c_str());
  if (sum.frames == 0)
    throw UsageError(fmt::format("view: {}: no frames to replay ({})", a.session,
                                 sum.stop_detail.empty() ? record::to_string(sum.stop) : sum.stop_detail));

  view::ViewerOptions vo;
  if (a.port >= 0) vo.server.port = static_cast<uint16_t>(a.port);
  if (!a.bind.empty()) vo.server.bind = a.bind;
  config::ViewerOptions check = vo.server;
  check.port = 1;  // --view-port 0 (a free port) is fine here
  std::string why;
  if (!check.valid(&why)) throw UsageError("--view-bind: " + why);
  vo.record_switch = false;
  view::Viewer viewer(vo);
  viewer.serve_session({dir, session_rig(dir, "view", true)});
  std::signal(SIGINT, on_view_signal);
  std::signal(SIGTERM, on_view_signal);
  viewer.start();
  fmt::print(
      "session {}: {} frames, {:.1f} s{}{}\n", dir.filename().string(), sum.frames, sum.duration_s(),
      sum.skipped_records ? fmt::format(", {} damaged records skipped", sum.skipped_records) : "",
      sum.truncated_bytes ? fmt::format(", {} bytes of a torn tail ignored", sum.truncated_bytes) : "");
  fmt::print("viewer: {}\n", viewer.url());
  std::fflush(stdout);
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(a.seconds);
  while (!g_view_stop && (a.seconds <= 0 || std::chrono::steady_clock::now() < end))
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  viewer.stop();
}

}  // namespace

void add_view_commands(CLI::App& app) {
  auto a = std::make_shared<ViewArgs>();
  CLI::App* cmd = app.add_subcommand(
      "view",
      "serve the viewer's page for a recorded session alone (no rig): every page that opens it replays "
      "the session with the timeline, play/pause/step and seek (host/view/PROTOCOL.md); Ctrl-C stops. A "
      "damaged session is read past its damaged records (named on stderr); a folder that is no session, "
      "a session without frames or an unreadable rig.toml/calibration.yaml copy: one line, exit 2");
  cmd->add_option("SESSION", a->session, "a session folder (records.vcr, rig.toml, calibration.yaml)")
      ->required();
  cmd->add_option("--view-port", a->port,
                  "the viewer's port (default 8080; 0: a free one; the URL is printed)")
      ->check(CLI::Range(0, 65535));
  cmd->add_option("--view-bind", a->bind, "the viewer's IPv4 address (default 127.0.0.1; \"any\": all)");
  cmd->add_option("--seconds", a->seconds, "stop after S seconds (default: until Ctrl-C)")
      ->check(CLI::NonNegativeNumber);
  cmd->callback([a] { run_view(*a); });
}

}  // namespace vc::cli
