// The committed vectors in proto/vectors: each .bin decodes, in any chunking, to exactly the events
// its .json lists (fields of every message, code and offset of every rejection); regenerating them
// gives byte-identical files; together they cover every message type and every error code; the RLE
// and trigger-datagram vectors hold for the library.
#include <gtest/gtest.h>

#include <unistd.h>
#include <algorithm>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <set>
#include <sstream>

#include "vectors.hpp"
#include "voxcap/auth.h"
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

// A stream's receiver-side MAC state from its "mac" object (authenticated vectors, 2.3): derived from
// the rig key, node id and nonces as a receiver derives it, and checked against the key written down.
vc_mac mac_state(const Json& m) {
  EXPECT_EQ(vc_auth_init(), 0);
  const Bytes key = unhex(m["rig_key"]), nn = unhex(m["nonce_node"]), nh = unhex(m["nonce_host"]);
  EXPECT_EQ(key.size(), size_t{VC_AUTH_KEY_SIZE});
  EXPECT_EQ(nn.size(), size_t{VC_AUTH_NONCE_SIZE});
  EXPECT_EQ(nh.size(), size_t{VC_AUTH_NONCE_SIZE});
  vc_mac n2h{}, h2n{};
  vc_auth_session(key.data(), m["node_id"].get<uint16_t>(), nn.data(), nh.data(), &n2h, &h2n);
  const vc_mac& rx = m["direction"] == "node_to_host" ? n2h : h2n;
  EXPECT_EQ(Bytes(rx.key, rx.key + VC_AUTH_KEY_SIZE), unhex(m["mac_key"]));
  vc_mac out = rx;
  out.counter = m["counter"].get<uint64_t>();
  return out;
}

