// voxcap-host: the aggregator of a real rig, as a daemon (systemd unit, or by hand). Thin: reads the
// rig.toml, runs the aggregator until SIGINT/SIGTERM, prints the figures. `voxcap rig` runs the same
// aggregator (and, with --emulated, the edges too). Exit codes: 0 ok, 1 runtime failure, 2 bad input.
// No exception leaves main.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <exception>
#include <thread>

#include <fmt/core.h>
#include <CLI/CLI.hpp>

#include "voxcap/aggregator/aggregator.hpp"
#include "voxcap/aggregator/record_stage.hpp"
#include "voxcap/base/log.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/record/session_info.hpp"
#include "voxcap/stream/vmc_stage.hpp"
#include "voxcap/view/viewer.hpp"

namespace {
std::atomic<bool> g_stop{false};
void on_signal(int) {
  g_stop = true;
}
}  // namespace

int main(int argc, char** argv) {
  try {
    vc::log::init("voxcap-host");  // log lines: "[time] [level] voxcap-host: ..." on stderr
    CLI::App app{
        "voxcap-host — the host aggregator of a voxcap rig: triggers the cameras, runs the edge "
        "sessions, merges the partial hulls. Configuration: rig.toml (host/config/README.md)."};
    std::string config;
    double seconds = 0;
    app.add_option("-c,--config", config, "rig.toml (default: $VOXCAP_RIG, else ./rig.toml)");
    app.add_option("--seconds", seconds, "stop after this long (default: until SIGINT/SIGTERM)");
    bool no_view = false;
    int view_port = -1;
    app.add_flag("--no-view", no_view,
                 "do not serve the live viewer (rig.toml [viewer] enabled = false does the same)");
    app.add_option("--view-port", view_port, "the viewer's port, over rig.toml [viewer] port (0: a free one)")
        ->check(CLI::Range(0, 65535));
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);  // --help
      std::fprintf(stderr, "voxcap-host: %s (see --help)\n", e.what());  // bad input: one line, exit 2
      return 2;
    }
    std::filesystem::path path =
        config.empty() ? vc::config::default_rig_config_path() : std::filesystem::path(config);
    vc::config::RigConfig rig = vc::config::load_rig_config(path);
    vc::aggregator::Aggregator agg(rig, {});
    // The pipeline after merge: the recording (every frame) — through the viewer's record switch when
    // the viewer is on (rig.toml [viewer]), so the page can stop and start it — and the viewer.
    std::unique_ptr<vc::view::Viewer> viewer;
    vc::aggregator::RecordStage* recording = nullptr;
    if (rig.viewer.enabled && !no_view) {
      vc::view::ViewerOptions vo;
      vo.server = rig.viewer;
      if (view_port >= 0) vo.server.port = static_cast<uint16_t>(view_port);
      vo.record_dir = rig.recording.dir;
      vo.record_at_start = true;
      viewer = std::make_unique<vc::view::Viewer>(vo);
      viewer->attach(agg.pipeline());
      viewer->set_report([&agg] { return agg.report(); });
      viewer->start();
      fmt::print("voxcap-host: viewer at {}\n", viewer->url());
    } else {
      recording = &agg.pipeline().tap(std::make_unique<vc::aggregator::RecordStage>(rig.recording.dir),
                                      vc::aggregator::RecordStage::kQueue);
    }
    if (rig.vmc.enabled)  // the live pose stream out ([vmc], host/stream)
      agg.pipeline().tap(std::make_unique<vc::stream::VmcStage>(rig.vmc), vc::stream::VmcStage::kQueue);
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    agg.start();
    const std::filesystem::path session_dir = recording ? recording->dir() : viewer->recorder()->state().dir;
    fmt::print("voxcap-host: recording to {}\n", session_dir.string());
    auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds > 0 ? seconds : 1e12);
    while (!g_stop && std::chrono::steady_clock::now() < end)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    agg.stop();
    if (viewer) viewer->stop();
    auto r = agg.report();
    fmt::print("voxcap-host: {} frames merged ({} complete, {} degraded, {} dropped), {:.1f} fps\n", r.frames,
               r.complete, r.degraded, r.dropped, r.fps);
    // The session as it is on disk, read back once closed: what it holds, damage skipped included.
    fmt::print("voxcap-host: {}\n",
               vc::record::run_recording_line(vc::record::read_back(session_dir, r.frames)));
  } catch (const vc::config::ConfigError& e) {
    std::fprintf(stderr, "voxcap-host: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "voxcap-host: %s\n", e.what());
    return 1;
  }
  return 0;
}
