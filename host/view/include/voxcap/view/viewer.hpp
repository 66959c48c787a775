// The live viewer of a rig (issue #15): the server (server.hpp), the "view" stage that turns frames
// into the page's messages, the record switch the page starts and stops, and replays of recorded
// sessions. One object per rig, wired by the app:
//
//   vc::view::Viewer viewer(rig, opts);
//   viewer.attach(agg.pipeline());                  // taps "view" (drop-oldest) and "record" (block)
//   viewer.set_report([&] { return agg.report(); }); // node health and stage timings for the page
//   viewer.start();  agg.start();  ...  agg.stop();  viewer.stop();
//
// Frames may be skipped for the page (at most max_hz reach it; silhouettes always), never for the
// recording: the record switch is a Block stage like RecordStage, which it runs while switched on.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "voxcap/aggregator/aggregator.hpp"
#include "voxcap/aggregator/record_stage.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/pipeline/pipeline.hpp"
#include "voxcap/view/assets.hpp"  // default_assets_dir()
#include "voxcap/view/server.hpp"

namespace vc::view {

// Recorded sessions below `parent`: folder names holding records.vcr, newest name first, at most `max`.
std::vector<std::string> list_sessions(const std::filesystem::path& parent, size_t max = 100);
// A session name a client may ask for: [A-Za-z0-9._-], not starting with '.', at most 128 bytes.
bool valid_session_name(std::string_view name);

// Every message of one frame for the page (encode.hpp): hull, features 2D/3D, pose, silhouettes.
std::vector<std::string> frame_messages(const pipeline::Frame& f, const config::RigConfig* rig,
                                        bool with_silhouettes = true);

class ViewStage : public pipeline::Stage {
 public:
  static constexpr pipeline::QueueOptions kQueue{4, pipeline::Overflow::DropOldest};
  // on_rig: told the rig at configure() (the viewer's Hello needs it).
  ViewStage(Server& server, double max_hz, std::function<void(const config::RigConfig*)> on_rig = {})
      : server_(server), max_hz_(max_hz), on_rig_(std::move(on_rig)) {}
  std::string name() const override { return "view"; }
  void configure(const pipeline::StageContext& ctx) override {
    rig_ = ctx.rig;
    if (on_rig_) on_rig_(rig_);
  }
  void process(pipeline::Frame& f) override;
  uint64_t frames_sent() const { return sent_; }
  uint64_t frames_skipped() const { return skipped_; }

 private:
  Server& server_;
  double max_hz_;
  std::function<void(const config::RigConfig*)> on_rig_;
  const config::RigConfig* rig_ = nullptr;
  uint64_t last_ns_ = 0;
  std::atomic<uint64_t> sent_{0}, skipped_{0};
};

// The recording, switched on and off at run time (the page's record button): while on, every frame
// goes to a RecordStage (one session folder per switch-on); the switch is applied on the stage's
// thread at the next frame.
class RecordSwitch : public pipeline::Stage {
 public:
  static constexpr pipeline::QueueOptions kQueue = aggregator::RecordStage::kQueue;
  RecordSwitch(std::filesystem::path parent, bool on) : parent_(std::move(parent)), want_(on) {}
  std::string name() const override { return "record"; }
  void configure(const pipeline::StageContext& ctx) override;
  void process(pipeline::Frame& f) override;
  void stop() override;

  void request(bool on) { want_ = on; }  // any thread
  struct State {
    bool on = false;
    std::filesystem::path dir;  // the session being written, or the last one
    uint64_t records = 0, sessions = 0;
    std::string error;
  };
  State state() const;
  const std::filesystem::path& parent() const { return parent_; }

 private:
  void apply();
  std::filesystem::path parent_;
  std::atomic<bool> want_;
  pipeline::StageContext ctx_;
  std::unique_ptr<aggregator::RecordStage> rec_;
  mutable std::mutex mu_;
  State state_;
};

struct ViewerOptions {
  config::ViewerOptions server;  // bind, port (0: a free one), assets (empty: default_assets_dir())
  std::filesystem::path record_dir = "recordings";  // sessions are recorded and listed here
  bool record_at_start = false;                     // the record switch starts on
  bool record_switch = true;  // false: no record switch (the caller records on its own; the page only lists)
  double max_hz = 30;         // frames to the page per second at most
  ServerOptions limits;       // clients, queues (bind/port/assets taken from above)
};

// A recorded session served alone (`voxcap view SESSION`): its folder and the rig it was recorded with
// (the session's own rig.toml and calibration.yaml copies).
struct SessionSource {
  std::filesystem::path dir;
  config::RigConfig rig;
};

class Replay;

class Viewer {
 public:
  // The rig comes from the pipeline the viewer is attached to (its stage's configure()); clients that
  // connected before get their Hello then.
  explicit Viewer(ViewerOptions options);
  ~Viewer();
  Viewer(const Viewer&) = delete;
  Viewer& operator=(const Viewer&) = delete;

  void attach(pipeline::Pipeline& p);  // before the pipeline starts
  // Instead of attach(): no rig, only this session; every page that connects replays it at once
  // (Hello `mode` "session"). No record switch. Before start().
  void serve_session(SessionSource source);
  void set_report(std::function<aggregator::Report()> fn);
  void start();  // throws std::runtime_error when it cannot listen or has no page
  void stop();
  uint16_t port() const;
  std::string url() const;  // http://ADDRESS:PORT/
  RecordSwitch* recorder() { return record_; }
  ViewStage* stage() { return stage_; }
  ServerStats server_stats() const;

 private:
  void on_control(ClientId client, std::string_view text);
  void on_closed(ClientId client);
  void on_tick();
  std::string stats_json();
  std::string hello(ClientId client);
  // The folder of session `name` a client may replay, or empty.
  std::filesystem::path session_dir(const std::string& name) const;
  void start_replay(ClientId client, const std::string& name, const std::filesystem::path& dir);

  std::atomic<const config::RigConfig*> rig_{nullptr};
  std::unique_ptr<SessionSource> session_;  // serve_session(): the one session, and the rig it owns
  ViewerOptions opt_;
  std::unique_ptr<Server> server_;
  ViewStage* stage_ = nullptr;
  RecordSwitch* record_ = nullptr;
  std::function<aggregator::Report()> report_;
  std::mutex mu_;  // replays_, report_
  std::map<ClientId, std::unique_ptr<Replay>> replays_;
  std::map<uint16_t, std::pair<uint64_t, uint64_t>> last_hulls_;  // node -> (hulls, t ns) at the last tick
  std::map<uint16_t, double> node_fps_;
};

}  // namespace vc::view
