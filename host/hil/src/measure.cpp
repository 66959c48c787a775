// The hardware-in-loop figures from timestamp streams (measure.hpp): pairing, percentiles, verdicts.
#include "voxcap/hil/measure.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include <fmt/format.h>

namespace vc::hil {
namespace {

bool by_time(const Stamp& a, const Stamp& b) {
  return a.t_ns < b.t_ns || (a.t_ns == b.t_ns && a.seq < b.seq);
}

double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  return v[mid];
}

// Index of the stamp in `sorted` whose time is closest to t (sorted non-empty).
size_t nearest(const std::vector<Stamp>& sorted, double t) {
  auto it = std::lower_bound(sorted.begin(), sorted.end(), t,
                             [](const Stamp& s, double v) { return static_cast<double>(s.t_ns) < v; });
  if (it == sorted.end()) return sorted.size() - 1;
  const size_t i = static_cast<size_t>(it - sorted.begin());
  if (i == 0) return 0;
  return std::fabs(static_cast<double>(sorted[i].t_ns) - t) <
                 std::fabs(static_cast<double>(sorted[i - 1].t_ns) - t)
             ? i
             : i - 1;
}

bool tolerance_ok(double tolerance, std::string* why) {
  if (!(tolerance > 0 && tolerance < 0.5)) {
    if (why) *why = fmt::format("tolerance: must be in (0, 0.5) of a period, got {}", tolerance);
    return false;
  }
  return true;
}

bool rate_ok(double rate_hz, std::string* why) {
  if (!(rate_hz > 0 && rate_hz <= 100000)) {
    if (why) *why = fmt::format("rate_hz: must be in (0, 100000], got {}", rate_hz);
    return false;
  }
  return true;
}

}  // namespace

Percentiles percentiles(std::vector<double> values) {
  Percentiles p;
  values.erase(std::remove_if(values.begin(), values.end(), [](double v) { return !std::isfinite(v); }),
               values.end());
  p.n = values.size();
  if (values.empty()) return p;
  std::sort(values.begin(), values.end());
  // Nearest rank: the smallest value with at least q of the sample at or below it.
  auto rank = [&](double q) {
    const double r = std::ceil(q * static_cast<double>(values.size()));
    const size_t i = r < 1 ? 0 : static_cast<size_t>(r) - 1;
    return values[std::min(i, values.size() - 1)];
  };
  p.min = values.front();
  p.p50 = rank(0.50);
  p.p95 = rank(0.95);
  p.p99 = rank(0.99);
  p.max = values.back();
  return p;
}

bool TrainOptions::valid(std::string* why) const {
  if (!rate_ok(rate_hz, why) || !tolerance_ok(tolerance, why)) return false;
  if (seq_bits != 32 && seq_bits != 64) {
    if (why) *why = fmt::format("seq_bits: must be 32 or 64, got {}", seq_bits);
    return false;
  }
  return true;
}

