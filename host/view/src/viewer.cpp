#include "voxcap/view/viewer.hpp"

#include <unistd.h>

#include <algorithm>
#include <condition_variable>
#include <thread>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "voxcap/base/clock.hpp"
#include "voxcap/record/pose.hpp"
#include "voxcap/record/recorder.hpp"
#include "voxcap/view/encode.hpp"

namespace vc::view {

using nlohmann::json;

bool valid_session_name(std::string_view name) {
  if (name.empty() || name.size() > 128 || name[0] == '.') return false;
  for (char c : name)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
          c == '_' || c == '.'))
      return false;
  return true;
}

std::vector<std::string> list_sessions(const std::filesystem::path& parent, size_t max) {
  std::vector<std::string> out;
  std::error_code ec;
  std::filesystem::directory_iterator it(parent, ec), end;
  size_t seen = 0;
  for (; !ec && it != end && seen < 10000; it.increment(ec), seen++) {
    const std::string name = it->path().filename().string();
    if (!valid_session_name(name)) continue;
    std::error_code e2;
    if (std::filesystem::is_regular_file(it->path() / "records.vcr", e2)) out.push_back(name);
  }
  std::sort(out.begin(), out.end(), std::greater<>());
  if (out.size() > max) out.resize(max);
  return out;
}

std::vector<std::string> frame_messages(const pipeline::Frame& f, const config::RigConfig* rig,
                                        bool with_silhouettes) {
  std::vector<std::string> out;
  out.push_back(encode_hull(f));
  if (std::string m = encode_features2d(f, rig); !m.empty()) out.push_back(std::move(m));
  if (std::string m = encode_features3d(f); !m.empty()) out.push_back(std::move(m));
  if (std::string m = encode_pose(f); !m.empty()) out.push_back(std::move(m));
  if (with_silhouettes)
    for (const pipeline::NodePart& p : f.nodes)
      for (const pipeline::Silhouette& s : p.silhouettes) out.push_back(encode_silhouette(f, p, s, rig));
  return out;
}

// ---- ViewStage ----

void ViewStage::process(pipeline::Frame& f) {
  // Silhouettes come at a low rate (CONFIG's silhouette_every): always passed on.
  for (const pipeline::NodePart& p : f.nodes)
    for (const pipeline::Silhouette& s : p.silhouettes)
      server_.broadcast(Channel::Live, std::make_shared<const std::string>(encode_silhouette(f, p, s, rig_)),
                        true);
  const uint64_t now = monotonic_ns();
  if (max_hz_ > 0 && last_ns_ && double(now - last_ns_) < 1e9 / max_hz_) {
    skipped_++;
    return;
  }
  last_ns_ = now;
  for (std::string& m : frame_messages(f, rig_, false))
    server_.broadcast(Channel::Live, std::make_shared<const std::string>(std::move(m)), true);
  if (std::string j = pose_json(f); !j.empty())
    server_.broadcast(Channel::PoseJson, std::make_shared<const std::string>(std::move(j)), false);
  sent_++;
}

// ---- RecordSwitch ----

void RecordSwitch::configure(const pipeline::StageContext& ctx) {
  ctx_ = ctx;
  apply();  // a recording asked for at start opens now (its folder errors stop the start)
  std::lock_guard<std::mutex> lock(mu_);
  if (!state_.error.empty()) throw std::runtime_error("record: " + state_.error);
}

void RecordSwitch::apply() {
  const bool want = want_;
  if (want == bool(rec_)) return;
  if (!want) {
    rec_->stop();
    rec_.reset();
    std::lock_guard<std::mutex> lock(mu_);
    state_.on = false;
    return;
  }
  try {
    auto r = std::make_unique<aggregator::RecordStage>(parent_);
    r->configure(ctx_);
    std::lock_guard<std::mutex> lock(mu_);
    state_.on = true;
    state_.dir = r->dir();
    state_.records = 0;
    state_.sessions++;
    state_.error.clear();
    rec_ = std::move(r);
  } catch (const std::exception& e) {
    want_ = false;
    std::lock_guard<std::mutex> lock(mu_);
    state_.error = e.what();
    if (ctx_.log) ctx_.log(log::Level::err, fmt::format("cannot start recording: {}", e.what()));
  }
}

