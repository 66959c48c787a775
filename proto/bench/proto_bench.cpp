// Micro-benchmarks of the per-frame protocol work, on human-shaped partial hulls (tests/hull_shapes):
// RLE encode (the edge, every frame), decode, AND of two partial hulls and popcount (the host, every
// frame and node), the host's merge of N partial hulls (a chain of pairwise ANDs vs vc_rle_and_n),
// CRC32C, a whole HULL encoded from a bitset and decoded by the stream decoder.
// Time per iteration is time per frame. Run: proto_bench [--benchmark_filter=...].
#include <benchmark/benchmark.h>

#include <cmath>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <tuple>
#include <vector>

#include "hull_shapes.hpp"
#include "voxcap/auth.h"
#include "voxcap/crc32c.h"
#include "voxcap/proto.h"
#include "voxcap/rle.h"

namespace {

using vc::proto::testing::Bitset;
using Bytes = std::vector<uint8_t>;

// Two partial hulls of one pose (the body extruded along x and along y, as two nodes at right angles
// would see it), cached per grid size.
struct Hulls {
  Bitset a, b;
  Bytes rle_a, rle_b;
};

Bytes encode(const Bitset& bits) {
  Bytes out(vc_rle_max_encoded_size(bits.nbits));
  size_t len = 0;
  if (vc_rle_encode(bits.bytes.data(), bits.nbits, out.data(), out.size(), &len) != 0) std::abort();
  out.resize(len);
  return out;
}

const Hulls& hulls(int n) {
  static std::map<int, std::unique_ptr<Hulls>> cache;
  auto& h = cache[n];
  if (!h) {
    h = std::make_unique<Hulls>();
    const Bitset body = vc::proto::testing::human_hull(n, 7);
    h->a = vc::proto::testing::extrude(body, n, 0);
    h->b = vc::proto::testing::extrude(body, n, 1);
    h->rle_a = encode(h->a);
    h->rle_b = encode(h->b);
  }
  return *h;
}

void set_counters(benchmark::State& state, const Hulls& h) {
  vc_rle_info info{};
  vc_rle_inspect(h.rle_a.data(), h.rle_a.size(), &info);
  state.counters["voxels"] = static_cast<double>(h.a.nbits);
  state.counters["runs"] = static_cast<double>(info.runs);
  state.counters["rle_bytes"] = static_cast<double>(h.rle_a.size());
}

void BM_RleEncode(benchmark::State& state) {
  const Hulls& h = hulls(static_cast<int>(state.range(0)));
  Bytes out(vc_rle_max_encoded_size(h.a.nbits));
  for ([[maybe_unused]] auto _ : state) {
    size_t len = 0;
    benchmark::DoNotOptimize(vc_rle_encode(h.a.bytes.data(), h.a.nbits, out.data(), out.size(), &len));
    benchmark::DoNotOptimize(out.data());
  }
  set_counters(state, h);
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * h.a.bytes.size()));
}
BENCHMARK(BM_RleEncode)->Arg(128)->Arg(256)->Unit(benchmark::kMicrosecond);

void BM_RleDecode(benchmark::State& state) {
  const Hulls& h = hulls(static_cast<int>(state.range(0)));
  Bytes bits(h.a.bytes.size());
  for ([[maybe_unused]] auto _ : state) {
    benchmark::DoNotOptimize(vc_rle_decode(h.rle_a.data(), h.rle_a.size(), bits.data(), h.a.nbits));
    benchmark::DoNotOptimize(bits.data());
  }
  set_counters(state, h);
}
BENCHMARK(BM_RleDecode)->Arg(128)->Arg(256)->Unit(benchmark::kMicrosecond);

void BM_RleAnd(benchmark::State& state) {
  const Hulls& h = hulls(static_cast<int>(state.range(0)));
  Bytes out(h.rle_a.size() + h.rle_b.size() + 16);
  for ([[maybe_unused]] auto _ : state) {
    size_t len = 0;
    benchmark::DoNotOptimize(vc_rle_and(h.rle_a.data(), h.rle_a.size(), h.rle_b.data(), h.rle_b.size(),
                                        out.data(), out.size(), &len));
    benchmark::DoNotOptimize(out.data());
  }
  set_counters(state, h);
}
BENCHMARK(BM_RleAnd)->Arg(128)->Arg(256)->Unit(benchmark::kMicrosecond);

