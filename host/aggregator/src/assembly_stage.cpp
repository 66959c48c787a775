#include "voxcap/aggregator/assembly_stage.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <chrono>

#include "voxcap/base/clock.hpp"

namespace vc::aggregator {

namespace {
assemble::AssemblerOptions unmerged(assemble::AssemblerOptions o) {
  o.merge = false;  // the pipeline's merge stage does it, on its own thread
  return o;
}
}  // namespace

AssemblyStage::AssemblyStage(assemble::AssemblerOptions assembler, AssemblyOptions options,
                             pipeline::Pipeline& out, log::Fn log)
    : out_(out),
      opt_(options),
      log_(log::or_spdlog(std::move(log), "voxcap-host")),
      inbox_(options.queue, pipeline::Overflow::DropNewest),
      assembler_(unmerged(std::move(assembler))),
      pulse_ring_(assembler_.options().max_pending) {
  pulse_batch_.reserve(pulse_ring_.size());
}

AssemblyStage::~AssemblyStage() {
  stop();
}

void AssemblyStage::start() {
  if (started_) return;
  started_ = true;
  thread_ = std::thread([this] { run(); });
}

void AssemblyStage::stop() {
  if (stopped_) return;
  stopped_ = true;
  inbox_.close();
  if (thread_.joinable()) thread_.join();
}

size_t AssemblyStage::bytes_of(const Input& in) {
  if (const auto* h = std::get_if<assemble::PartialHull>(&in)) return sizeof(*h) + h->rle.size();
  if (const auto* s = std::get_if<SilhouetteIn>(&in)) return sizeof(*s) + s->silhouette.rle.size();
  if (const auto* f = std::get_if<Features>(&in)) return sizeof(*f);
  if (const auto* st = std::get_if<Stats>(&in)) return sizeof(*st);
  return 0;
}

bool AssemblyStage::post(uint16_t node_id, Input in) {
  const size_t bytes = bytes_of(in);
  bool over = false;
  {
    std::lock_guard<std::mutex> g(mu_);
    size_t& q = queued_bytes_[node_id];
    over = q + bytes > opt_.max_node_bytes;
    if (over)
      drops_[node_id]++;  // over its share: the other nodes' messages still get in
    else
      q += bytes;
  }
  if (over) {
    note_drop("a node over its share of the queue's bytes");
    return false;
  }
  if (inbox_.push(std::move(in))) return true;
  {
    std::lock_guard<std::mutex> g(mu_);
    queued_bytes_[node_id] -= bytes;
    if (!inbox_.closed_and_empty()) drops_[node_id]++;
  }
  if (inbox_.closed_and_empty()) return false;
  note_drop("queue full");
  return false;
}

void AssemblyStage::note_drop(const char* why) {
  // Dropped: the stages are behind by a whole queue, or one node sends more than its share. Counted
  // per node; a line at most every 5 s.
  uint64_t now = vc::monotonic_ns(), total = 0, since = 0;
  bool say = false;
  {
    std::lock_guard<std::mutex> g(mu_);
    for (const auto& [n, d] : drops_) total += d;
    if (last_drop_log_ns_ == 0 || now - last_drop_log_ns_ >= 5'000'000'000u) {
      say = true;
      last_drop_log_ns_ = now;
      since = total - drops_logged_;
      drops_logged_ = total;
    }
  }
  if (say)
    log_(log::Level::warn,
         fmt::format(
             "assemble: {} ({} messages, {} bytes a node): dropping what the nodes send ({} dropped so "
             "far, {} since the last such line)",
             why, opt_.queue, opt_.max_node_bytes, total, since));
}

bool AssemblyStage::post_hull(assemble::PartialHull hull) {
  uint16_t node = hull.node_id;
  return post(node, std::move(hull));
}

bool AssemblyStage::post_features(uint16_t node_id, uint64_t seq, uint64_t t_trigger_ns,
                                  const vc_features& f) {
  return post(node_id, Features{node_id, seq, t_trigger_ns, f});
}

bool AssemblyStage::post_stats(uint16_t node_id, const vc_stats& s) {
  return post(node_id, Stats{node_id, s});
}

bool AssemblyStage::post_silhouette(uint16_t node_id, uint64_t seq, uint64_t t_trigger_ns,
                                    pipeline::Silhouette silhouette) {
  return post(node_id, SilhouetteIn{node_id, seq, t_trigger_ns, std::move(silhouette)});
}

void AssemblyStage::set_running(uint16_t node_id, bool running) {
  inbox_.push_always(Running{node_id, running});
}

void AssemblyStage::post_pulse(uint64_t seq, uint64_t t_ns) {
  std::lock_guard<std::mutex> g(pulse_mu_);
  if (pulse_count_ == pulse_ring_.size()) {  // full: the oldest note goes (see the header)
    pulse_head_ = (pulse_head_ + 1) % pulse_ring_.size();
    pulse_count_--;
    pulse_overwritten_++;
  }
  pulse_ring_[(pulse_head_ + pulse_count_) % pulse_ring_.size()] = Pulse{seq, t_ns};
  pulse_count_++;
}

void AssemblyStage::take_pulses() {
  pulse_batch_.clear();
  {
    std::lock_guard<std::mutex> g(pulse_mu_);
    for (size_t k = 0; k < pulse_count_; k++)
      pulse_batch_.push_back(pulse_ring_[(pulse_head_ + k) % pulse_ring_.size()]);
    pulse_head_ = pulse_count_ = 0;
  }
  for (const Pulse& p : pulse_batch_) assembler_.pulse(p.seq, p.t_ns);
}

size_t AssemblyStage::pulse_notes_waiting() const {
  std::lock_guard<std::mutex> g(pulse_mu_);
  return pulse_count_;
}

uint64_t AssemblyStage::pulse_notes_overwritten() const {
  std::lock_guard<std::mutex> g(pulse_mu_);
  return pulse_overwritten_;
}

void AssemblyStage::forward(std::vector<assemble::MergedFrame>& frames) {
  for (auto& f : frames) out_.push(std::make_shared<pipeline::Frame>(std::move(f)));
  frames.clear();
}

void AssemblyStage::run() {
  using Clock = std::chrono::steady_clock;
  const auto poll = std::chrono::milliseconds(opt_.poll_ms);
  const uint64_t poll_ns = static_cast<uint64_t>(opt_.poll_ms) * 1'000'000u;
  uint64_t last_poll = 0;
  std::vector<assemble::MergedFrame> out;
  uint64_t next_deadline = 0;  // the earliest pending frame's (0: none pending)
  for (;;) {
    // Wait for the next message, or until the earliest pending frame's deadline (at most poll_ms: a
    // pulse note can still move a deadline earlier): a deadline is met when it passes, not at the
    // next tick of a fixed poll.
    std::chrono::nanoseconds wait = poll;
    if (next_deadline != 0) {
      const uint64_t t = vc::monotonic_ns();
      wait = std::min<std::chrono::nanoseconds>(
          poll, std::chrono::nanoseconds(next_deadline > t ? next_deadline - t : 0));
    }
    std::optional<Input> in = inbox_.pop_for(wait);
    auto t0 = Clock::now();
    uint64_t now = vc::monotonic_ns();
    {
      std::lock_guard<std::mutex> g(mu_);
      take_pulses();  // every pulse noted before this message was taken is known before it
      if (in) {
        if (const size_t bytes = bytes_of(*in)) {
          const uint16_t node = std::visit(
              [](const auto& x) -> uint16_t {
                if constexpr (requires { x.node_id; }) return x.node_id;
                return 0;
              },
              *in);
          queued_bytes_[node] -= bytes;
        }
        if (auto* h = std::get_if<assemble::PartialHull>(&*in)) {
          assembler_.add(std::move(*h), now, out);
        } else if (auto* f = std::get_if<Features>(&*in)) {
          assembler_.add_features(f->node_id, f->seq, f->t_trigger_ns, f->features, now, out);
        } else if (auto* s = std::get_if<Stats>(&*in)) {
          assembler_.add_stats(s->node_id, s->stats);
        } else if (auto* sil = std::get_if<SilhouetteIn>(&*in)) {
          assembler_.add_silhouette(sil->node_id, sil->seq, sil->t_trigger_ns, std::move(sil->silhouette),
                                    now, out);
        } else if (auto* r = std::get_if<Running>(&*in)) {
          assembler_.set_running(r->node_id, r->running);
        }
      }
      if (!in || now - last_poll >= poll_ns || (next_deadline != 0 && now >= next_deadline)) {
        assembler_.poll(now, out);
        last_poll = now;
      }
      next_deadline = assembler_.next_deadline_ns();
      if (in) {
        processed_++;
        double ns = std::chrono::duration<double, std::nano>(Clock::now() - t0).count();
        busy_ns_sum_ += ns;
        if (ns > busy_ns_max_) busy_ns_max_ = ns;
      }
    }
    forward(out);
    if (!in && inbox_.closed_and_empty()) break;
  }
  {
    std::lock_guard<std::mutex> g(mu_);
    take_pulses();
    assembler_.flush(vc::monotonic_ns(), out);
  }
  forward(out);
}

assemble::AssemblerStats AssemblyStage::stats() const {
  std::lock_guard<std::mutex> g(mu_);
  return assembler_.stats();
}

size_t AssemblyStage::pending() const {
  std::lock_guard<std::mutex> g(mu_);
  return assembler_.pending();
}

std::map<uint16_t, uint64_t> AssemblyStage::drops() const {
  std::lock_guard<std::mutex> g(mu_);
  return drops_;
}

pipeline::StageReport AssemblyStage::report() const {
  pipeline::StageReport r;
  r.name = "assemble";
  r.overflow = pipeline::Overflow::DropNewest;
  r.queue = inbox_.counters();
  std::lock_guard<std::mutex> g(mu_);
  r.processed = processed_;
  r.busy_ms_mean = processed_ ? busy_ns_sum_ / double(processed_) / 1e6 : 0;
  r.busy_ms_max = busy_ns_max_ / 1e6;
  return r;
}

}  // namespace vc::aggregator
