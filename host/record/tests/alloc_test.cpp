// Steady-state appends allocate nothing: once the encode buffer has grown to the largest record,
// appending frames, features and poses (what the host does per frame) makes no heap allocation.
// Counted with the sanitizer allocator hooks under ASan, with a replaced operator new otherwise (this
// file is its own test binary, so the replacement affects nothing else). Also: the proto adapters.
#include <atomic>
#include <cstdlib>
#include <new>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "session_fixture.hpp"
#include "voxcap/record/from_proto.hpp"
#include "voxcap/record/recorder.hpp"

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define VC_ALLOC_TEST_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define VC_ALLOC_TEST_ASAN 1
#endif

namespace {
std::atomic<uint64_t> g_allocations{0};
}  // namespace

#ifdef VC_ALLOC_TEST_ASAN
#include <sanitizer/allocator_interface.h>
namespace {
void on_malloc(const volatile void*, size_t) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
}
void on_free(const volatile void*) {}
const int g_hooks = __sanitizer_install_malloc_and_free_hooks(on_malloc, on_free);
}  // namespace
#else
void* operator new(size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, size_t) noexcept {
  std::free(p);
}
#endif

namespace vc::record {
namespace {

TEST(RecordAlloc, SteadyStateAppendsDoNotAllocate) {
  testing::TempDir tmp;
  const testing::RigFiles rig = testing::write_rig_files(tmp.path());
  Recorder rec = Recorder::create(tmp.path() / "s", rig.rig_toml, rig.calibration_yaml, "");
  // Records built up front: the test counts the recorder's allocations, not the fixture's.
  std::vector<FrameRecord> frames;
  for (uint64_t seq = 0; seq < 8; ++seq) frames.push_back(testing::make_frame(seq, 64));
  const FeatureRecord features = testing::make_features(3, 0, 1);
  const PoseRecord pose = testing::make_pose(3, true);
  for (const FrameRecord& f : frames) rec.append(f);  // warm-up: the buffer reaches its size
  rec.append(features);
  rec.append(pose);

  const uint64_t before = g_allocations.load();
  for (int round = 0; round < 50; ++round) {
    for (const FrameRecord& f : frames) {
      rec.append(f);
      rec.append(features);
      rec.append(pose);
    }
  }
  rec.flush();
  const uint64_t allocations = g_allocations.load() - before;
  EXPECT_EQ(allocations, 0u) << "allocations in 1200 appends";
  EXPECT_EQ(rec.records(), 8u + 2u + 1200u);
  // The hook/replacement is live: the counter moves for an allocation we make ourselves.
  auto* p = new std::vector<int>(100);
  EXPECT_GT(g_allocations.load(), before);
  delete p;
}

// A FEATURES message of camera 1 with features 0..2 (states alternating, u = 10 i, v = 20 i).
vc_features three_features() {
  vc_features msg{};
  msg.camera = 1;
  msg.feature_count = 3;
  for (uint16_t i = 0; i < 3; ++i)
    msg.features[i] = {i, static_cast<uint16_t>(i % 2), 10.0f * i, 20.0f * i, 0.5f};
  return msg;
}

TEST(RecordAlloc, FeaturesFromTheWireMessage) {
  vc_features msg = three_features();
  FeatureRecord r;
  to_record(4, 99, msg, &r);
  EXPECT_EQ(r.seq, 99u);
  EXPECT_EQ(r.node_id, 4u);
  EXPECT_EQ(r.camera, 1u);
  ASSERT_EQ(r.features.size(), 3u);
  EXPECT_EQ(r.features[2], (FeatureRecord::F{2, 0, 20.0f, 40.0f, 0.5f}));
  msg.feature_count = 1000;  // a bad count cannot read past the array
  to_record(4, 99, msg, &r);
  EXPECT_EQ(r.features.size(), static_cast<size_t>(VC_PROTO_MAX_FEATURES));
}

TEST(RecordAlloc, FeaturesBackToTheWireMessage) {
  const vc_features msg = three_features();
  FeatureRecord r;
  to_record(4, 99, msg, &r);
  const vc_features back = to_proto(r);
  EXPECT_EQ(back.camera, 1u);
  ASSERT_EQ(back.feature_count, 3u);
  for (uint16_t i = 0; i < 3; ++i) {
    EXPECT_EQ(back.features[i].feature_id, i);
    EXPECT_EQ(back.features[i].state, msg.features[i].state);
    EXPECT_EQ(back.features[i].u, msg.features[i].u);
    EXPECT_EQ(back.features[i].v, msg.features[i].v);
    EXPECT_EQ(back.features[i].confidence, msg.features[i].confidence);
  }
  r.features.resize(VC_PROTO_MAX_FEATURES + 5);  // a hostile record cannot write past the array
  EXPECT_EQ(to_proto(r).feature_count, static_cast<uint16_t>(VC_PROTO_MAX_FEATURES));
}

TEST(RecordAlloc, StatsFromTheWireMessage) {
  vc_stats msg{};
  msg.frames = 60;
  msg.stage_count = 2;
  msg.stages[0] = {VC_STAGE_CARVE, 1'500'000, 4'000'000};
  msg.stages[1] = {999, 1000, 2000};
  msg.counter_count = 1;
  msg.counters[0] = {VC_COUNTER_FRAMES_CAPTURED, 1234};
  const StatsRecord s = to_record(2, 777, msg);
  EXPECT_EQ(s.node_id, 2u);
  EXPECT_EQ(s.t_ns, 777u);
  const auto j = nlohmann::json::parse(s.json);
  EXPECT_EQ(j["frames"], 60);
  EXPECT_DOUBLE_EQ(j["stages_ms"]["carve"]["mean"].get<double>(), 1.5);
  EXPECT_DOUBLE_EQ(j["stages_ms"]["carve"]["max"].get<double>(), 4.0);
  EXPECT_TRUE(j["stages_ms"].contains("stage_999"));
  EXPECT_EQ(j["counters"]["frames_captured"], 1234);
}

}  // namespace
}  // namespace vc::record