TrainResult match_train(std::vector<Stamp> sent, std::vector<Stamp> seen, const TrainOptions& options) {
  TrainResult r;
  std::string why;
  if (!options.valid(&why)) throw std::invalid_argument("hil::match_train: " + why);
  std::sort(sent.begin(), sent.end(), by_time);
  std::sort(seen.begin(), seen.end(), by_time);
  r.sent = sent.size();
  r.seen = seen.size();
  const double period = options.period_ns();
  const double window = options.tolerance * period;

  // The input's own counter: a step of more than one is pulses it knows it lost. Modulo 2^seq_bits, so
  // a 32-bit counter wrapping from 0xffffffff to 0 is a step of one.
  const uint64_t mask = options.seq_bits == 64 ? ~uint64_t{0} : (uint64_t{1} << options.seq_bits) - 1;
  for (size_t j = 1; j < seen.size(); ++j) {
    const uint64_t step = (seen[j].seq - seen[j - 1].seq) & mask;
    if (step > 1 && step < (mask >> 1)) r.seq_gaps += step - 1;
  }

  // The offset between where the output says it pulsed and where the input saw it: the median of each
  // seen edge's distance to its nearest pulse (glitches and missed pulses do not move a median).
  double offset = 0;
  if (!sent.empty() && !seen.empty()) {
    std::vector<double> d;
    d.reserve(seen.size());
    for (const Stamp& e : seen) {
      const double t = static_cast<double>(e.t_ns);
      d.push_back(t - static_cast<double>(sent[nearest(sent, t)].t_ns));
    }
    offset = median(std::move(d));
    r.offset_us = offset / 1e3;
  }

  const int64_t t0 = sent.empty() ? (seen.empty() ? 0 : seen.front().t_ns) : sent.front().t_ns;
  auto note_extra = [&](const Stamp& e) {
    ++r.extra;
    if (r.extra_at_us.size() < TrainResult::kMaxListed) r.extra_at_us.push_back((e.t_ns - t0) / 1000);
  };
  auto note_missed = [&](const Stamp& s) {
    ++r.missed;
    if (r.missed_seqs.size() < TrainResult::kMaxListed) r.missed_seqs.push_back(s.seq);
  };

  std::vector<double> spread;
  std::vector<int64_t> matched_t;
  size_t j = 0;
  for (const Stamp& s : sent) {
    const double expect = static_cast<double>(s.t_ns) + offset;
    // Edges before this pulse's window belong to no pulse.
    while (j < seen.size() && static_cast<double>(seen[j].t_ns) < expect - window) note_extra(seen[j++]);
    // The closest edge inside the window is the pulse's; any other edge in the window is extra.
    size_t best = seen.size();
    double best_d = 0;
    size_t k = j;
    for (; k < seen.size() && static_cast<double>(seen[k].t_ns) <= expect + window; ++k) {
      const double dist = std::fabs(static_cast<double>(seen[k].t_ns) - expect);
      if (best == seen.size() || dist < best_d) {
        best = k;
        best_d = dist;
      }
    }
    if (best == seen.size()) {
      note_missed(s);
      continue;
    }
    for (size_t m = j; m < k; ++m)
      if (m != best) note_extra(seen[m]);
    j = k;
    ++r.matched;
    spread.push_back(best_d / 1e3);
    matched_t.push_back(seen[best].t_ns);
  }
  while (j < seen.size()) note_extra(seen[j++]);

  std::vector<double> jitter;
  for (size_t i = 1; i < matched_t.size(); ++i) {
    const double interval = static_cast<double>(matched_t[i] - matched_t[i - 1]);
    const double k = std::max(1.0, std::round(interval / period));
    jitter.push_back(std::fabs(interval - k * period) / 1e3);
  }
  if (matched_t.size() >= 2 && sent.size() >= 2) {
    // Mean period over the whole span, in the slots the pulses' own times say they spanned.
    const double slots =
        std::max(1.0, std::round(static_cast<double>(matched_t.back() - matched_t.front()) / period));
    r.period_us = static_cast<double>(matched_t.back() - matched_t.front()) / slots / 1e3;
  }
  r.jitter_us = percentiles(std::move(jitter));
  r.spread_us = percentiles(std::move(spread));
  return r;
}

bool AlignOptions::valid(std::string* why) const {
  if (!rate_ok(rate_hz, why) || !tolerance_ok(tolerance, why)) return false;
  if (!std::isfinite(latency_us)) {
    if (why) *why = "latency_us: must be a finite number";
    return false;
  }
  if (cameras < 1 || cameras > 64) {
    if (why) *why = fmt::format("cameras: must be in [1, 64], got {}", cameras);
    return false;
  }
  return true;
}

AlignResult align_frames(std::vector<Stamp> pulses, std::vector<FrameStamp> frames,
                         const AlignOptions& options) {
  std::string why;
  if (!options.valid(&why)) throw std::invalid_argument("hil::align_frames: " + why);
  std::sort(pulses.begin(), pulses.end(), by_time);
  std::stable_sort(frames.begin(), frames.end(),
                   [](const FrameStamp& a, const FrameStamp& b) { return a.t_ns < b.t_ns; });
  for (const FrameStamp& f : frames)
    if (f.camera < 0 || f.camera >= options.cameras)
      throw std::invalid_argument(
          fmt::format("hil::align_frames: frame of camera {} (cameras: {})", f.camera, options.cameras));
  AlignResult r;
  r.pulses = pulses.size();
  const double period = 1e9 / options.rate_hz;
  const double window = options.tolerance * period;
  const double latency_ns = options.latency_us * 1e3;
  for (int c = 0; c < options.cameras; ++c) {
    CameraAlignment a;
    a.camera = c;
    std::vector<bool> taken(pulses.size(), false);
    std::vector<double> offsets;
    size_t first = pulses.size(), last = 0;
    for (const FrameStamp& f : frames) {
      if (f.camera != c) continue;
      ++a.frames;
      const double t = static_cast<double>(f.t_ns);
      if (pulses.empty()) {
        ++a.unpaired;
        continue;
      }
      const size_t i = nearest(pulses, t - latency_ns);
      const double off = t - static_cast<double>(pulses[i].t_ns);
      if (std::fabs(off - latency_ns) > window) {
        ++a.unpaired;
        continue;
      }
      if (taken[i]) {
        ++a.unpaired;
        ++a.duplicate;
        continue;
      }
      taken[i] = true;
      ++a.paired;
      offsets.push_back(off / 1e3);
      first = std::min(first, i);
      last = std::max(last, i);
    }
    if (a.paired > 0)
      for (size_t i = first; i <= last; ++i)
        if (!taken[i]) ++a.pulses_without_frame;
    a.offset_us = percentiles(std::move(offsets));
    r.cameras.push_back(a);
  }
  return r;
}