// decode_events with the decoder checking MACs (vc_decoder_set_mac) from the first message on: the
// same events (offsets, messages, errors with the rejected message's type).
Json decode_events_mac(const Bytes& bytes, size_t max_payload, const vc_mac& rx,
                       const std::function<size_t(size_t)>& chunker) {
  vc_decoder* dec = nullptr;
  EXPECT_EQ(vc_decoder_new(max_payload, &dec, nullptr, 0), 0);
  EXPECT_EQ(vc_decoder_set_mac(dec, &rx), 0);
  Json events = Json::array();
  vc_msg msg{};
  bool fatal = false;
  auto drain = [&] {
    for (;;) {
      const uint64_t offset = vc_decoder_offset(dec);
      const int rc = vc_decoder_next(dec, &msg);
      if (rc == 0) return;
      Json e;
      e["offset"] = offset;
      if (rc > 0) {
        e["message"] = vc::proto::msg_to_json(msg);
      } else {
        e["error"] = vc::proto::error_to_json(*vc_decoder_diag(dec), false);
        if (!vc_proto_error_is_fatal(rc)) {
          const char* name = vc_msg_type_name(msg.hdr.type);
          e["type"] = name ? Json(name) : Json(msg.hdr.type);
        }
      }
      events.push_back(e);
      if (rc < 0 && vc_proto_error_is_fatal(rc)) {
        fatal = true;
        return;
      }
    }
  };
  size_t pos = 0;
  while (pos < bytes.size() && !fatal) {
    const size_t left = bytes.size() - pos;
    const size_t chunk = chunker ? std::clamp<size_t>(chunker(left), 1, left) : left;
    for (size_t off = 0, used = 0; off < chunk && !fatal; off += used) {
      if (vc_decoder_feed(dec, bytes.data() + pos + off, chunk - off, &used) < 0) fatal = true;
      drain();
    }
    pos += chunk;
  }
  EXPECT_EQ(vc_decoder_finish(dec), 0);
  vc_decoder_free(dec);
  return events;
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
      const Json events = expected.contains("mac")
                              ? decode_events_mac(bytes, max_payload, mac_state(expected["mac"]), chunker)
                              : vc::proto::decode_events(bytes, max_payload, chunker);
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
  for (uint16_t t = VC_MSG_HELLO; t <= VC_MSG_AUTH; t++) EXPECT_TRUE(types.count(vc_msg_type_name(t))) << t;
  EXPECT_TRUE(types.count("UNKNOWN"));
  for (int code = VC_PROTO_EORDER; code <= VC_PROTO_EMAGIC; code++)
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

// The handshake (2.3): each proof is the one the key, node id and nonces give, and only for its own
// role (a reflected proof fails); the MAC'd streams decode only with the key written down: the same
// bytes without the MAC check are refused (any other key makes the first sealed message forged).
TEST(Vectors, AuthProofsVerifyForTheirRoleOnly) {
  ASSERT_EQ(vc_auth_init(), 0);
  const Json j = Json::parse(read_text(kVectors / "auth.json"));
  ASSERT_TRUE(j.contains("auth"));
  const Json& a = j["auth"];
  const Bytes key = unhex(a["rig_key"]), nn = unhex(a["nonce_node"]), nh = unhex(a["nonce_host"]);
  const Bytes ph = unhex(a["proof_host"]), pn = unhex(a["proof_node"]);
  const uint16_t node = a["node_id"].get<uint16_t>();
  EXPECT_TRUE(vc_auth_verify(ph.data(), key.data(), VC_AUTH_ROLE_HOST, node, nn.data(), nh.data()));
  EXPECT_TRUE(vc_auth_verify(pn.data(), key.data(), VC_AUTH_ROLE_NODE, node, nn.data(), nh.data()));
  EXPECT_FALSE(vc_auth_verify(ph.data(), key.data(), VC_AUTH_ROLE_NODE, node, nn.data(), nh.data()));
  EXPECT_FALSE(vc_auth_verify(pn.data(), key.data(), VC_AUTH_ROLE_NODE, node + 1, nn.data(), nh.data()));
  // The proofs on the wire are those: RESPONSE carries the host's, PROOF the node's.
  const Json& ev = j["events"];
  ASSERT_EQ(ev.size(), 3u);
  EXPECT_EQ(ev[0]["message"]["body"]["step_name"], "challenge");
  EXPECT_EQ(unhex(ev[0]["message"]["body"]["nonce"]), nn);
  EXPECT_EQ(unhex(ev[1]["message"]["body"]["nonce"]), nh);
  EXPECT_EQ(unhex(ev[1]["message"]["body"]["proof"]), ph);
  EXPECT_EQ(unhex(ev[2]["message"]["body"]["proof"]), pn);

  const Json ms = Json::parse(read_text(kVectors / "mac_stream.json"));
  const Bytes stream = read_bytes(kVectors / "mac_stream.bin");
  vc_mac rx = mac_state(ms["mac"]);
  const Json good = decode_events_mac(stream, 0, rx, nullptr);
  ASSERT_EQ(good.size(), 4u);
  for (const Json& e : good) EXPECT_TRUE(e.contains("message")) << e.dump();
  EXPECT_EQ(good[1]["message"]["type"], "HULL");
  EXPECT_EQ(good[1]["message"]["header"]["flags"], VC_FLAG_MAC);
  rx.key[5] ^= 1;  // another key: every sealed message is forged
  for (const Json& e : decode_events_mac(stream, 0, rx, nullptr))
    EXPECT_EQ(e["error"]["code"], "VC_PROTO_EMAC") << e.dump();
}

TEST(Vectors, TriggerDatagramWithMac) {
  ASSERT_EQ(vc_auth_init(), 0);
  const Json j = Json::parse(read_text(kVectors / "trigger_mac.json"));
  const Bytes b = read_bytes(kVectors / "trigger_mac.bin");
  ASSERT_EQ(b.size(), size_t{VC_TRIGGER_DGRAM_MAC_SIZE});
  vc_mac rx{};
  vc_auth_trigger_key(unhex(j["rig_key"]).data(), &rx);
  EXPECT_EQ(Bytes(rx.key, rx.key + VC_AUTH_KEY_SIZE), unhex(j["trigger_key"]));
  uint64_t seq = 0, t = 0;
  ASSERT_EQ(vc_trigger_dgram_decode_mac(b.data(), b.size(), &rx, &seq, &t), 0);
  EXPECT_EQ(seq, j["seq"].get<uint64_t>());
  EXPECT_EQ(t, j["t_ns"].get<uint64_t>());
  EXPECT_EQ(rx.counter, j["counter"].get<uint64_t>() + 1);
  EXPECT_EQ(vc_trigger_dgram_decode_mac(b.data(), b.size(), &rx, &seq, &t), VC_PROTO_EREPLAY);
  vc_mac fresh{};
  vc_auth_trigger_key(unhex(j["rig_key"]).data(), &fresh);
  for (size_t i = 0; i < b.size(); i++) {
    if (i >= 4 && i < 6) continue;  // the version field: a changed version is -EBADMSG, not a forgery
    if (i < 4) continue;            // the magic likewise
    Bytes f = b;
    f[i] ^= 0x01;
    vc_mac r = fresh;
    EXPECT_EQ(vc_trigger_dgram_decode_mac(f.data(), f.size(), &r, &seq, &t), VC_PROTO_EMAC) << "byte " << i;
  }
}

}  // namespace
