#include "voxcap/record/from_proto.hpp"

#include <algorithm>

#include <nlohmann/json.hpp>

namespace vc::record {

void to_record(uint16_t node_id, uint64_t seq, const vc_features& msg, FeatureRecord* out) {
  out->seq = seq;
  out->node_id = node_id;
  out->camera = msg.camera;
  const size_t n = std::min<size_t>(msg.feature_count, VC_PROTO_MAX_FEATURES);
  out->features.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const vc_feature& f = msg.features[i];
    out->features[i] = {f.feature_id, f.state, f.u, f.v, f.confidence};
  }
}

vc_features to_proto(const FeatureRecord& r) {
  vc_features msg{};
  msg.camera = r.camera;
  msg.feature_count = static_cast<uint16_t>(std::min<size_t>(r.features.size(), VC_PROTO_MAX_FEATURES));
  for (size_t i = 0; i < msg.feature_count; ++i) {
    const FeatureRecord::F& f = r.features[i];
    msg.features[i] = {f.id, f.state, f.u, f.v, f.confidence};
  }
  return msg;
}

std::string stats_json(const vc_stats& msg) {
  nlohmann::ordered_json stages = nlohmann::ordered_json::object();
  for (size_t i = 0; i < std::min<size_t>(msg.stage_count, VC_PROTO_MAX_STAGES); ++i) {
    const vc_stage_time& s = msg.stages[i];
    const char* name = vc_stage_name(s.stage_id);
    stages[name ? std::string(name) : "stage_" + std::to_string(s.stage_id)] = {{"mean", s.mean_ns / 1e6},
                                                                                {"max", s.max_ns / 1e6}};
  }
  nlohmann::ordered_json counters = nlohmann::ordered_json::object();
  for (size_t i = 0; i < std::min<size_t>(msg.counter_count, VC_PROTO_MAX_COUNTERS); ++i) {
    const vc_counter& c = msg.counters[i];
    const char* name = vc_counter_name(c.counter_id);
    counters[name ? std::string(name) : "counter_" + std::to_string(c.counter_id)] = c.value;
  }
  const nlohmann::ordered_json j = {{"frames", msg.frames}, {"stages_ms", stages}, {"counters", counters}};
  return j.dump();
}

StatsRecord to_record(uint16_t node_id, uint64_t t_ns, const vc_stats& msg) {
  return {t_ns, node_id, stats_json(msg)};
}

}  // namespace vc::record