// The same intersection the plain way, for comparison: AND of the two bitsets, then encode.
void BM_BitsetAndThenEncode(benchmark::State& state) {
  const Hulls& h = hulls(static_cast<int>(state.range(0)));
  Bytes both(h.a.bytes.size()), out(vc_rle_max_encoded_size(h.a.nbits));
  for ([[maybe_unused]] auto _ : state) {
    for (size_t i = 0; i < both.size(); i++) both[i] = h.a.bytes[i] & h.b.bytes[i];
    size_t len = 0;
    benchmark::DoNotOptimize(vc_rle_encode(both.data(), h.a.nbits, out.data(), out.size(), &len));
  }
}
BENCHMARK(BM_BitsetAndThenEncode)->Arg(128)->Arg(256)->Unit(benchmark::kMicrosecond);

// N streams of one size for the merge benchmarks, cached per (kind, grid, nodes):
//   kind 0: a ring of nodes, the body extruded from horizontal directions pi*k/nodes (real hulls);
//   kind 1: independent bitsets, 97 % occupied in runs of mean 32 (many runs survive the AND: the
//           worst case for the N-way walk's O(nodes) work per output run).
struct Streams {
  std::vector<Bytes> rle;
  std::vector<const uint8_t*> ptrs;
  std::vector<size_t> lens;
  size_t nbits = 0, in_runs = 0, out_bytes = 0;
};

const Streams& streams(int kind, int grid, int nodes) {
  static std::map<std::tuple<int, int, int>, std::unique_ptr<Streams>> cache;
  auto& st = cache[{kind, grid, nodes}];
  if (!st) {
    st = std::make_unique<Streams>();
    const Bitset body = vc::proto::testing::human_hull(grid, 7);
    std::mt19937_64 rng(static_cast<uint64_t>(grid * 100 + nodes));
    std::geometric_distribution<size_t> empty_len(1.0), occ_len(1.0 / 32);
    for (int k = 0; k < nodes; k++) {
      Bitset b(body.nbits);
      if (kind == 0) {
        b = vc::proto::testing::extrude_horizontal(body, grid, M_PI * k / nodes);
      } else {
        for (size_t pos = 0; pos < b.nbits;) {
          pos += empty_len(rng) + 1;
          for (size_t end = std::min(b.nbits, pos + occ_len(rng) + 1); pos < end; pos++) b.set(pos);
        }
      }
      st->rle.push_back(encode(b));
      vc_rle_info info{};
      vc_rle_inspect(st->rle.back().data(), st->rle.back().size(), &info);
      st->in_runs += info.runs;
    }
    for (const Bytes& r : st->rle) {
      st->ptrs.push_back(r.data());
      st->lens.push_back(r.size());
    }
    st->nbits = body.nbits;
    Bytes out(vc_rle_max_encoded_size(st->nbits));
    if (vc_rle_and_n(st->ptrs.data(), st->lens.data(), st->ptrs.size(), out.data(), out.size(),
                     &st->out_bytes))
      std::abort();
  }
  return *st;
}

void merge_counters(benchmark::State& state, const Streams& st) {
  state.counters["in_runs"] = static_cast<double>(st.in_runs);
  state.counters["in_bytes"] =
      static_cast<double>(std::accumulate(st.lens.begin(), st.lens.end(), size_t{0}));
  state.counters["out_bytes"] = static_cast<double>(st.out_bytes);
}

