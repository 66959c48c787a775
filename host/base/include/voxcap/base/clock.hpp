// The host's one monotonic clock. Every host timestamp is CLOCK_MONOTONIC in nanoseconds, unsigned as
// on the wire (t_trigger_ns, sender_time_ns) and on the edge (vc_clock_monotonic_ns), so stamps from
// the trigger, the sessions, the assembly and the recording compare directly. std::chrono::steady_clock
// reads the same clock on Linux; use it for durations measured and compared within one function.
#pragma once

#include <cstdint>

namespace vc {

// CLOCK_MONOTONIC now, in nanoseconds.
uint64_t monotonic_ns();

}  // namespace vc
