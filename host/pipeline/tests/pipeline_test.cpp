// The stage runner and the pipeline: order, both overflow policies of the stages, stop while a
// producer is blocked, exceptions in a stage, the lifecycle and the context.
#include "voxcap/pipeline/pipeline.hpp"
#include "voxcap/pipeline/timing.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <future>
#include <mutex>
#include <thread>

namespace vc::pipeline {
namespace {

using namespace std::chrono_literals;

FramePtr frame(uint64_t seq) {
  auto f = std::make_shared<Frame>();
  f->seq = seq;
  return f;
}

// Records the seqs it saw (and the lifecycle calls); optionally waits on a gate in process().
class Probe : public Stage {
 public:
  explicit Probe(std::string name) : name_(std::move(name)) {}
  std::string name() const override { return name_; }
  void configure(const StageContext& ctx) override {
    calls.push_back("configure");
    rig = ctx.rig;
    if (ctx.log) ctx.log(log::Level::info, "configured");
  }
  void start() override { calls.push_back("start"); }
  void process(Frame& f) override {
    {
      std::unique_lock<std::mutex> l(mu);
      entered++;
      cv.notify_all();
      cv.wait(l, [&] { return open; });
      seen.push_back(f.seq);
    }
    if (throw_on && f.seq == throw_on) throw std::runtime_error("bad frame");
    if (sleep_ms) std::this_thread::sleep_for(std::chrono::milliseconds(sleep_ms));
    if (mutates) f.occupied += 1;  // a chain stage may change the frame
    saw_occupied.push_back(f.occupied);
  }
  void stop() override { calls.push_back("stop"); }

  void close_gate() {
    std::lock_guard<std::mutex> g(mu);
    open = false;
  }
  void open_gate() {
    {
      std::lock_guard<std::mutex> g(mu);
      open = true;
    }
    cv.notify_all();
  }
  void wait_entered(int n) {
    std::unique_lock<std::mutex> l(mu);
    cv.wait_for(l, 5s, [&] { return entered >= n; });
  }
  std::vector<uint64_t> seqs() {
    std::lock_guard<std::mutex> g(mu);
    return seen;
  }