void RecordSwitch::process(pipeline::Frame& f) {
  apply();
  if (!rec_) return;
  rec_->process(f);
  std::lock_guard<std::mutex> lock(mu_);
  state_.records = rec_->records();
}

void RecordSwitch::stop() {
  if (rec_) {
    rec_->stop();
    rec_.reset();
  }
  std::lock_guard<std::mutex> lock(mu_);
  state_.on = false;
}

RecordSwitch::State RecordSwitch::state() const {
  std::lock_guard<std::mutex> lock(mu_);
  return state_;
}

// ---- Replay: one client's replay of a recorded session, on a thread of its own ----

class Replay {
 public:
  static constexpr size_t kMaxFrames = 200000;
  static constexpr size_t kMaxBytes = 256u << 20;

  Replay(Server& server, ClientId client, std::filesystem::path dir, const config::RigConfig* rig,
         std::string name)
      : server_(server), client_(client), dir_(std::move(dir)), rig_(rig), name_(std::move(name)) {
    thread_ = std::thread([this] { run(); });
  }
  ~Replay() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      quit_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  // play, pause, step (by), seek (index)
  void command(const std::string& cmd, int64_t arg) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (cmd == "play") {
        playing_ = true;
        if (!frames_.empty() && index_ + 1 >= frames_.size()) pending_ = 0;  // at the end: from the start
      } else if (cmd == "pause") {
        playing_ = false;
      } else if (cmd == "step") {
        playing_ = false;
        pending_ =
            std::clamp<int64_t>(int64_t(index_) + arg, 0, frames_.empty() ? 0 : int64_t(frames_.size()) - 1);
      } else if (cmd == "seek") {
        pending_ = std::clamp<int64_t>(arg, 0, frames_.empty() ? 0 : int64_t(frames_.size()) - 1);
      }
    }
    cv_.notify_all();
    // The page learns of play/pause at once (a step or seek is answered with its frame).
    if (loaded_ && (cmd == "play" || cmd == "pause")) state();
  }

 private:
  struct Encoded {
    uint64_t seq = 0, t_trigger_ns = 0;
    std::vector<std::shared_ptr<const std::string>> msgs;
  };

  void state(const std::string& error = "") {
    // Read and sent under one lock: the replay's thread and a play/pause from the page post in the
    // order they read, so the last message the page gets is the newest state.
    std::lock_guard<std::mutex> order(state_mu_);
    json j;
    j["session"] = name_;
    j["loaded"] = loaded_.load();
    {
      std::lock_guard<std::mutex> lock(mu_);
      j["frames"] = frames_.size();
      j["index"] = index_;
      j["playing"] = playing_;
      if (index_ < frames_.size()) j["seq"] = frames_[index_].seq;
    }
    if (!error.empty()) j["error"] = error;
    server_.send(client_, std::make_shared<const std::string>(encode_json(MsgType::Replay, j.dump())), true,
                 false);
  }

  bool stopping() {
    std::lock_guard<std::mutex> lock(mu_);
    return quit_;
  }

  void load() {
    record::Reader reader = record::Reader::open(dir_);
    record::Record rec;
    pipeline::Frame f;
    bool have = false;
    size_t bytes = 0;
    auto flush = [&] {
      if (!have) return;
      Encoded e;
      e.seq = f.seq;
      e.t_trigger_ns = f.t_trigger_ns;
      for (std::string& m : frame_messages(f, rig_)) {
        bytes += m.size();
        e.msgs.push_back(std::make_shared<const std::string>(std::move(m)));
      }
      std::lock_guard<std::mutex> lock(mu_);
      frames_.push_back(std::move(e));
      have = false;
    };
    while (reader.next(rec)) {
      if (stopping() || frames_.size() >= kMaxFrames || bytes >= kMaxBytes) break;
      if (auto* fr = std::get_if<record::FrameRecord>(&rec)) {
        flush();
        f = record::frame_from_record(*fr);
        have = true;
      } else if (!have) {
        continue;
      } else if (auto* fe = std::get_if<record::FeatureRecord>(&rec); fe && fe->seq == f.seq) {
        pipeline::NodePart* part = nullptr;
        for (auto& p : f.nodes)
          if (p.node_id == fe->node_id) part = &p;
        if (!part) {
          f.nodes.emplace_back();
          part = &f.nodes.back();
          part->node_id = fe->node_id;
        }
        vc_features v{};
        v.camera = fe->camera;
        v.feature_count = static_cast<uint16_t>(std::min<size_t>(fe->features.size(), VC_PROTO_MAX_FEATURES));
        for (size_t i = 0; i < v.feature_count; i++)
          v.features[i] = {fe->features[i].id, fe->features[i].state, fe->features[i].u, fe->features[i].v,
                           fe->features[i].confidence};
        part->features.push_back(v);
      } else if (auto* f3 = std::get_if<record::Features3DRecord>(&rec); f3 && f3->seq == f.seq) {
        f.triangulated = true;
        for (const auto& p : f3->features) f.features3d.push_back(record::feature3d_from_record(p));
      } else if (auto* po = std::get_if<record::PoseRecord>(&rec); po && po->seq == f.seq) {
        std::string why;
        pipeline::Pose pose;
        if (record::from_record(*po, &pose, &why)) f.pose = pose;
      }
    }
    flush();
  }

  void run() {
    try {
      load();
    } catch (const std::exception& e) {
      loaded_ = true;
      state(e.what());
      return;
    }
    loaded_ = true;
    std::unique_lock<std::mutex> lock(mu_);
    playing_ = !frames_.empty();
    pending_ = 0;
    uint64_t last_sent_ns = 0;
    while (!quit_) {
      if (frames_.empty()) {
        lock.unlock();
        state("the session has no frames");
        lock.lock();
        cv_.wait(lock, [&] { return quit_; });
        break;
      }
      if (pending_ >= 0) {
        index_ = size_t(pending_);
        pending_ = -1;
      } else if (playing_) {
        if (index_ + 1 >= frames_.size()) {
          playing_ = false;
        } else {
          // Wait the recorded time to the next frame, skipping frames to stay at most ~30 per second.
          const uint64_t dt = frames_[index_ + 1].t_trigger_ns - frames_[index_].t_trigger_ns;
          const auto wait = std::chrono::nanoseconds(std::clamp<uint64_t>(dt, 1'000'000, 200'000'000));
          if (cv_.wait_for(lock, wait, [&] { return quit_ || pending_ >= 0 || !playing_; })) continue;
          index_++;
          const uint64_t now = monotonic_ns();
          if (now - last_sent_ns < 33'000'000 && index_ + 1 < frames_.size()) continue;
        }
      } else {
        cv_.wait(lock, [&] { return quit_ || pending_ >= 0 || playing_; });
        continue;
      }
      const Encoded& e = frames_[index_];
      last_sent_ns = monotonic_ns();
      lock.unlock();
      for (const auto& m : e.msgs) server_.send(client_, m, true, true);
      state();
      lock.lock();
    }
  }

  Server& server_;
  ClientId client_;
  std::filesystem::path dir_;
  const config::RigConfig* rig_;
  std::string name_;
  std::thread thread_;
  std::mutex mu_, state_mu_;
  std::condition_variable cv_;
  bool quit_ = false, playing_ = false;
  std::atomic<bool> loaded_{false};
  int64_t pending_ = -1;
  size_t index_ = 0;
  std::vector<Encoded> frames_;
};

