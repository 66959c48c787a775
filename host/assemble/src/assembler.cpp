#include "voxcap/assemble/assembler.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <stdexcept>

#include "voxcap/rle.h"

namespace vc::assemble {

bool AssemblerOptions::valid(std::string* why) const {
  auto fail = [&](std::string m) {
    if (why) *why = std::move(m);
    return false;
  };
  if (nodes.empty()) return fail("nodes: at least one node");
  std::vector<uint16_t> s = nodes;
  std::sort(s.begin(), s.end());
  if (std::adjacent_find(s.begin(), s.end()) != s.end()) return fail("nodes: duplicate node id");
  if (voxel_count == 0) return fail("voxel_count: must be > 0");
  if (deadline_ns == 0) return fail("deadline_ns: must be > 0");
  if (max_pending == 0) return fail("max_pending: must be > 0");
  if (max_stats_waiting == 0) return fail("max_stats_waiting: must be > 0");
  return true;
}

Assembler::Assembler(AssemblerOptions options) : opt_(std::move(options)) {
  std::string why;
  if (!opt_.valid(&why)) throw std::invalid_argument("assembler: " + why);
  for (uint16_t n : opt_.nodes) {
    running_[n] = true;
    stats_.nodes[n];
  }
  if (opt_.pulsed_only) pulse_times_.resize(opt_.max_pending);
}

void Assembler::pulse(uint64_t seq, uint64_t t_ns) {
  if (any_pulse_ && seq <= last_pulse_) return;
  any_pulse_ = true;
  last_pulse_ = seq;
  if (pulse_times_.empty()) return;
  pulse_times_[seq % pulse_times_.size()] = {seq, t_ns};
  // A frame that a message opened before its pulse's note arrived takes the host's time now.
  auto it = pending_.find(seq);
  if (it != pending_.end()) it->second.t_trigger_ns = t_ns;
}

bool Assembler::trusted(uint64_t seq, uint64_t& t_trigger_ns, NodeCounters& nc) const {
  if (!opt_.pulsed_only) return true;
  if (!any_pulse_ || (seq > last_pulse_ && seq - last_pulse_ > opt_.pulse_slack)) {
    nc.unpulsed++;
    return false;
  }
  const PulseTime& pt = pulse_times_[seq % pulse_times_.size()];
  // Not (or no longer) known: an old seq is late anyway; one just ahead waits from its own stamp,
  // at most the last pulse's time (a stamp from the future would hold the frame back).
  if (pt.seq == seq && pt.t_ns != 0) {
    t_trigger_ns = pt.t_ns;
  } else {
    const PulseTime& last = pulse_times_[last_pulse_ % pulse_times_.size()];
    if (last.seq == last_pulse_)
      t_trigger_ns = std::clamp(t_trigger_ns, last.t_ns, last.t_ns + 1'000'000'000u);
  }
  return true;
}

void Assembler::set_running(uint16_t node_id, bool running) {
  auto it = running_.find(node_id);
  if (it != running_.end()) it->second = running;
}

bool Assembler::complete(uint64_t seq, const Pending& p) const {
  for (const auto& [node, run] : running_) {
    if (!run) continue;
    auto it = p.parts.find(node);
    if (it != p.parts.end() && it->second.has_hull) continue;
    auto seen = seen_.find(node);
    if (seen != seen_.end() && seen->second > seq + 1) continue;  // it is past seq: no hull will come
    return false;
  }
  return true;
}

void Assembler::note_seen(uint16_t node_id, uint64_t seq) {
  uint64_t& s = seen_[node_id];
  if (seq + 1 > s) s = seq + 1;
}

void Assembler::resolve_ready(uint64_t now_ns, bool check_deadlines, std::vector<MergedFrame>& out) {
  for (auto it = pending_.begin(); it != pending_.end();) {
    if ((check_deadlines && it->second.t_trigger_ns + opt_.deadline_ns <= now_ns) ||
        complete(it->first, it->second)) {
      resolve(it->first, it->second, now_ns, out);
      it = pending_.erase(it);
    } else {
      ++it;
    }
  }
}

void intersect(const std::vector<const std::vector<uint8_t>*>& hulls, std::vector<uint8_t>& out,
               std::vector<uint8_t>& scratch) {
  if (hulls.empty()) throw std::runtime_error("intersect: no hulls");
  // One vc_rle_and_n pass over all hulls; beyond VC_RLE_AND_MAX_STREAMS (never in a real rig) the
  // result so far is one of the streams of the next pass.
  std::array<const uint8_t*, VC_RLE_AND_MAX_STREAMS> ptrs{};
  std::array<size_t, VC_RLE_AND_MAX_STREAMS> lens{};
  size_t next = 0;
  bool have_result = false;
  while (next < hulls.size()) {
    size_t n = 0, in_bytes = 0;
    if (have_result) {
      ptrs[n] = out.data();
      lens[n++] = out.size();
      in_bytes += out.size();
    }
    for (; n < ptrs.size() && next < hulls.size(); n++, next++) {
      ptrs[n] = hulls[next]->data();
      lens[n] = hulls[next]->size();
      in_bytes += lens[n];
    }
    // Every run of the AND ends where some input run ends, so in practice it is no longer than its
    // inputs together; should it be, vc_rle_and_n reports the size it needs and the second call fits.
    if (scratch.size() < in_bytes + 16) scratch.resize(in_bytes + 16);
    size_t len = 0;
    int rc = vc_rle_and_n(ptrs.data(), lens.data(), n, scratch.data(), scratch.size(), &len);
    if (rc == -ENOSPC) {
      scratch.resize(len);
      rc = vc_rle_and_n(ptrs.data(), lens.data(), n, scratch.data(), scratch.size(), &len);
    }
    if (rc < 0) throw std::runtime_error(fmt::format("intersect: vc_rle_and_n failed ({})", rc));
    out.assign(scratch.begin(), scratch.begin() + static_cast<std::ptrdiff_t>(len));
    have_result = true;
  }
}

void merge(pipeline::Frame& f, std::vector<uint8_t>& scratch, uint64_t now_ns) {
  std::vector<const std::vector<uint8_t>*> parts;
  for (const pipeline::NodePart& p : f.nodes)
    if (p.has_hull) parts.push_back(&p.rle);
  intersect(parts, f.rle, scratch);
  uint64_t occ = 0, total = 0;
  if (vc_rle_popcount(f.rle.data(), f.rle.size(), &occ, &total) < 0 || total != f.voxel_count)
    throw std::runtime_error("assembler: merged hull is inconsistent");
  f.occupied = occ;
  f.merged = true;
  f.t_merged_ns = now_ns;
}

void Assembler::resolve(uint64_t seq, Pending& p, uint64_t now_ns, std::vector<MergedFrame>& out) {
  if (!any_resolved_ || seq > max_resolved_) max_resolved_ = seq;
  any_resolved_ = true;
  MergedFrame f;
  f.seq = seq;
  for (uint16_t n : opt_.nodes) {
    auto it = p.parts.find(n);
    if (it != p.parts.end() && it->second.has_hull) {
      f.present.push_back(n);
    } else {
      f.missing.push_back(n);
      stats_.nodes[n].missing++;
    }
  }
  if (f.present.empty()) return;  // nobody sent a hull: nothing to merge or count
  if (!f.missing.empty() && opt_.policy == MissingPolicy::Drop) {
    stats_.dropped++;
    return;
  }
  f.degraded = !f.missing.empty();
  f.t_trigger_ns = p.t_trigger_ns;
  f.t_first_rx_ns = p.t_first_rx_ns;
  f.t_last_rx_ns = p.t_last_rx_ns;
  f.t_assembled_ns = now_ns;
  f.grid_id = opt_.grid_id;
  f.voxel_count = opt_.voxel_count;
  for (auto& [node, part] : p.parts) f.nodes.push_back(std::move(part));
  for (auto& [id, waiting] : stats_waiting_) {
    if (waiting.empty()) continue;
    const uint16_t node = id;
    auto it = std::find_if(f.nodes.begin(), f.nodes.end(),
                           [&](const pipeline::NodePart& x) { return x.node_id == node; });
    if (it == f.nodes.end()) {
      pipeline::NodePart part;
      part.node_id = node;
      it = f.nodes.insert(
          std::upper_bound(f.nodes.begin(), f.nodes.end(), node,
                           [](uint16_t n, const pipeline::NodePart& x) { return n < x.node_id; }),
          std::move(part));
    }
    it->stats = std::move(waiting);
    waiting.clear();
  }
  if (opt_.merge) merge(f, tmp_, now_ns);
  (f.degraded ? stats_.degraded : stats_.complete)++;
  out.push_back(std::move(f));
}

Assembler::Pending* Assembler::slot(uint64_t seq, uint64_t t_trigger_ns, uint64_t now_ns,
                                    std::vector<MergedFrame>& out, uint64_t& late) {
  auto it = pending_.find(seq);
  if (it != pending_.end()) return &it->second;
  if (any_resolved_ && seq <= max_resolved_) {
    late++;
    return nullptr;
  }
  while (pending_.size() >= opt_.max_pending) {
    auto oldest = pending_.begin();
    if (oldest->first > seq) {  // the new one is older than everything kept: it is the one to go
      late++;
      return nullptr;
    }
    stats_.evicted++;
    resolve(oldest->first, oldest->second, now_ns, out);
    pending_.erase(oldest);
  }
  Pending& p = pending_.emplace(seq, Pending{}).first->second;
  p.t_trigger_ns = t_trigger_ns;
  return &p;
}

bool Assembler::add(PartialHull h, uint64_t now_ns, std::vector<MergedFrame>& out) {
  auto node_it = stats_.nodes.find(h.node_id);
  if (node_it == stats_.nodes.end()) return false;  // not a configured node: the session rejects those
  NodeCounters& nc = node_it->second;
  if (h.grid_id != opt_.grid_id || h.voxel_count != opt_.voxel_count) {
    nc.rejected++;
    return false;
  }
  if (!trusted(h.seq, h.t_trigger_ns, nc)) return false;
  const bool fresh = !pending_.count(h.seq);
  Pending* p = slot(h.seq, h.t_trigger_ns, now_ns, out, nc.late);
  if (!p) return false;
  pipeline::NodePart& part = p->parts[h.node_id];
  if (part.has_hull) {
    nc.rejected++;
    return false;
  }
  if (fresh || p->t_first_rx_ns == 0) p->t_first_rx_ns = h.t_received_ns;
  p->t_last_rx_ns = std::max(p->t_last_rx_ns, h.t_received_ns);
  part.node_id = h.node_id;
  part.has_hull = true;
  part.t_received_ns = h.t_received_ns;
  part.occupied = h.occupied;
  part.rle = std::move(h.rle);
  nc.received++;
  note_seen(h.node_id, h.seq);
  // This hull may complete its frame and, being of a later seq than some pending frames, tell that
  // its node skipped them: those go first (frames leave in seq order).
  resolve_ready(now_ns, false, out);
  return true;
}

bool Assembler::add_features(uint16_t node_id, uint64_t seq, uint64_t t_trigger_ns,
                             const vc_features& features, uint64_t now_ns, std::vector<MergedFrame>& out) {
  auto node_it = stats_.nodes.find(node_id);
  if (node_it == stats_.nodes.end()) return false;
  NodeCounters& nc = node_it->second;
  if (features.camera >= VC_PROTO_MAX_CAMERAS) {
    nc.features_rejected++;
    return false;
  }
  if (!trusted(seq, t_trigger_ns, nc)) return false;
  Pending* p = slot(seq, t_trigger_ns, now_ns, out, nc.features_late);
  if (!p) return false;
  pipeline::NodePart& part = p->parts[node_id];
  part.node_id = node_id;
  for (const vc_features& f : part.features) {
    if (f.camera == features.camera) {  // one per camera and frame: a repeat cannot grow the frame
      nc.features_rejected++;           // nor count its camera twice in the triangulation
      return false;
    }
  }
  part.features.push_back(features);
  nc.features++;
  note_seen(node_id, seq);
  resolve_ready(now_ns, false, out);  // older frames this node skipped need not wait for it
  return true;
}

bool Assembler::add_silhouette(uint16_t node_id, uint64_t seq, uint64_t t_trigger_ns,
                               pipeline::Silhouette silhouette, uint64_t now_ns,
                               std::vector<MergedFrame>& out) {
  auto node_it = stats_.nodes.find(node_id);
  if (node_it == stats_.nodes.end()) return false;
  NodeCounters& nc = node_it->second;
  if (silhouette.camera >= VC_PROTO_MAX_CAMERAS) {
    nc.silhouettes_rejected++;
    return false;
  }
  if (!trusted(seq, t_trigger_ns, nc)) return false;
  Pending* p = slot(seq, t_trigger_ns, now_ns, out, nc.silhouettes_late);
  if (!p) return false;
  pipeline::NodePart& part = p->parts[node_id];
  part.node_id = node_id;
  for (const pipeline::Silhouette& s : part.silhouettes) {
    if (s.camera == silhouette.camera) {  // one per camera and frame: a repeat cannot grow the frame
      nc.silhouettes_rejected++;
      return false;
    }
  }
  part.silhouettes.push_back(std::move(silhouette));
  nc.silhouettes++;
  note_seen(node_id, seq);
  resolve_ready(now_ns, false, out);
  return true;
}

void Assembler::add_stats(uint16_t node_id, const vc_stats& stats) {
  if (!stats_.nodes.count(node_id)) return;
  std::vector<vc_stats>& w = stats_waiting_[node_id];
  if (w.size() >= opt_.max_stats_waiting) w.erase(w.begin());
  w.push_back(stats);
}

void Assembler::poll(uint64_t now_ns, std::vector<MergedFrame>& out) {
  resolve_ready(now_ns, true, out);
}

uint64_t Assembler::next_deadline_ns() const {
  uint64_t next = 0;
  for (const auto& [seq, p] : pending_) {
    const uint64_t d = p.t_trigger_ns + opt_.deadline_ns;
    if (next == 0 || d < next) next = d;
  }
  return next;
}

void Assembler::flush(uint64_t now_ns, std::vector<MergedFrame>& out) {
  for (auto& [seq, p] : pending_) resolve(seq, p, now_ns, out);
  pending_.clear();
}

size_t Assembler::pending_bytes() const {
  size_t b = 0;
  for (const auto& [seq, p] : pending_)
    for (const auto& [n, part] : p.parts) {
      b += part.rle.size();
      for (const pipeline::Silhouette& s : part.silhouettes) b += s.rle.size();
    }
  return b;
}

}  // namespace vc::assemble