  std::string name_;
  std::vector<std::string> calls;
  const config::RigConfig* rig = nullptr;
  uint64_t throw_on = 0;
  int sleep_ms = 0;
  // Only chain stages may change a frame: consumers share it read-only and run at the same time.
  bool mutates = false;                // set on chain stages
  std::vector<uint64_t> saw_occupied;  // f.occupied as this stage left it, per frame
  std::mutex mu;
  std::condition_variable cv;
  bool open = true;
  int entered = 0;
  std::vector<uint64_t> seen;
};

std::vector<uint64_t> range(uint64_t a, uint64_t b) {
  std::vector<uint64_t> v;
  for (uint64_t s = a; s < b; s++) v.push_back(s);
  return v;
}

TEST(Pipeline, EveryStageSeesFramesInOrderThroughTheChainAndEveryConsumer) {
  std::vector<std::string> lines;
  std::mutex lines_mu;
  StageContext ctx;
  ctx.log = [&](log::Level, const std::string& l) {
    std::lock_guard<std::mutex> g(lines_mu);
    lines.push_back(l);
  };
  Pipeline p(ctx);
  Probe& a = p.then(std::make_unique<Probe>("a"), {4, Overflow::Block});
  Probe& b = p.then(std::make_unique<Probe>("b"), {4, Overflow::Block});
  Probe& c = p.tap(std::make_unique<Probe>("c"), {4, Overflow::Block});
  Probe& d = p.tap(std::make_unique<Probe>("d"), {4, Overflow::Block});
  a.mutates = b.mutates = true;
  EXPECT_THROW(p.then(std::make_unique<Probe>("late"), {}), std::logic_error);
  p.start();
  EXPECT_THROW(p.tap(std::make_unique<Probe>("after-start"), {}), std::logic_error);
  std::vector<FramePtr> frames;
  for (uint64_t s = 1; s <= 200; s++) {
    frames.push_back(frame(s));
    ASSERT_TRUE(p.push(frames.back()));
  }
  p.stop();
  for (Probe* s : {&a, &b, &c, &d}) {
    EXPECT_EQ(s->seqs(), range(1, 201)) << s->name();
    EXPECT_EQ(s->calls, (std::vector<std::string>{"configure", "start", "stop"})) << s->name();
  }
  for (const FramePtr& f : frames)
    EXPECT_EQ(f->occupied, 2u) << "each chain stage ran once on frame " << f->seq;
  EXPECT_EQ(a.saw_occupied, std::vector<uint64_t>(200, 1u)) << "a runs first";
  EXPECT_EQ(b.saw_occupied, std::vector<uint64_t>(200, 2u)) << "b runs after a";
  for (Probe* s : {&c, &d})
    EXPECT_EQ(s->saw_occupied, std::vector<uint64_t>(200, 2u)) << s->name() << " sees frames after the chain";
  PipelineReport r = p.report();
  ASSERT_EQ(r.stages.size(), 4u);
  EXPECT_EQ(r.stages[0].name, "a");
  EXPECT_EQ(r.stages[3].name, "d");
  for (const StageReport& s : r.stages) {
    EXPECT_EQ(s.processed, 200u) << s.name;
    EXPECT_EQ(s.queue.dropped, 0u) << s.name;
    EXPECT_LE(s.queue.max_depth, 4u) << s.name;
    EXPECT_EQ(s.queue.depth, 0u) << s.name;
  }
  std::lock_guard<std::mutex> g(lines_mu);
  EXPECT_NE(std::find(lines.begin(), lines.end(), "c: configured"), lines.end())
      << "lines carry the stage's name";
}

TEST(Pipeline, AStalledLiveConsumerDropsTheOldestWhileARecordingConsumerGetsEveryFrame) {
  Pipeline p(StageContext{});
  Probe& live = p.tap(std::make_unique<Probe>("live"), {3, Overflow::DropOldest});
  Probe& rec = p.tap(std::make_unique<Probe>("record"), {512, Overflow::Block});
  p.start();
  live.close_gate();
  ASSERT_TRUE(p.push(frame(1)));
  live.wait_entered(1);  // the live stage is stuck inside frame 1
  for (uint64_t s = 2; s <= 100; s++) p.push(frame(s));
  live.open_gate();
  p.stop();
  PipelineReport r = p.report();
  const StageReport* lr = r.stage("live");
  ASSERT_NE(lr, nullptr);
  EXPECT_EQ(live.seqs(), (std::vector<uint64_t>{1, 98, 99, 100}))
      << "the stall's frames were dropped, the newest kept";
  EXPECT_EQ(lr->queue.dropped, 96u);
  EXPECT_EQ(lr->processed + lr->queue.dropped, 100u) << "every frame accounted";
  EXPECT_EQ(rec.seqs(), range(1, 101));
  EXPECT_EQ(r.stage("record")->queue.dropped, 0u);
}

TEST(Pipeline, ABlockingStageHoldsBackTheStageBeforeItNotTheProducerOfTheChain) {
  Pipeline p(StageContext{});
  Probe& merge = p.then(std::make_unique<Probe>("merge"), {64, Overflow::Block});
  Probe& rec = p.tap(std::make_unique<Probe>("record"), {2, Overflow::Block});
  p.start();
  rec.close_gate();
  for (uint64_t s = 1; s <= 10; s++) ASSERT_TRUE(p.push(frame(s)));  // never waits: 64 places
  rec.wait_entered(1);
  std::this_thread::sleep_for(50ms);
  EXPECT_LT(merge.seqs().size(), 10u) << "merge waits for room in record's queue";
  EXPECT_GT(p.report().stage("record")->queue.blocked, 0u);
  rec.open_gate();
  p.stop();
  EXPECT_EQ(merge.seqs(), range(1, 11));
  EXPECT_EQ(rec.seqs(), range(1, 11));
}

TEST(StageRunner, StopWhileAProducerIsBlockedWakesItAndFinishesTheQueuedFrames) {
  auto probe = std::make_unique<Probe>("slow");
  Probe& slow = *probe;
  StageRunner r(std::move(probe), {2, Overflow::Block});
  r.configure({});
  r.start();
  slow.close_gate();
  ASSERT_TRUE(r.push(frame(1)));
  slow.wait_entered(1);
  ASSERT_TRUE(r.push(frame(2)));
  ASSERT_TRUE(r.push(frame(3)));  // the queue is full now
  std::promise<bool> pushed;
  std::thread producer([&] { pushed.set_value(r.push(frame(4))); });
  std::future<bool> result = pushed.get_future();
  EXPECT_EQ(result.wait_for(100ms), std::future_status::timeout) << "blocked: no room";
  std::thread stopper([&] { r.stop(); });
  ASSERT_EQ(result.wait_for(2s), std::future_status::ready) << "stop() woke the blocked producer";
  EXPECT_FALSE(result.get()) << "its frame was refused, not lost silently";
  slow.open_gate();
  stopper.join();
  producer.join();
  EXPECT_EQ(slow.seqs(), (std::vector<uint64_t>{1, 2, 3}));
  StageReport rep = r.report();
  EXPECT_EQ(rep.processed, 3u);
  EXPECT_EQ(rep.queue.refused_closed, 1u);
  EXPECT_EQ(slow.calls.back(), "stop");
  EXPECT_FALSE(r.push(frame(5)));
}

TEST(StageRunner, AnExceptionInAStageIsCountedAndTheFrameGoesNoFurther) {
  std::atomic<int> errors_logged{0};
  StageContext ctx;
  ctx.log = [&](log::Level level, const std::string& line) {
    if (level == log::Level::err && line.find("bad frame") != std::string::npos) errors_logged++;
  };
  Pipeline p(ctx);
  Probe& a = p.then(std::make_unique<Probe>("a"), {8, Overflow::Block});
  Probe& b = p.tap(std::make_unique<Probe>("b"), {8, Overflow::Block});
  a.throw_on = 3;
  p.start();
  for (uint64_t s = 1; s <= 6; s++) p.push(frame(s));
  p.stop();
  EXPECT_EQ(a.seqs(), range(1, 7));
  EXPECT_EQ(b.seqs(), (std::vector<uint64_t>{1, 2, 4, 5, 6}));
  PipelineReport rep = p.report();
  const StageReport* ra = rep.stage("a");
  ASSERT_NE(ra, nullptr);
  EXPECT_EQ(ra->errors, 1u);
  EXPECT_EQ(ra->processed, 5u);
  EXPECT_EQ(ra->last_error, "bad frame");
  EXPECT_EQ(errors_logged.load(), 1);
}

TEST(Pipeline, ConfigureGetsTheContextAndItsErrorsStopTheStart) {
  struct Refuses : Stage {
    std::string name() const override { return "refuses"; }
    void configure(const StageContext&) override { throw std::invalid_argument("no rig"); }
    void process(Frame&) override {}
  };
  StageContext ctx;
  ctx.rig = reinterpret_cast<const config::RigConfig*>(&ctx);  // any address: stages borrow it
  Pipeline p(ctx);
  Probe& a = p.then(std::make_unique<Probe>("a"), {});
  p.tap(std::make_unique<Refuses>(), {});
  EXPECT_THROW(p.start(), std::invalid_argument);
  EXPECT_EQ(a.rig, ctx.rig);
  EXPECT_EQ(a.calls, (std::vector<std::string>{"configure"})) << "nothing started";
  p.stop();
  EXPECT_EQ(a.calls, (std::vector<std::string>{"configure"})) << "a stage never started is not stopped";
}

TEST(Pipeline, WithoutAChainFramesGoStraightToTheConsumers) {
  Pipeline p(StageContext{});
  Probe& c = p.tap(std::make_unique<Probe>("c"), {4, Overflow::Block});
  p.start();
  for (uint64_t s = 1; s <= 3; s++) EXPECT_TRUE(p.push(frame(s)));
  p.stop();
  EXPECT_EQ(c.seqs(), range(1, 4));
  EXPECT_FALSE(p.push(frame(4))) << "stopped";
}

TEST(StageRunner, ReportsTimeInProcess) {
  auto probe = std::make_unique<Probe>("sleepy");
  probe->sleep_ms = 20;
  StageRunner r(std::move(probe), {4, Overflow::Block});
  r.configure({});
  r.start();
  r.push(frame(1));
  r.push(frame(2));
  r.stop();
  StageReport rep = r.report();
  EXPECT_EQ(rep.processed, 2u);
  EXPECT_GE(rep.busy_ms_mean, 19.0);
  EXPECT_GE(rep.busy_ms_max, rep.busy_ms_mean);
  EXPECT_EQ(rep.overflow, Overflow::Block);
  EXPECT_STREQ(overflow_name(Overflow::DropOldest), "drop-oldest");
}

// The fit's torso right for the stages before it: level and unit, never going back to an older frame,
// nothing that has no level direction; one object shared by every copy of a context.
TEST(BodyHeading, KeepsTheLatestLevelRightAndIsSharedByCopiesOfTheContext) {
  StageContext a;
  const StageContext b = a;
  EXPECT_FALSE(b.body_heading->latest().has_value());
  a.body_heading->publish(10, {3, 4, 7});
  auto h = b.body_heading->latest();
  ASSERT_TRUE(h.has_value());
  EXPECT_EQ(h->seq, 10u);
  EXPECT_DOUBLE_EQ(h->right[0], 0.6);
  EXPECT_DOUBLE_EQ(h->right[1], 0.8);
  EXPECT_DOUBLE_EQ(h->right[2], 0.0);
  a.body_heading->publish(9, {1, 0, 0});              // older: ignored
  a.body_heading->publish(11, {0, 0, 1});             // straight up: no level direction
  a.body_heading->publish(12, {std::nan(""), 1, 0});  // not finite
  EXPECT_EQ(b.body_heading->latest()->seq, 10u);
  a.body_heading->publish(13, {-2, 0, 0});
  EXPECT_EQ(b.body_heading->latest()->seq, 13u);
  EXPECT_DOUBLE_EQ(b.body_heading->latest()->right[0], -1.0);
}

// Where a frame's time went: each chain stage stamps its start and end of process() in its place in the
// chain (the context names the chain), in the order the frame went through them; consumers stamp
// nothing. TimingLog splits a frame into segments that add up to its last stage's end.
TEST(Pipeline, ChainStagesStampTheirStartAndEndInChainOrder) {
  struct Names : Stage {
    std::string name() const override { return "names"; }
    void configure(const StageContext& ctx) override { chain = ctx.chain; }
    void process(Frame&) override {}
    std::vector<std::string> chain;
  };
  Pipeline p(StageContext{});
  p.then(std::make_unique<Probe>("merge"), {4, Overflow::Block});
  p.then(std::make_unique<Probe>("fit"), {4, Overflow::Block});
  Names& n = p.tap(std::make_unique<Names>(), {4, Overflow::Block});
  p.start();
  std::vector<FramePtr> frames;
  for (uint64_t s = 1; s <= 20; s++) {
    frames.push_back(frame(s));
    ASSERT_TRUE(p.push(frames.back()));
  }
  p.stop();
  EXPECT_EQ(n.chain, (std::vector<std::string>{"merge", "fit"}));
  for (const FramePtr& f : frames) {
    EXPECT_GT(f->t_stage_start_ns[0], 0u);
    EXPECT_LE(f->t_stage_start_ns[0], f->t_stage_end_ns[0]);
    EXPECT_LE(f->t_stage_end_ns[0], f->t_stage_start_ns[1]) << "fit starts after merge ended";
    EXPECT_LE(f->t_stage_start_ns[1], f->t_stage_end_ns[1]);
    for (size_t i = 2; i < Frame::kTimedStages; i++)
      EXPECT_EQ(f->t_stage_start_ns[i], 0u) << "no stage " << i;
  }
}

TEST(TimingLog, SplitsAFrameIntoSegmentsThatAddUpAndFindsTheTail) {
  TimingLog log;
  log.set_chain({"merge", "fit"});
  auto make = [](uint64_t seq, uint64_t slow_node_ms, bool degraded) {
    Frame f;
    f.seq = seq;
    const uint64_t t0 = 1'000'000'000, ms = 1'000'000;
    f.t_trigger_ns = t0;
    for (uint16_t n : {1, 2}) {
      NodePart p;
      p.node_id = n;
      p.has_hull = !(degraded && n == 2);
      p.t_received_ns = t0 + (n == 1 ? 8 : slow_node_ms) * ms;
      f.nodes.push_back(p);
    }
    f.degraded = degraded;
    if (degraded) f.missing = {2};
    f.t_assembled_ns = t0 + (degraded ? 30 : slow_node_ms + 1) * ms;
    uint64_t t = f.t_assembled_ns;
    for (size_t i = 0; i < 2; i++) {
      f.t_stage_start_ns[i] = t + 1 * ms;
      f.t_stage_end_ns[i] = t + 3 * ms;
      t = f.t_stage_end_ns[i];
    }
    return f;
  };
  for (uint64_t seq = 0; seq < 99; seq++) EXPECT_TRUE(log.add(make(seq, 10, false)));
  EXPECT_TRUE(log.add(make(99, 10, true)));  // node 2 skipped it: waited until t + 30 ms
  Frame unstamped = make(100, 10, false);
  unstamped.t_stage_start_ns[1] = 0;
  EXPECT_FALSE(log.add(unstamped)) << "a frame that never reached fit is not split";
  const FrameTiming& r = log.rows()[0];
  EXPECT_EQ(r.hull_ms, (std::vector<std::pair<uint16_t, double>>{{1, 8.0}, {2, 10.0}}));
  EXPECT_EQ(r.segments_ms, (std::vector<double>{8, 2, 1, 1, 2, 1, 2}));
  EXPECT_DOUBLE_EQ(r.total_ms, 17.0);
  LatencySplit s = log.split();
  EXPECT_EQ(s.segments, (std::vector<std::string>{"edges", "last_node", "assembly", "merge_queue", "merge",
                                                  "fit_queue", "fit"}));
  EXPECT_EQ(s.frames, 100u);
  EXPECT_DOUBLE_EQ(s.tail_from_ms, 36.0);
  EXPECT_EQ(s.tail_frames, 1u);
  EXPECT_EQ(s.tail_degraded, 1u);
  EXPECT_DOUBLE_EQ(s.tail_mean_ms[2], 22.0) << "the degraded frame waited in the assembler";
  EXPECT_DOUBLE_EQ(s.mean_ms[0], 8.0);
}

}  // namespace
}  // namespace vc::pipeline