// The merge as host/assemble did it before vc_rle_and_n: vc_rle_and over the running result,
// ping-ponging between two buffers (no copies, so this is the chain at its best).
void BM_MergeChain(benchmark::State& state) {
  const Streams& st = streams(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)),
                              static_cast<int>(state.range(2)));
  const size_t cap = vc_rle_max_encoded_size(st.nbits);
  Bytes bufs[2] = {Bytes(cap), Bytes(cap)};
  for ([[maybe_unused]] auto _ : state) {
    const uint8_t* acc = st.ptrs[0];
    size_t acc_len = st.lens[0];
    for (size_t i = 1; i < st.ptrs.size(); i++) {
      Bytes& dst = bufs[i & 1];
      size_t len = 0;
      if (vc_rle_and(acc, acc_len, st.ptrs[i], st.lens[i], dst.data(), dst.size(), &len)) std::abort();
      acc = dst.data();
      acc_len = len;
    }
    benchmark::DoNotOptimize(acc_len);
    benchmark::ClobberMemory();
  }
  merge_counters(state, st);
}

void BM_MergeN(benchmark::State& state) {
  const Streams& st = streams(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)),
                              static_cast<int>(state.range(2)));
  Bytes out(vc_rle_max_encoded_size(st.nbits));
  for ([[maybe_unused]] auto _ : state) {
    size_t len = 0;
    if (vc_rle_and_n(st.ptrs.data(), st.lens.data(), st.ptrs.size(), out.data(), out.size(), &len))
      std::abort();
    benchmark::DoNotOptimize(len);
    benchmark::ClobberMemory();
  }
  merge_counters(state, st);
}

// Args: kind (0 ring of nodes, 1 dense random), grid n (n^3 voxels), nodes.
void merge_args(benchmark::internal::Benchmark* b) {
  b->ArgNames({"kind", "grid", "nodes"});
  for (int grid : {128, 256})
    for (int nodes : {2, 3, 4, 8, 16}) b->Args({0, grid, nodes});
  for (int nodes : {2, 3, 4, 8, 16}) b->Args({1, 128, nodes});
}
BENCHMARK(BM_MergeChain)->Apply(merge_args)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_MergeN)->Apply(merge_args)->Unit(benchmark::kMicrosecond);

void BM_RlePopcount(benchmark::State& state) {
  const Hulls& h = hulls(static_cast<int>(state.range(0)));
  for ([[maybe_unused]] auto _ : state) {
    uint64_t occ = 0, total = 0;
    benchmark::DoNotOptimize(vc_rle_popcount(h.rle_a.data(), h.rle_a.size(), &occ, &total));
    benchmark::DoNotOptimize(occ);
  }
}
BENCHMARK(BM_RlePopcount)->Arg(128)->Arg(256)->Unit(benchmark::kMicrosecond);

void BM_Crc32c(benchmark::State& state) {
  Bytes data(static_cast<size_t>(state.range(0)), 0x5A);
  for ([[maybe_unused]] auto _ : state) benchmark::DoNotOptimize(vc_crc32c(0, data.data(), data.size()));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * data.size()));
  state.SetLabel(vc_crc32c_impl());
}
BENCHMARK(BM_Crc32c)->Arg(64 << 10)->Arg(1 << 20);

void BM_Crc32cPortable(benchmark::State& state) {
  Bytes data(static_cast<size_t>(state.range(0)), 0x5A);
  for ([[maybe_unused]] auto _ : state)
    benchmark::DoNotOptimize(vc_crc32c_portable(0, data.data(), data.size()));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * data.size()));
}
BENCHMARK(BM_Crc32cPortable)->Arg(64 << 10)->Arg(1 << 20);

// The edge's whole per-frame protocol cost: HULL message from the carved bitset (RLE + both CRCs).
void BM_EncodeHullFromBits(benchmark::State& state) {
  const Hulls& h = hulls(static_cast<int>(state.range(0)));
  Bytes msg(VC_PROTO_HEADER_SIZE + 24 + vc_rle_max_encoded_size(h.a.nbits));
  vc_header hdr{};
  hdr.node_id = 1;
  for ([[maybe_unused]] auto _ : state) {
    size_t len = 0;
    hdr.seq++;
    benchmark::DoNotOptimize(
        vc_encode_hull_bits(msg.data(), msg.size(), &len, &hdr, 1, h.a.bytes.data(), h.a.nbits));
  }
}
BENCHMARK(BM_EncodeHullFromBits)->Arg(128)->Arg(256)->Unit(benchmark::kMicrosecond);