// ---- Viewer ----

Viewer::Viewer(ViewerOptions options) : opt_(std::move(options)) {
  ServerOptions so = opt_.limits;
  so.bind = opt_.server.bind;
  so.port = opt_.server.port;
  so.assets = opt_.server.assets.empty() ? default_assets_dir() : opt_.server.assets;
  Server::Hooks hooks;
  hooks.hello = [this](ClientId c, Channel ch) { return ch == Channel::Live ? hello(c) : std::string(); };
  hooks.control = [this](ClientId c, std::string_view text) { on_control(c, text); };
  hooks.closed = [this](ClientId c) { on_closed(c); };
  hooks.tick = [this] { on_tick(); };
  server_ = std::make_unique<Server>(std::move(so), std::move(hooks));
}

Viewer::~Viewer() {
  stop();
}

void Viewer::attach(pipeline::Pipeline& p) {
  if (opt_.record_switch)
    record_ =
        &p.tap(std::make_unique<RecordSwitch>(opt_.record_dir, opt_.record_at_start), RecordSwitch::kQueue);
  stage_ =
      &p.tap(std::make_unique<ViewStage>(*server_, opt_.max_hz,
                                         [this](const config::RigConfig* rig) {
                                           rig_ = rig;
                                           if (rig)
                                             server_->broadcast_always(std::make_shared<const std::string>(
                                                 encode_json(MsgType::Hello, hello_json(*rig, "live"))));
                                         }),
             ViewStage::kQueue);
}

