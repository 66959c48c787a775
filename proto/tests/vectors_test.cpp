// The committed vectors in proto/vectors: each .bin decodes, in any chunking, to exactly the events
// its .json lists (fields of every message, code and offset of every rejection); regenerating them
// gives byte-identical files; together they cover every message type and every error code; the RLE
// and trigger-datagram vectors hold for the library.
#include <gtest/gtest.h>

#include <unistd.h>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>

#include "vectors.hpp"
#include "voxcap/proto.h"
#include "voxcap/proto_json.hpp"
#include "voxcap/rle.h"

namespace {

namespace fs = std::filesystem;
using vc::proto::Json;
using Bytes = std::vector<uint8_t>;

const fs::path kVectors = PROTO_VECTORS_DIR;

std::string read_text(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

Bytes read_bytes(const fs::path& p) {
  std::string s = read_text(p);
  return Bytes(s.begin(), s.end());
}

Bytes unhex(const std::string& h) {
  Bytes b;
  for (size_t i = 0; i + 1 < h.size(); i += 2)
    b.push_back(static_cast<uint8_t>(std::stoi(h.substr(i, 2), nullptr, 16)));
  return b;
}

// Stream vectors: every .json with "events".
std::vector<std::string> stream_vectors() {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(kVectors)) {
    if (e.path().extension() != ".json") continue;
    if (Json::parse(read_text(e.path())).contains("events")) names.push_back(e.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

TEST(Vectors, ThereAreVectors) {
  EXPECT_GE(stream_vectors().size(), 30u);
}

TEST(Vectors, EveryStreamDecodesToItsEventsInAnyChunking) {
  std::mt19937_64 rng(42);
  for (const std::string& name : stream_vectors()) {
    SCOPED_TRACE(name);
    const Json expected = Json::parse(read_text(kVectors / (name + ".json")));
    const Bytes bytes = read_bytes(kVectors / (name + ".bin"));
    const size_t max_payload = expected["max_payload"].get<size_t>();
    const std::vector<std::pair<const char*, std::function<size_t(size_t)>>> chunkers = {
        {"whole", nullptr},
        {"1 byte", [](size_t) { return size_t{1}; }},
        {"3 bytes", [](size_t) { return size_t{3}; }},
        {"header-sized", [](size_t) { return size_t{VC_PROTO_HEADER_SIZE}; }},
        {"random", [&](size_t left) { return size_t{1} + rng() % left; }},
    };
    for (const auto& [what, chunker] : chunkers) {
      SCOPED_TRACE(what);
      const Json events = vc::proto::decode_events(bytes, max_payload, chunker);
      EXPECT_EQ(events, expected["events"]) << "got:\n" << events.dump(2);
    }
  }
}

TEST(Vectors, CoverEveryMessageTypeAndEveryErrorCode) {
  std::set<std::string> types, codes;
  for (const std::string& name : stream_vectors()) {
    const Json j = Json::parse(read_text(kVectors / (name + ".json")));
    for (const Json& e : j["events"]) {
      if (e.contains("message")) types.insert(e["message"]["type"].get<std::string>());
      if (e.contains("error")) codes.insert(e["error"]["code"].get<std::string>());
    }
  }
  for (uint16_t t = VC_MSG_HELLO; t <= VC_MSG_ERROR; t++) EXPECT_TRUE(types.count(vc_msg_type_name(t))) << t;
  EXPECT_TRUE(types.count("UNKNOWN"));
  for (int code = VC_PROTO_EFIELD; code <= VC_PROTO_EMAGIC; code++)
    EXPECT_TRUE(codes.count(vc_proto_error_name(code))) << vc_proto_error_name(code);
}

TEST(Vectors, RegeneratingGivesByteIdenticalFiles) {
  // Unique per process: several build trees may run this test at once.
  const fs::path out = fs::path(testing::TempDir()) / ("voxcap_proto_vectors_" + std::to_string(getpid()));
  fs::remove_all(out);
  const auto written = vc::proto::vectors::write_all(out);
  std::vector<std::string> committed;
  for (const auto& e : fs::directory_iterator(kVectors)) committed.push_back(e.path().filename().string());
  std::sort(committed.begin(), committed.end());
  EXPECT_EQ(written, committed) << "run `vc_proto_vectors proto/vectors` and commit the result";
  for (const std::string& f : written)
    EXPECT_TRUE(read_text(out / f) == read_text(kVectors / f)) << f << " differs from the generator's output";
  fs::remove_all(out);
}

int errno_code(const std::string& name) {
  if (name == "EBADMSG") return -EBADMSG;
  if (name == "EINVAL") return -EINVAL;
  ADD_FAILURE() << "unknown errno name " << name;
  return 0;
}

TEST(Vectors, Rle) {
  const Json j = Json::parse(read_text(kVectors / "rle.json"));
  ASSERT_FALSE(j["valid"].empty());
  for (const Json& v : j["valid"]) {
    SCOPED_TRACE(v["name"].get<std::string>());
    const size_t nbits = v["nbits"].get<size_t>();
    const Bytes bits = unhex(v["bits"]), rle = unhex(v["rle"]);
    const Bytes input = v.contains("encode_input") ? unhex(v["encode_input"]) : bits;
    Bytes out(vc_rle_max_encoded_size(nbits) + 1);
    size_t len = 0;
    ASSERT_EQ(vc_rle_encode(input.data(), nbits, out.data(), out.size(), &len), 0);
    out.resize(len);
    EXPECT_EQ(out, rle);
    Bytes back(bits.size() + 1, 0xEE);
    ASSERT_EQ(vc_rle_decode(rle.data(), rle.size(), back.data(), nbits), 0);
    back.resize(bits.size());
    EXPECT_EQ(back, bits);
    uint64_t occupied = 0, total = 0;
    ASSERT_EQ(vc_rle_popcount(rle.data(), rle.size(), &occupied, &total), 0);
    EXPECT_EQ(occupied, v["occupied"].get<uint64_t>());
    EXPECT_EQ(total, nbits);
  }
  for (const Json& v : j["invalid"]) {
    SCOPED_TRACE(v["name"].get<std::string>());
    const Bytes rle = unhex(v["rle"]);
    const size_t nbits = v["nbits"].get<size_t>();
    Bytes bits(nbits / 8 + 1);
    EXPECT_EQ(vc_rle_decode(rle.data(), rle.size(), bits.data(), nbits), errno_code(v["error"]));
  }
}

TEST(Vectors, TriggerDatagram) {
  const Json j = Json::parse(read_text(kVectors / "trigger.json"));
  const Bytes b = read_bytes(kVectors / "trigger.bin");
  uint64_t seq = 0, t = 0;
  ASSERT_EQ(vc_trigger_dgram_decode(b.data(), b.size(), &seq, &t), 0);
  EXPECT_EQ(seq, j["seq"].get<uint64_t>());
  EXPECT_EQ(t, j["t_ns"].get<uint64_t>());
  Bytes again(VC_TRIGGER_DGRAM_SIZE);
  ASSERT_EQ(vc_trigger_dgram_encode(again.data(), seq, t), 0);
  EXPECT_EQ(again, b);
  const Json bj = Json::parse(read_text(kVectors / "trigger_bad_version.json"));
  const Bytes bad = read_bytes(kVectors / "trigger_bad_version.bin");
  EXPECT_EQ(vc_trigger_dgram_decode(bad.data(), bad.size(), &seq, &t), errno_code(bj["error"]));
}

}  // namespace