// The host's per-node, per-frame receive cost: feed one HULL in 64 KiB chunks, decode and validate.
void BM_DecodeHullStream(benchmark::State& state) {
  const Hulls& h = hulls(static_cast<int>(state.range(0)));
  Bytes msg(VC_PROTO_HEADER_SIZE + 24 + h.rle_a.size());
  vc_header hdr{};
  size_t len = 0;
  if (vc_encode_hull_bits(msg.data(), msg.size(), &len, &hdr, 1, h.a.bytes.data(), h.a.nbits) != 0)
    std::abort();
  vc_decoder* dec = nullptr;
  if (vc_decoder_new(0, &dec, nullptr, 0) < 0) std::abort();
  auto out = std::make_unique<vc_msg>();
  for ([[maybe_unused]] auto _ : state) {
    for (size_t off = 0; off < len;) {
      size_t used = 0;
      vc_decoder_feed(dec, msg.data() + off, std::min<size_t>(len - off, 64 << 10), &used);
      off += used;
      while (vc_decoder_next(dec, out.get()) > 0) benchmark::DoNotOptimize(out->u.hull.occupied_count);
    }
  }
  vc_decoder_free(dec);
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * len));
}
BENCHMARK(BM_DecodeHullStream)->Arg(128)->Arg(256)->Unit(benchmark::kMicrosecond);

// Authenticated control (2.3): the per-message MAC of one HULL, sealing on the edge (copy into the send
// buffer not included) and checking on the host. The counter says ns per HULL message.
void BM_HullMacSeal(benchmark::State& state) {
  const Hulls& h = hulls(static_cast<int>(state.range(0)));
  Bytes msg(VC_PROTO_HEADER_SIZE + 24 + h.rle_a.size() + VC_AUTH_TRAILER_SIZE);
  vc_header hdr{};
  size_t len = 0, sealed = 0;
  if (vc_encode_hull_bits(msg.data(), msg.size(), &len, &hdr, 1, h.a.bytes.data(), h.a.nbits) != 0)
    std::abort();
  vc_mac tx{};
  for ([[maybe_unused]] auto _ : state) {
    msg[8] = msg[9] =
        0;  // unsealed again: the same message each time (CRCs left as sealed: not checked here)
    const uint32_t plen = static_cast<uint32_t>(len - VC_PROTO_HEADER_SIZE);
    for (int i = 0; i < 4; i++) msg[12 + static_cast<size_t>(i)] = static_cast<uint8_t>(plen >> (8 * i));
    benchmark::DoNotOptimize(vc_mac_seal(&tx, msg.data(), len, msg.size(), &sealed));
  }
  state.counters["payload_bytes"] = static_cast<double>(len - VC_PROTO_HEADER_SIZE);
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * len));
}
BENCHMARK(BM_HullMacSeal)->Arg(128)->Arg(256);

void BM_HullMacOpen(benchmark::State& state) {
  const Hulls& h = hulls(static_cast<int>(state.range(0)));
  Bytes msg(VC_PROTO_HEADER_SIZE + 24 + h.rle_a.size() + VC_AUTH_TRAILER_SIZE);
  vc_header hdr{};
  size_t len = 0, sealed = 0;
  if (vc_encode_hull_bits(msg.data(), msg.size(), &len, &hdr, 1, h.a.bytes.data(), h.a.nbits) != 0)
    std::abort();
  vc_mac tx{}, rx{};
  if (vc_mac_seal(&tx, msg.data(), len, msg.size(), &sealed) != 0) std::abort();
  for ([[maybe_unused]] auto _ : state) {
    rx.counter = 0;
    benchmark::DoNotOptimize(vc_mac_open(&rx, msg.data(), sealed, nullptr));
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * sealed));
}
BENCHMARK(BM_HullMacOpen)->Arg(128)->Arg(256);

}  // namespace

BENCHMARK_MAIN();