const char* to_string(Status status) {
  switch (status) {
    case Status::Pass:
      return "PASS";
    case Status::Fail:
      return "FAIL";
    case Status::Skip:
      return "SKIPPED";
  }
  return "?";
}

Verdict judge_train(const TrainResult& r, uint64_t expected, double max_jitter_us) {
  std::vector<std::string> wrong;
  if (r.sent != expected) wrong.push_back(fmt::format("{} of {} pulses sent", r.sent, expected));
  if (r.missed > 0) {
    std::string seqs;
    for (uint64_t s : r.missed_seqs) seqs += (seqs.empty() ? "" : ", ") + std::to_string(s);
    wrong.push_back(
        fmt::format("{} missed (seq {}{})", r.missed, seqs, r.missed > r.missed_seqs.size() ? ", ..." : ""));
  }
  if (r.extra > 0)
    wrong.push_back(fmt::format("{} extra edges (glitches or a second edge per pulse)", r.extra));
  if (r.seq_gaps > 0)
    wrong.push_back(fmt::format("the input's counter skipped {} (its event queue overflowed)", r.seq_gaps));
  if (max_jitter_us > 0 && r.jitter_us.n > 0 && r.jitter_us.max > max_jitter_us)
    wrong.push_back(
        fmt::format("jitter max {:.1f} us over the limit {:.1f} us", r.jitter_us.max, max_jitter_us));
  if (expected > 0 && r.seen == 0)
    wrong.insert(wrong.begin(), "no edge seen: is the output wired to the input?");
  if (wrong.empty())
    return {Status::Pass, fmt::format("{} of {} pulses seen, 0 missed, 0 extra", r.matched, expected)};
  std::string reason;
  for (const std::string& w : wrong) reason += (reason.empty() ? "" : "; ") + w;
  return {Status::Fail, reason};
}

Verdict judge_alignment(const AlignResult& r, const AlignOptions& options, double max_offset_us) {
  std::vector<std::string> wrong;
  uint64_t paired = 0, frames = 0;
  if (r.pulses == 0) wrong.push_back("no pulse seen on the input line");
  for (const CameraAlignment& c : r.cameras) {
    paired += c.paired;
    frames += c.frames;
    if (c.frames == 0) {
      wrong.push_back(
          fmt::format("camera {}: no frame (is its trigger input wired and external trigger on?)", c.camera));
      continue;
    }
    if (c.unpaired > 0)
      wrong.push_back(
          fmt::format("camera {}: {} of {} frames without a pulse{}", c.camera, c.unpaired, c.frames,
                      c.duplicate ? fmt::format(" ({} a second frame on one pulse)", c.duplicate) : ""));
    if (c.pulses_without_frame > 0)
      wrong.push_back(fmt::format("camera {}: {} pulses without a frame", c.camera, c.pulses_without_frame));
    if (max_offset_us > 0 && c.offset_us.n > 0 &&
        std::max(std::fabs(c.offset_us.max - options.latency_us),
                 std::fabs(c.offset_us.min - options.latency_us)) > max_offset_us)
      wrong.push_back(fmt::format(
          "camera {}: offset {:.1f}..{:.1f} us strays more than {:.1f} us from the latency {:.1f} us",
          c.camera, c.offset_us.min, c.offset_us.max, max_offset_us, options.latency_us));
  }
  if (wrong.empty())
    return {Status::Pass, fmt::format("{} of {} frames paired with their pulse on {} camera(s)", paired,
                                      frames, r.cameras.size())};
  std::string reason;
  for (const std::string& w : wrong) reason += (reason.empty() ? "" : "; ") + w;
  return {Status::Fail, reason};
}

Verdict judge_smoke(const SmokeFigures& f) {
  std::vector<std::string> wrong;
  if (f.nodes_connected < f.nodes) {
    std::string ids;
    for (const std::string& id : f.nodes_missing) ids += (ids.empty() ? "" : ", ") + id;
    wrong.push_back(fmt::format("{} of {} nodes connected (missing: {})", f.nodes_connected, f.nodes, ids));
  }
  if (!f.running) wrong.push_back("the run never started (not every node became READY)");
  if (f.frames == 0) wrong.push_back("no frame merged");
  if (f.merging_stopped) wrong.push_back("frames stopped merging");
  if (wrong.empty())
    return {Status::Pass,
            fmt::format("{} nodes connected, {} frames merged ({} complete)", f.nodes, f.frames, f.complete)};
  std::string reason;
  for (const std::string& w : wrong) reason += (reason.empty() ? "" : "; ") + w;
  return {Status::Fail, reason};
}

}  // namespace vc::hil
