#include "voxcap/export/session_take.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "voxcap/record/pose.hpp"
#include "voxcap/record/recorder.hpp"

namespace vc::take {

SessionPoses read_session_poses(const std::filesystem::path& dir, std::optional<uint64_t> origin) {
  record::Reader reader = record::Reader::open(dir);
  SessionPoses out;
  std::map<uint64_t, pipeline::Pose> by_seq;  // seq -> pose (state none until a pose record says more)
  std::vector<std::pair<uint64_t, uint64_t>> triggers;  // (seq, t_trigger_ns) of the frame records
  record::Record r;
  std::string why;
  while (reader.next(r)) {
    if (const auto* f = std::get_if<record::FrameRecord>(&r)) {
      ++out.frame_records;
      by_seq.try_emplace(f->seq);
      triggers.emplace_back(f->seq, f->t_trigger_ns);
    } else if (const auto* p = std::get_if<record::PoseRecord>(&r)) {
      if (p->layout != record::kPoseLayout) {
        ++out.other_layouts;
        continue;
      }
      ++out.pose_records;
      pipeline::Pose pose;
      if (!record::from_record(*p, &pose, &why)) {
        if (out.bad_poses++ == 0) out.warnings.push_back(why);
        continue;
      }
      out.posed += pose.valid() ? 1 : 0;
      by_seq[p->seq] = pose;
    }
  }
  const record::Reader::Summary& s = reader.summary_ref();
  if (!s.closed_cleanly)
    out.warnings.push_back(fmt::format("the session is {} ({}): read up to its last complete record",
                                       to_string(s.stop), s.stop_detail));
  if (origin) {
    out.origin = static_cast<int64_t>(*origin);
  } else {
    out.origin = triggers.empty() ? (by_seq.empty() ? 0 : static_cast<int64_t>(by_seq.begin()->first))
                                  : static_cast<int64_t>(triggers.front().first);
  }
  for (const auto& [seq, pose] : by_seq) out.frames.push_back({static_cast<int64_t>(seq) - out.origin, pose});

  // The frame period: the rig's trigger rate, else the trigger times per seq.
  try {
    const toml::table t = toml::parse_file((dir / "rig.toml").string());
    if (const auto hz = t["trigger"]["rate_hz"].value<double>(); hz && *hz > 0 && *hz <= 10000) {
      out.frame_time_s = 1.0 / *hz;
      out.frame_time_source = "rig.toml";
    }
  } catch (const std::exception&) {  // no usable rig.toml copy: the trigger times say it
  }
  if (out.frame_time_s <= 0) {
    std::vector<double> dt;
    for (size_t i = 1; i < triggers.size(); ++i) {
      const auto& [s0, t0] = triggers[i - 1];
      const auto& [s1, t1] = triggers[i];
      if (s1 > s0 && t1 > t0) dt.push_back(double(t1 - t0) / double(s1 - s0) * 1e-9);
    }
    if (!dt.empty()) {
      std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
      out.frame_time_s = dt[dt.size() / 2];
      out.frame_time_source = "trigger times";
    } else {
      out.frame_time_s = 1.0 / 60;
      out.frame_time_source = "default 60 Hz";
      out.warnings.push_back("no rig.toml rate and too few frames: the frame time is 1/60 s");
    }
  }
  return out;
}

}  // namespace vc::take
