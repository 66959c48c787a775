// The emulated rig's feature scorer (private to host/emulated): the tracked head, hands and feet of
// every merged frame against the virtual rig's truth — the host's 3D features (Frame::features3d)
// against hw/sim's joints, the edges' 2D FEATURES against its 2D features. Figures in
// emulated::FeatureAccuracy (emulated_rig.hpp); the rules in feature_scorer.cpp.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "voxcap/emulated/emulated_rig.hpp"
#include "voxcap/pipeline/pipeline.hpp"
#include "voxcap/sim/scene.hpp"

namespace vc::emulated {

// Quantiles of non-negative values from a fixed histogram: bounded memory over any run length, no
// allocation per sample. Values beyond the last bin land in it; a quantile there is the largest value
// seen.
class Histogram {
 public:
  // A value x falls in bin floor(x / bin); a quantile is reported at the bin's start + centre × bin
  // (0.5: the bin's middle; 0 for counts, with bin 1: the count itself).
  Histogram(double bin, size_t bins, double centre = 0.5) : bin_(bin), centre_(centre), n_(bins, 0) {}
  void add(double x);
  uint64_t count() const { return count_; }
  double max() const { return max_; }
  double quantile(double q) const;  // nearest rank; NaN when empty

 private:
  double bin_, centre_;
  std::vector<uint64_t> n_;
  uint64_t count_ = 0;
  double max_ = 0;
};

class FeatureScorer : public pipeline::Stage {
 public:
  // opt: the rig's simulator (motion, rate, seed, appearance, room) and camera count; calibration: the
  // rig.yaml the edges render with; confident: [triangulation] confident of the rig.
  FeatureScorer(const Options& opt, const std::string& calibration, double confident);
  // Cheap per frame (no rendering): a deep queue, dropping the oldest only when far behind (counted
  // as the stage's drops).
  static pipeline::QueueOptions queue() { return {512, pipeline::Overflow::DropOldest}; }
  std::string name() const override { return "score-features"; }
  void set_origin(uint64_t origin) {
    origin_ = origin;
    started_ = true;
  }
  void process(pipeline::Frame& f) override;
  FeatureAccuracy figures() const;

 private:
  struct Sums {
    FeatureScore s;
    Histogram err3d_mm{0.1, 20000};   // 0.1 mm bins to 2 m
    Histogram err2d_px{0.05, 20000};  // 0.05 px bins to 1000 px
    Histogram runs{1, 4096, 0};       // lost-while-visible run lengths, frames
    bool acquired = false;            // triangulated once while visible
    uint64_t run = 0;                 // the open run's length
  };
  struct View {
    bool reported = false, tracking = false;
    double u = 0, v = 0;
  };
  void score_2d(const pipeline::Frame& f);

  int cameras_;
  double confident_;
  std::unique_ptr<sim::Scene> scene_;
  std::atomic<uint64_t> origin_{0};
  std::atomic<bool> started_{false};
  int frame_ = 0;
  std::vector<std::array<View, kTrackedFeatures>> views_;               // per rig camera, this frame
  std::vector<std::array<sim::FeatureTruth, kTrackedFeatures>> truth_;  // per rig camera, this frame
  mutable std::mutex mu_;                                               // everything below
  uint64_t frames_ = 0;
  std::array<Sums, kTrackedFeatures> sums_;
};

}  // namespace vc::emulated
