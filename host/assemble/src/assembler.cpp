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
  return true;
}

Assembler::Assembler(AssemblerOptions options) : opt_(std::move(options)) {
  std::string why;
  if (!opt_.valid(&why)) throw std::invalid_argument("assembler: " + why);
  for (uint16_t n : opt_.nodes) {
    running_[n] = true;
    stats_.nodes[n];
  }
}

void Assembler::set_running(uint16_t node_id, bool running) {
  auto it = running_.find(node_id);
  if (it != running_.end()) it->second = running;
}

bool Assembler::complete(const Pending& p) const {
  for (const auto& [node, run] : running_)
    if (run && !p.hulls.count(node)) return false;
  return true;
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

void Assembler::resolve(uint64_t seq, Pending& p, uint64_t now_ns, std::vector<MergedFrame>& out) {
  if (!any_resolved_ || seq > max_resolved_) max_resolved_ = seq;
  any_resolved_ = true;
  MergedFrame f;
  f.seq = seq;
  for (uint16_t n : opt_.nodes) {
    if (p.hulls.count(n)) {
      f.present.push_back(n);
    } else {
      f.missing.push_back(n);
      stats_.nodes[n].missing++;
    }
  }
  if (f.present.empty()) return;  // nobody sent anything: nothing to merge or count
  if (!f.missing.empty() && opt_.policy == MissingPolicy::Drop) {
    stats_.dropped++;
    return;
  }
  f.degraded = !f.missing.empty();
  f.t_trigger_ns = p.t_trigger_ns;
  f.t_first_rx_ns = p.t_first_rx_ns;
  f.t_last_rx_ns = p.t_last_rx_ns;
  f.t_merged_ns = now_ns;
  f.grid_id = opt_.grid_id;
  f.voxel_count = opt_.voxel_count;
  std::vector<const std::vector<uint8_t>*> parts;
  for (auto& [node, rle] : p.hulls) parts.push_back(&rle);
  intersect(parts, f.rle, tmp_);
  uint64_t occ = 0, total = 0;
  if (vc_rle_popcount(f.rle.data(), f.rle.size(), &occ, &total) < 0 || total != opt_.voxel_count)
    throw std::runtime_error("assembler: merged hull is inconsistent");
  f.occupied = occ;
  (f.degraded ? stats_.degraded : stats_.complete)++;
  out.push_back(std::move(f));
}

bool Assembler::add(PartialHull h, uint64_t now_ns, std::vector<MergedFrame>& out) {
  auto node_it = stats_.nodes.find(h.node_id);
  if (node_it == stats_.nodes.end()) return false;  // not a configured node: the session rejects those
  NodeCounters& nc = node_it->second;
  if (h.grid_id != opt_.grid_id || h.voxel_count != opt_.voxel_count) {
    nc.rejected++;
    return false;
  }
  auto it = pending_.find(h.seq);
  if (it == pending_.end()) {
    if (any_resolved_ && h.seq <= max_resolved_) {
      nc.late++;
      return false;
    }
    while (pending_.size() >= opt_.max_pending) {
      auto oldest = pending_.begin();
      if (oldest->first > h.seq) {  // the new hull is older than everything kept: it is the one to go
        nc.late++;
        return false;
      }
      stats_.evicted++;
      resolve(oldest->first, oldest->second, now_ns, out);
      pending_.erase(oldest);
    }
    it = pending_.emplace(h.seq, Pending{}).first;
    it->second.t_trigger_ns = h.t_trigger_ns;
    it->second.t_first_rx_ns = h.t_received_ns;
  }
  Pending& p = it->second;
  if (p.hulls.count(h.node_id)) {
    nc.rejected++;
    return false;
  }
  p.t_last_rx_ns = std::max(p.t_last_rx_ns, h.t_received_ns);
  p.hulls.emplace(h.node_id, std::move(h.rle));
  nc.received++;
  if (complete(p)) {
    resolve(it->first, p, now_ns, out);
    pending_.erase(it);
  }
  return true;
}

void Assembler::poll(uint64_t now_ns, std::vector<MergedFrame>& out) {
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (it->second.t_trigger_ns + opt_.deadline_ns <= now_ns || complete(it->second)) {
      resolve(it->first, it->second, now_ns, out);
      it = pending_.erase(it);
    } else {
      ++it;
    }
  }
}

void Assembler::flush(uint64_t now_ns, std::vector<MergedFrame>& out) {
  for (auto& [seq, p] : pending_) resolve(seq, p, now_ns, out);
  pending_.clear();
}

size_t Assembler::pending_bytes() const {
  size_t b = 0;
  for (const auto& [seq, p] : pending_)
    for (const auto& [n, rle] : p.hulls) b += rle.size();
  return b;
}

}  // namespace vc::assemble
