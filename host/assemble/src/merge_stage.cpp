#include "voxcap/assemble/merge_stage.hpp"

#include <time.h>

#include "voxcap/assemble/assembler.hpp"

namespace vc::assemble {

void MergeStage::process(pipeline::Frame& frame) {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);  // the host's time base (trigger pulses, receive times)
  merge(frame, scratch_,
        static_cast<uint64_t>(ts.tv_sec) * 1'000'000'000u + static_cast<uint64_t>(ts.tv_nsec));
}

}  // namespace vc::assemble
