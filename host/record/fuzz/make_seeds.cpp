// Writes the seed corpus of vc_record_fuzz into the folder given: small valid sessions (closed, cut,
// torn) in both of the fuzz target's modes (first byte 0: raw, 1: re-framed).
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "session_fixture.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR\n", argv[0]);
    return 2;
  }
  namespace t = vc::record::testing;
  const std::filesystem::path out = argv[1];
  int n = 0;
  auto emit = [&](const std::vector<uint8_t>& bytes) {
    for (uint8_t mode : {uint8_t{0}, uint8_t{1}}) {
      std::vector<uint8_t> seed{mode};
      seed.insert(seed.end(), bytes.begin(), bytes.end());
      t::write_bytes(out / ("seed" + std::to_string(n++)), seed);
    }
  };
  // 8^3 hulls keep each seed well under the target's -max_len.
  emit(t::session_bytes(t::make_session_records(0, 3, 8), true));
  emit(t::session_bytes(t::make_session_records(40, 2, 8), false));
  std::vector<uint8_t> torn = t::session_bytes(t::make_session_records(7, 2, 8), false);
  torn.resize(torn.size() - 9);
  emit(torn);
  std::vector<vc::record::Record> one{t::make_pose(1, true), t::make_stats(5, vc::record::kHostNodeId),
                                      t::make_features(2, 1, 1), t::make_frame(9, 0)};
  emit(t::session_bytes(one, true));
  return 0;
}