void Viewer::serve_session(SessionSource source) {
  session_ = std::make_unique<SessionSource>(std::move(source));
  rig_ = &session_->rig;
}

std::string Viewer::hello(ClientId client) {
  const config::RigConfig* rig = rig_.load();
  if (!rig) return {};
  if (!session_) return encode_json(MsgType::Hello, hello_json(*rig, "live"));
  // A session served alone: the page replays it from the start, without asking.
  json h = json::parse(hello_json(*rig, "session"));
  const std::string name = session_->dir.filename().string();
  h["session"] = name;
  start_replay(client, name, session_->dir);
  return encode_json(MsgType::Hello, h.dump());
}

std::filesystem::path Viewer::session_dir(const std::string& name) const {
  if (session_) return name == session_->dir.filename().string() ? session_->dir : std::filesystem::path();
  const auto sessions = list_sessions(opt_.record_dir);
  if (!valid_session_name(name) || std::find(sessions.begin(), sessions.end(), name) == sessions.end())
    return {};
  return opt_.record_dir / name;
}

void Viewer::start_replay(ClientId client, const std::string& name, const std::filesystem::path& dir) {
  std::lock_guard<std::mutex> lock(mu_);
  replays_.erase(client);
  server_->set_replaying(client, true);
  replays_[client] = std::make_unique<Replay>(*server_, client, dir, rig_.load(), name);
}

void Viewer::set_report(std::function<aggregator::Report()> fn) {
  std::lock_guard<std::mutex> lock(mu_);
  report_ = std::move(fn);
}

void Viewer::start() {
  if (opt_.server.assets.empty()) {
    const AssetSearch found = find_assets();
    if (found.dir.empty()) throw std::runtime_error(no_assets_message(found));
  }
  const std::filesystem::path assets = opt_.server.assets.empty() ? default_assets_dir() : opt_.server.assets;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(assets / "index.html", ec))
    throw std::runtime_error(
        fmt::format("viewer: no page in {} (build the voxcap_web target, or set rig.toml [viewer] assets)",
                    assets.string()));
  server_->start();
}

void Viewer::stop() {
  server_->stop();  // no hook runs after this
  std::lock_guard<std::mutex> lock(mu_);
  replays_.clear();
}

uint16_t Viewer::port() const {
  return server_->port();
}

std::string Viewer::url() const {
  return fmt::format("http://{}:{}/", opt_.server.bind == "any" ? "127.0.0.1" : opt_.server.bind, port());
}

ServerStats Viewer::server_stats() const {
  return server_->stats();
}

void Viewer::on_control(ClientId client, std::string_view text) {
  json j;
  try {
    j = json::parse(text);
  } catch (const std::exception&) {
    return;  // not JSON: ignored
  }
  if (!j.is_object() || !j.contains("cmd") || !j["cmd"].is_string()) return;
  const std::string cmd = j["cmd"].get<std::string>();
  auto integer = [&](const char* k, int64_t dflt) {
    return j.contains(k) && j[k].is_number_integer() ? j[k].get<int64_t>() : dflt;
  };
  auto reply = [&](const json& r) {
    server_->send(client, std::make_shared<const std::string>(encode_json(MsgType::Stats, r.dump())), true,
                  false);
  };
  if (cmd == "record") {
    if (!record_ || !j.contains("on") || !j["on"].is_boolean()) return;
    record_->request(j["on"].get<bool>());
  } else if (cmd == "replay") {
    if (!j.contains("session") || !j["session"].is_string()) return;
    const std::string name = j["session"].get<std::string>();
    const std::filesystem::path dir = session_dir(name);
    if (dir.empty()) return reply({{"error", "no such session"}});
    start_replay(client, name, dir);
  } else if (cmd == "live") {
    if (session_) return reply({{"error", "no live rig: this viewer serves one recorded session"}});
    std::lock_guard<std::mutex> lock(mu_);
    replays_.erase(client);
    server_->set_replaying(client, false);
    server_->send(client,
                  std::make_shared<const std::string>(encode_json(MsgType::Replay, R"({"live":true})")), true,
                  false);
  } else if (cmd == "play" || cmd == "pause" || cmd == "step" || cmd == "seek") {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = replays_.find(client);
    if (it != replays_.end())
      it->second->command(cmd, cmd == "step" ? integer("by", 1) : integer("index", 0));
  }
}

