// Records from the wire messages the host receives (and back) (proto/include/voxcap/proto.h): what the
// aggregator's sink hands to the Recorder for FEATURES and STATS messages. (A merged frame maps onto
// FrameRecord field by field.)
#pragma once

#include <cstdint>
#include <string>

#include "voxcap/proto.h"
#include "voxcap/record/recorder.hpp"

namespace vc::record {

// Fills *out from a FEATURES message of node `node_id` for frame `seq`. Reuses out->features'
// capacity (no allocation in steady state); counts above VC_PROTO_MAX_FEATURES are clamped.
void to_record(uint16_t node_id, uint64_t seq, const vc_features& msg, FeatureRecord* out);

// The FEATURES message a FeatureRecord was made from (its inverse, for re-running the host's
// triangulation on a recorded session); features beyond VC_PROTO_MAX_FEATURES are left out.
vc_features to_proto(const FeatureRecord& r);

// A STATS message as JSON text, stages and counters by their protocol names (unknown ids as
// "stage_<id>" / "counter_<id>"):
//   {"frames": 60, "stages_ms": {"capture": {"mean": 1.2, "max": 3.4}, ...},
//    "counters": {"frames_captured": 1234, ...}}
std::string stats_json(const vc_stats& msg);

// The StatsRecord of a STATS message of node `node_id` received at host time `t_ns`.
StatsRecord to_record(uint16_t node_id, uint64_t t_ns, const vc_stats& msg);

}  // namespace vc::record
