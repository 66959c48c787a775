#include "voxcap/pipeline/timing.hpp"

#include <algorithm>
#include <cmath>

namespace vc::pipeline {

namespace {
double ms_after(uint64_t t_ns, uint64_t t0_ns) {
  return t_ns >= t0_ns ? static_cast<double>(t_ns - t0_ns) / 1e6 : -static_cast<double>(t0_ns - t_ns) / 1e6;
}
}  // namespace

bool frame_timing(const Frame& f, size_t chain_stages, FrameTiming* out) {
  if (f.t_trigger_ns == 0 || f.t_assembled_ns == 0 || chain_stages > Frame::kTimedStages) return false;
  FrameTiming t;
  t.seq = f.seq;
  t.degraded = f.degraded;
  t.missing = f.missing;
  double first = 0, last = 0;
  for (const NodePart& p : f.nodes) {
    if (!p.has_hull || p.t_received_ns == 0) continue;
    const double ms = ms_after(p.t_received_ns, f.t_trigger_ns);
    first = t.hull_ms.empty() ? ms : std::min(first, ms);
    last = t.hull_ms.empty() ? ms : std::max(last, ms);
    t.hull_ms.emplace_back(p.node_id, ms);
  }
  if (t.hull_ms.empty()) return false;
  t.assembled_ms = ms_after(f.t_assembled_ns, f.t_trigger_ns);
  t.segments_ms = {first, last - first, t.assembled_ms - last};
  double prev = t.assembled_ms;
  for (size_t i = 0; i < chain_stages; i++) {
    if (f.t_stage_start_ns[i] == 0 || f.t_stage_end_ns[i] < f.t_stage_start_ns[i]) return false;
    const double start = ms_after(f.t_stage_start_ns[i], f.t_trigger_ns);
    const double end = ms_after(f.t_stage_end_ns[i], f.t_trigger_ns);
    t.stage_ms.emplace_back(start, end);
    t.segments_ms.push_back(start - prev);
    t.segments_ms.push_back(end - start);
    prev = end;
  }
  t.total_ms = prev;
  for (double s : t.segments_ms)
    if (!std::isfinite(s) || s < 0) return false;  // a stamp out of order: not a path to split
  *out = std::move(t);
  return true;
}

std::vector<std::string> timing_segments(const std::vector<std::string>& chain) {
  std::vector<std::string> s = {"edges", "last_node", "assembly"};
  for (const std::string& c : chain) {
    s.push_back(c + "_queue");
    s.push_back(c);
  }
  return s;
}

bool TimingLog::add(const Frame& f) {
  if (rows_.size() >= max_rows_) return false;
  FrameTiming t;
  if (!frame_timing(f, std::min(chain_.size(), Frame::kTimedStages), &t)) return false;
  rows_.push_back(std::move(t));
  return true;
}

LatencySplit TimingLog::split() const {
  LatencySplit s;
  s.segments = timing_segments(std::vector<std::string>(
      chain_.begin(),
      chain_.begin() + static_cast<std::ptrdiff_t>(std::min(chain_.size(), Frame::kTimedStages))));
  s.mean_ms.assign(s.segments.size(), 0);
  s.tail_mean_ms.assign(s.segments.size(), 0);
  s.frames = rows_.size();
  if (rows_.empty()) return s;
  // The tail: the slowest 1% of the frames (at least one), slowest first (ties in frame order).
  std::vector<size_t> order(rows_.size());
  for (size_t i = 0; i < order.size(); i++) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return rows_[a].total_ms > rows_[b].total_ms; });
  const size_t tail_n = std::max<size_t>(1, rows_.size() / 100);
  std::vector<bool> tail(rows_.size(), false);
  for (size_t k = 0; k < tail_n; k++) tail[order[k]] = true;
  s.tail_from_ms = rows_[order[tail_n - 1]].total_ms;
  for (size_t k = 0; k < rows_.size(); k++) {
    const FrameTiming& r = rows_[k];
    s.tail_frames += tail[k] ? 1 : 0;
    s.tail_degraded += tail[k] && r.degraded ? 1 : 0;
    for (size_t i = 0; i < s.segments.size() && i < r.segments_ms.size(); i++) {
      s.mean_ms[i] += r.segments_ms[i];
      if (tail[k]) s.tail_mean_ms[i] += r.segments_ms[i];
    }
  }
  for (size_t i = 0; i < s.segments.size(); i++) {
    s.mean_ms[i] /= static_cast<double>(s.frames);
    s.tail_mean_ms[i] /= static_cast<double>(s.tail_frames);
  }
  return s;
}

}  // namespace vc::pipeline
