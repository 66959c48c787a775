#include "voxcap/record/session_info.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "io.hpp"

namespace vc::record {
namespace {

std::string human_bytes(uint64_t n) {
  if (n < 1024) return fmt::format("{} B", n);
  if (n < (uint64_t{1} << 20)) return fmt::format("{:.1f} KiB", static_cast<double>(n) / 1024.0);
  if (n < (uint64_t{1} << 30)) return fmt::format("{:.1f} MiB", static_cast<double>(n) / (1024.0 * 1024.0));
  return fmt::format("{:.2f} GiB", static_cast<double>(n) / (1024.0 * 1024.0 * 1024.0));
}

double frames_per_s(const Reader::Summary& s) {
  const double d = s.duration_s();
  return d > 0 ? static_cast<double>(s.frames - 1) / d : 0.0;
}

std::string ending(const Reader::Summary& s) {
  switch (s.stop) {
    case Reader::Stop::Closed:
      return s.truncated_bytes ? fmt::format("closed cleanly ({} bytes after END ignored)", s.truncated_bytes)
                               : "closed cleanly";
    case Reader::Stop::EndOfFile:
      return fmt::format("cut (no END record): {}", s.stop_detail);
    case Reader::Stop::TornTail:
      return fmt::format("cut, torn tail of {} bytes ignored: {}", s.truncated_bytes, s.stop_detail);
    case Reader::Stop::Corrupt:
      return fmt::format("CORRUPT, reading stopped; {} bytes ignored: {}", s.truncated_bytes, s.stop_detail);
  }
  return "?";
}

}  // namespace

std::string summary_text(const Reader::Summary& s, const std::filesystem::path& dir,
                         const NodeNames& node_names) {
  std::string out;
  auto line = [&out](const char* key, const std::string& value) {
    out += fmt::format("{:<10}{}\n", key, value);
  };
  line("session", dir.string());
  line("rig", fmt::format("{}  (rig.toml {}, calibration.yaml {})", s.rig_name.empty() ? "?" : s.rig_name,
                          s.rig_toml_ok ? "ok" : "NOT VERIFIED", s.calibration_ok ? "ok" : "NOT VERIFIED"));
  line("created", s.created_unix_ns
                      ? fmt::format("{}  by voxcap {} (format {})", io::format_utc(s.created_unix_ns),
                                    s.software_version.empty() ? "?" : s.software_version, s.format_version)
                      : std::string("?"));
  if (s.frames == 0) {
    line("frames", "0");
  } else {
    std::string seqs = fmt::format("seq {} .. {}", s.first_seq, s.last_seq);
    if (s.missing_seqs) seqs += fmt::format(", {} skipped", s.missing_seqs);
    if (s.unordered_seqs) seqs += fmt::format(", {} out of order", s.unordered_seqs);
    line("frames", fmt::format("{} ({} degraded), {}", s.frames, s.degraded_frames, seqs));
    line(
        "duration",
        fmt::format("{:.3f} s of trigger time ({:.1f} frames/s), merge latency mean {:.2f} ms, max {:.2f} ms",
                    s.duration_s(), frames_per_s(s), s.mean_merge_latency_ns / 1e6,
                    static_cast<double>(s.max_merge_latency_ns) / 1e6));
    line("hulls", fmt::format("{} frames, {} RLE", s.hull_frames, human_bytes(s.hull_bytes)));
  }
  line("features", fmt::format("{} records, {} points", s.features, s.feature_points));
  line("3d feats", fmt::format("{} records (the host's triangulated features)", s.features3d));
  std::string poses = fmt::format("{} records", s.poses);
  if (s.poses) poses += fmt::format(" (layout \"{}\", {} joint names)", s.pose_layout, s.joint_names.size());
  line("poses", poses);
  line("stats", fmt::format("{} records", s.stats));
  if (s.nodes.empty()) {
    line("nodes", "none");
  } else {
    line("nodes", fmt::format("{}", s.nodes.size()));
    for (const auto& [id, c] : s.nodes) {
      const auto name = node_names.find(id);
      const std::string label =
          name == node_names.end() ? std::to_string(id) : fmt::format("{} ({})", id, name->second);
      out +=
          fmt::format("  node {:<12} in {} frames, missing from {}, {} feature records, {} stats records\n",
                      label, c.frames_present, c.frames_missing, c.feature_records, c.stats_records);
    }
  }
  line("records", fmt::format("{} data records, {} of {} valid", s.records, human_bytes(s.valid_bytes),
                              human_bytes(s.file_bytes)));
  line("end", ending(s));
  if (s.skipped_records > 0 || s.skipped_bytes > 0) {
    line("skipped", fmt::format("{} damaged record{} ({}), read on after each", s.skipped_records,
                                s.skipped_records == 1 ? "" : "s", human_bytes(s.skipped_bytes)));
    for (const std::string& d : s.damage) out += fmt::format("  {}\n", d);
  }
  for (const std::string& w : s.warnings) line("warning", w);
  return out;
}

std::string summary_json(const Reader::Summary& s, const std::filesystem::path& dir,
                         const NodeNames& node_names) {
  using nlohmann::json;
  json nodes = json::array();
  for (const auto& [id, c] : s.nodes) {
    const auto name = node_names.find(id);
    nodes.push_back({{"id", id},
                     {"name", name == node_names.end() ? json(nullptr) : json(name->second)},
                     {"frames_present", c.frames_present},
                     {"frames_missing", c.frames_missing},
                     {"feature_records", c.feature_records},
                     {"stats_records", c.stats_records}});
  }
  json meta = json::parse(s.meta_json, nullptr, false);
  if (meta.is_discarded()) meta = nullptr;
  const bool any = s.frames > 0;
  json j = {
      {"dir", dir.string()},
      {"rig_name", s.rig_name},
      {"rig_toml_ok", s.rig_toml_ok},
      {"calibration_ok", s.calibration_ok},
      {"created_utc", s.created_unix_ns ? json(io::format_utc(s.created_unix_ns)) : json(nullptr)},
      {"created_unix_ns", s.created_unix_ns},
      {"software_version", s.software_version},
      {"format_version", s.format_version},
      {"frames", s.frames},
      {"degraded_frames", s.degraded_frames},
      {"first_seq", any ? json(s.first_seq) : json(nullptr)},
      {"last_seq", any ? json(s.last_seq) : json(nullptr)},
      {"missing_seqs", s.missing_seqs},
      {"unordered_seqs", s.unordered_seqs},
      {"first_trigger_ns", any ? json(s.first_trigger_ns) : json(nullptr)},
      {"last_trigger_ns", any ? json(s.last_trigger_ns) : json(nullptr)},
      {"duration_s", s.duration_s()},
      {"frames_per_s", frames_per_s(s)},
      {"merge_latency_ms",
       {{"mean", s.mean_merge_latency_ns / 1e6}, {"max", static_cast<double>(s.max_merge_latency_ns) / 1e6}}},
      {"hull_frames", s.hull_frames},
      {"hull_bytes", s.hull_bytes},
      {"features", s.features},
      {"feature_points", s.feature_points},
      {"features3d", s.features3d},
      {"poses", s.poses},
      {"pose_layout", s.pose_layout},
      {"joint_names", s.joint_names},
      {"stats", s.stats},
      {"nodes", nodes},
      {"records", s.records},
      {"closed_cleanly", s.closed_cleanly},
      {"stop", to_string(s.stop)},
      {"stop_detail", s.stop_detail},
      {"file_bytes", s.file_bytes},
      {"valid_bytes", s.valid_bytes},
      {"truncated_bytes", s.truncated_bytes},
      {"skipped_records", s.skipped_records},
      {"skipped_bytes", s.skipped_bytes},
      {"damage", s.damage},
      {"meta", meta},
      {"warnings", s.warnings},
  };
  return j.dump(2) + "\n";
}

RunRecording read_back(const Reader::Summary& s, const std::filesystem::path& dir, uint64_t merged_frames) {
  RunRecording r;
  r.dir = dir;
  r.merged_frames = merged_frames;
  r.frames = s.frames;
  r.records = s.records;
  r.skipped_records = s.skipped_records;
  r.skipped_bytes = s.skipped_bytes;
  r.truncated_bytes = s.truncated_bytes;
  r.closed_cleanly = s.closed_cleanly;
  r.stop = to_string(s.stop);
  r.damage = s.damage;
  return r;
}

RunRecording read_back(const std::filesystem::path& dir, uint64_t merged_frames) {
  const Reader reader = Reader::open(dir);
  return read_back(reader.summary_ref(), dir, merged_frames);
}

std::string run_recording_line(const RunRecording& r) {
  std::string out = fmt::format("session   {}: {} frames (of {} merged), {} records, ", r.dir.string(),
                                r.frames, r.merged_frames, r.records);
  if (r.closed_cleanly)
    out += "closed cleanly";
  else
    out += r.stop == "closed" ? "closed with damage" : fmt::format("NOT closed ({})", r.stop);
  if (r.skipped_records > 0 || r.skipped_bytes > 0)
    out += fmt::format(", {} damaged record{} skipped ({})", r.skipped_records,
                       r.skipped_records == 1 ? "" : "s", human_bytes(r.skipped_bytes));
  if (r.truncated_bytes > 0) out += fmt::format(", {} ignored at its end", human_bytes(r.truncated_bytes));
  if (const uint64_t n = r.frames_not_recorded())
    out += fmt::format(", {} merged frame{} NOT in the session", n, n == 1 ? "" : "s");
  return out;
}

}  // namespace vc::record