void Viewer::on_closed(ClientId client) {
  std::lock_guard<std::mutex> lock(mu_);
  replays_.erase(client);
}

std::string Viewer::stats_json() {
  json j;
  std::function<aggregator::Report()> fn;
  {
    std::lock_guard<std::mutex> lock(mu_);
    fn = report_;
  }
  if (fn) {
    const aggregator::Report r = fn();
    const uint64_t now = monotonic_ns();
    j["frames"] = r.frames;
    j["complete"] = r.complete;
    j["degraded"] = r.degraded;
    j["dropped"] = r.dropped;
    j["fps"] = r.fps;
    j["running"] = r.running;
    j["rate_hz"] = r.rate_hz;
    j["trigger_to_merged_ms"] = {{"p50", r.merged.percentile_ms(0.5)}, {"p99", r.merged.percentile_ms(0.99)}};
    json nodes = json::array();
    for (const aggregator::NodeReport& n : r.nodes) {
      auto& last = last_hulls_[n.id];
      if (last.second && now > last.second)
        node_fps_[n.id] = double(n.hulls - std::min(n.hulls, last.first)) * 1e9 / double(now - last.second);
      last = {n.hulls, now};
      nodes.push_back(
          {{"id", n.id},
           {"name", n.name},
           {"connected", n.connected},
           {"state", vc_node_state_name(n.state) ? vc_node_state_name(n.state) : "?"},
           {"fps", node_fps_[n.id]},
           {"hulls", n.hulls},
           {"late", n.late},
           {"missing", n.missing},
           {"drops", n.edge_queue_drops + n.host_queue_drops + n.edge_pulses_without_frame},
           {"trigger_to_hull_ms", n.edge_frame_ms},
           {"trigger_to_host_ms", {{"p50", n.rx.percentile_ms(0.5)}, {"p99", n.rx.percentile_ms(0.99)}}},
           {"edge_stage_ms", n.edge_stage_ms},
           {"last_error", n.last_error}});
    }
    j["nodes"] = nodes;
    json stages = json::array();
    for (const pipeline::StageReport& s : r.pipeline.stages)
      stages.push_back({{"name", s.name},
                        {"mean_ms", s.busy_ms_mean},
                        {"max_ms", s.busy_ms_max},
                        {"queue", s.queue.depth},
                        {"capacity", s.queue.capacity},
                        {"dropped", s.queue.dropped},
                        {"processed", s.processed},
                        {"errors", s.errors}});
    j["stages"] = stages;
  }
  if (record_) {
    const RecordSwitch::State st = record_->state();
    j["recording"] = {
        {"on", st.on}, {"dir", st.dir.filename().string()}, {"records", st.records}, {"error", st.error}};
  }
  j["sessions"] = session_ ? std::vector<std::string>{session_->dir.filename().string()}
                           : list_sessions(opt_.record_dir, 50);
  const ServerStats ss = server_->stats();
  j["viewer"] = {{"clients", ss.clients},
                 {"dropped", ss.messages_dropped},
                 {"sent", ss.messages_sent},
                 {"frames_sent", stage_ ? stage_->frames_sent() : 0},
                 {"frames_skipped", stage_ ? stage_->frames_skipped() : 0}};
  json per_client = json::array();
  for (const ClientStats& c : ss.per_client)
    per_client.push_back({{"id", c.id},
                          {"path", c.channel == Channel::Live ? "/ws" : "/pose.json"},
                          {"port", c.peer_port},
                          {"sent", c.sent},
                          {"dropped", c.dropped},
                          {"queued_bytes", c.queued_bytes}});
  j["viewer"]["per_client"] = std::move(per_client);
  return j.dump();
}

void Viewer::on_tick() {
  server_->broadcast_always(std::make_shared<const std::string>(encode_json(MsgType::Stats, stats_json())));
}

}  // namespace vc::view
