// Recording throughput (Google Benchmark; figures only, nothing asserted):
//   BM_Append/<grid_n>   append one frame (a human-shaped grid_n^3 hull) + its features + pose: what the
//                        host does per merged frame, write(2) included, no fsync
//   BM_AppendFlush       the same plus fdatasync every 60 frames (the host flushes about once a second)
//   BM_OpenScan          Reader::open of a 600-frame session: validating scan, per byte
//   BM_Iterate           Reader::next over the same session
// Run: build/<preset>/bin/vc_record_bench [--benchmark_filter=...]
#include <benchmark/benchmark.h>

#include "session_fixture.hpp"
#include "voxcap/record/recorder.hpp"

namespace {

using namespace vc::record;
namespace t = vc::record::testing;

void append_loop(benchmark::State& state, int grid_n, int flush_every) {
  t::TempDir tmp;
  const t::RigFiles rig = t::write_rig_files(tmp.path());
  int session = 0;
  std::vector<FrameRecord> frames;
  for (uint64_t seq = 0; seq < 8; ++seq) frames.push_back(t::make_frame(seq, grid_n));
  const FeatureRecord features = t::make_features(1, 0, 0);
  const PoseRecord pose = t::make_pose(1, false);
  auto rec = std::make_unique<Recorder>(
      Recorder::create(tmp.path() / std::to_string(session++), rig.rig_toml, rig.calibration_yaml, ""));
  uint64_t seq = 0;
  for (auto _ : state) {
    FrameRecord& f = frames[seq % 8];
    f.seq = seq;
    rec->append(f);
    rec->append(features);
    rec->append(pose);
    if (flush_every && ++seq % flush_every == 0) rec->flush();
    if (!flush_every) ++seq;
    if (rec->bytes() > (512u << 20)) {  // keep the temp folder bounded on long runs
      state.PauseTiming();
      rec->close();
      rec = std::make_unique<Recorder>(
          Recorder::create(tmp.path() / std::to_string(session++), rig.rig_toml, rig.calibration_yaml, ""));
      state.ResumeTiming();
    }
  }
  state.counters["frame_bytes"] = static_cast<double>(frames[0].rle.size());
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  rec->close();
}

void BM_Append(benchmark::State& state) {
  append_loop(state, static_cast<int>(state.range(0)), 0);
}
BENCHMARK(BM_Append)->Arg(64)->Arg(128)->Arg(256)->Unit(benchmark::kMicrosecond);

void BM_AppendFlush(benchmark::State& state) {
  append_loop(state, 128, 60);
}
BENCHMARK(BM_AppendFlush)->Unit(benchmark::kMicrosecond);

struct Session {
  t::TempDir tmp;
  std::filesystem::path dir;
  Session() {
    const t::RigFiles rig = t::write_rig_files(tmp.path());
    dir = tmp.path() / "s";
    Recorder rec = Recorder::create(dir, rig.rig_toml, rig.calibration_yaml, "");
    for (const Record& r : t::make_session_records(0, 600, 128)) t::append(rec, r);
    rec.close();
  }
};

void BM_OpenScan(benchmark::State& state) {
  Session s;
  uint64_t bytes = 0;
  for (auto _ : state) {
    Reader reader = Reader::open(s.dir);
    bytes = reader.summary_ref().file_bytes;
    benchmark::DoNotOptimize(reader.summary_ref().frames);
  }
  state.SetBytesProcessed(static_cast<int64_t>(bytes * state.iterations()));
}
BENCHMARK(BM_OpenScan)->Unit(benchmark::kMillisecond);

void BM_Iterate(benchmark::State& state) {
  Session s;
  Reader reader = Reader::open(s.dir);
  Record r;
  for (auto _ : state) {
    reader.rewind();
    uint64_t n = 0;
    while (reader.next(r)) ++n;
    benchmark::DoNotOptimize(n);
  }
  state.SetBytesProcessed(static_cast<int64_t>(reader.summary_ref().file_bytes * state.iterations()));
}
BENCHMARK(BM_Iterate)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
