// The merge stage of the host's pipeline: each frame's partial hulls ANDed into its merged hull
// (assemble::merge, one vc_rle_and_n pass), stamped with the CLOCK_MONOTONIC time it was ready. A frame
// that cannot be merged (inconsistent hulls) throws: the runner counts it and it goes no further.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "voxcap/pipeline/stage.hpp"

namespace vc::assemble {

class MergeStage : public pipeline::Stage {
 public:
  std::string name() const override { return "merge"; }
  void process(pipeline::Frame& frame) override;

 private:
  std::vector<uint8_t> scratch_;  // vc_rle_and_n's output buffer, kept: no allocation per frame
};

}  // namespace vc::assemble
