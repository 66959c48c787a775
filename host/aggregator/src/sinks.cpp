#include "voxcap/aggregator/sinks.hpp"

#include <fmt/chrono.h>
#include <fmt/core.h>

#include <ctime>

#include "voxcap/record/from_proto.hpp"
#include "voxcap/session/server.hpp"

namespace vc::aggregator {

static std::filesystem::path session_dir(const config::RigConfig& rig, const std::filesystem::path& parent) {
  std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  std::filesystem::path p = parent / fmt::format("{}-{:%Y%m%dT%H%M%SZ}", rig.name.empty() ? "rig" : rig.name, utc);
  for (int k = 2; std::filesystem::exists(p); k++)
    p = parent / fmt::format("{}-{:%Y%m%dT%H%M%SZ}-{}", rig.name.empty() ? "rig" : rig.name, utc, k);
  return p;
}

RecordingSink::RecordingSink(const config::RigConfig& rig, const std::filesystem::path& parent)
    : dir_(session_dir(rig, parent)),
      rec_(record::Recorder::create(dir_, rig.source, rig.calibration_path,
                                    fmt::format(R"({{"rig":"{}","nodes":{}}})", rig.name, rig.nodes.size()))),
      last_sync_(std::chrono::steady_clock::now()) {}

RecordingSink::~RecordingSink() {
  try {
    rec_.close();
  } catch (...) {  // a destructor must not throw; the session stays readable up to its last record
  }
}

void RecordingSink::maybe_sync() {
  auto now = std::chrono::steady_clock::now();
  if (now - last_sync_ < std::chrono::seconds(1)) return;
  rec_.flush();
  last_sync_ = now;
}

void RecordingSink::frame(const assemble::MergedFrame& f) {
  frame_.seq = f.seq;
  frame_.t_trigger_ns = f.t_trigger_ns;
  frame_.t_merged_ns = f.t_merged_ns;
  frame_.grid_id = f.grid_id;
  frame_.voxel_count = f.voxel_count;
  frame_.occupied = f.occupied;
  frame_.degraded = f.degraded;
  frame_.nodes_present.assign(f.present.begin(), f.present.end());
  frame_.nodes_missing.assign(f.missing.begin(), f.missing.end());
  frame_.rle.assign(f.rle.begin(), f.rle.end());
  rec_.append(frame_);
  maybe_sync();
}

void RecordingSink::features(uint16_t node, uint64_t seq, const vc_features& f) {
  record::FeatureRecord r;
  record::to_record(node, seq, f, &r);
  rec_.append(r);
}

void RecordingSink::stats(uint16_t node, const vc_stats& st) {
  rec_.append(record::to_record(node, session::monotonic_ns(), st));
}

}  // namespace vc::aggregator
