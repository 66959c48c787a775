#include "session_fixture.hpp"

#include <unistd.h>

#include <array>
#include <cmath>
#include <fstream>
#include <mutex>
#include <stdexcept>

#include "hull_shapes.hpp"
#include "voxcap/record/format.hpp"
#include "voxcap/rle.h"

namespace vc::record::testing {
namespace fs = std::filesystem;

TempDir::TempDir() {
  std::string tmpl = (fs::temp_directory_path() / "voxcap-record-XXXXXX").string();
  if (!::mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed");
  path_ = tmpl;
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

RigFiles write_rig_files(const fs::path& dir, const std::string& name) {
  RigFiles f{dir / (name + ".toml"), dir / (name + ".yaml")};
  std::ofstream(f.rig_toml)
      << "# test rig\nversion = 1\nname = \"" << name << "\"\ncalibration = \"" << name
      << ".yaml\"\n\n[grid]\nmin_m = [-1.0, -1.0, 0.0]\nvoxel_m = 0.125\nnx = 16\nny = 16\nnz = 16\n"
      << "\n[[nodes]]\nid = \"front0\"\ncameras = [\"cam0\", \"cam1\"]\nrole = \"front\"\n"
      << "\n[[nodes]]\nid = \"side1\"\ncameras = [\"cam2\", \"cam3\"]\n"
      << "\n[[nodes]]\nid = \"side2\"\ncameras = [\"cam4\", \"cam5\"]\n";
  std::ofstream(f.calibration_yaml) << "%YAML:1.0\n---\nformat: voxcap-rig\nversion: 1\ncameras: []\n";
  return f;
}

std::vector<uint8_t> hull_rle(int grid_n, uint64_t seed, uint64_t* occupied) {
  const proto::testing::Bitset bits = proto::testing::human_hull(grid_n, seed);
  std::vector<uint8_t> rle(vc_rle_max_encoded_size(bits.nbits));
  size_t len = 0;
  if (vc_rle_encode(bits.bytes.data(), bits.nbits, rle.data(), rle.size(), &len) != 0)
    throw std::runtime_error("vc_rle_encode failed");
  rle.resize(len);
  if (occupied) *occupied = bits.count();
  return rle;
}

namespace {

struct Hull {
  std::vector<uint8_t> rle;
  uint64_t occupied = 0;
};

// Hulls are the slow part of building records: cache 8 poses per grid size.
const Hull& cached_hull(int grid_n, uint64_t pose) {
  static std::mutex mu;
  static std::vector<std::pair<int, std::array<Hull, 8>>> cache;
  std::lock_guard lock(mu);
  for (auto& [n, hulls] : cache)
    if (n == grid_n) return hulls[pose % 8];
  std::array<Hull, 8> hulls;
  for (uint64_t i = 0; i < 8; ++i) hulls[i].rle = hull_rle(grid_n, 1000 + i, &hulls[i].occupied);
  cache.emplace_back(grid_n, std::move(hulls));
  return cache.back().second[pose % 8];
}

}  // namespace

FrameRecord make_frame(uint64_t seq, int grid_n) {
  FrameRecord f;
  f.seq = seq;
  f.t_trigger_ns = 1'000'000'000 + seq * 16'666'667;
  f.t_merged_ns = f.t_trigger_ns + 2'000'000 + (seq % 5) * 100'000;
  f.grid_id = 7;
  f.degraded = seq % 7 == 3;
  f.nodes_present = f.degraded ? std::vector<uint16_t>{0, 1} : std::vector<uint16_t>{0, 1, 2};
  if (f.degraded) f.nodes_missing = {2};
  if (grid_n > 0) {
    const Hull& h = cached_hull(grid_n, seq);
    f.voxel_count = static_cast<uint64_t>(grid_n) * grid_n * grid_n;
    f.occupied = h.occupied;
    f.rle = h.rle;
  }
  return f;
}

FeatureRecord make_features(uint64_t seq, uint16_t node_id, uint16_t camera) {
  FeatureRecord r;
  r.seq = seq;
  r.node_id = node_id;
  r.camera = camera;
  for (uint16_t id = 0; id < 5; ++id) {
    const double phase = 0.05 * static_cast<double>(seq) + id;
    r.features.push_back(
        {id, static_cast<uint16_t>((seq + id) % 3), static_cast<float>(320 + 100 * std::sin(phase)),
         static_cast<float>(240 + 80 * std::cos(phase)), static_cast<float>(0.5 + 0.1 * id)});
  }
  if (seq % 11 == 5) r.features[4].u = r.features[4].v = std::nanf("");  // a lost feature
  return r;
}

PoseRecord make_pose(uint64_t seq, bool with_names) {
  static const std::vector<std::string> kJoints = {"head",    "neck",       "pelvis",  "l_shoulder",
                                                   "l_wrist", "r_shoulder", "r_wrist", "l_hip",
                                                   "l_ankle", "r_hip",      "r_ankle"};
  PoseRecord p;
  p.seq = seq;
  p.layout = "positions_xyz_m";
  if (with_names) p.joint_names = kJoints;
  for (size_t j = 0; j < kJoints.size(); ++j)
    for (int c = 0; c < 3; ++c) p.values.push_back(0.001 * static_cast<double>(seq) + 0.1 * j + 0.01 * c);
  return p;
}

StatsRecord make_stats(uint64_t t_ns, uint16_t node_id) {
  return {t_ns, node_id,
          "{\"fps\": 60.0, \"dropped\": " + std::to_string(t_ns % 17) +
              ", \"node\": " + std::to_string(node_id) + "}"};
}

std::vector<Record> make_session_records(uint64_t first_seq, size_t frames, int grid_n) {
  std::vector<Record> out;
  for (uint64_t seq = first_seq; seq < first_seq + frames; ++seq) {
    out.emplace_back(make_frame(seq, grid_n));
    out.emplace_back(make_features(seq, 0, 0));
    out.emplace_back(make_features(seq, 0, 1));
    out.emplace_back(make_pose(seq, seq == first_seq));
    if (seq % 10 == 9)
      out.emplace_back(make_stats(make_frame(seq, 0).t_merged_ns, static_cast<uint16_t>(seq % 3)));
  }
  return out;
}

void append(Recorder& recorder, const Record& record) {
  std::visit([&recorder](const auto& r) { recorder.append(r); }, record);
}

bool same_record(const Record& a, const Record& b) {
  if (a.index() != b.index()) return false;
  std::vector<uint8_t> ea, eb;
  std::visit([&ea](const auto& r) { format::encode(r, 0, ea); }, a);
  std::visit([&eb](const auto& r) { format::encode(r, 0, eb); }, b);
  return ea == eb;
}

std::vector<uint8_t> session_bytes(const std::vector<Record>& records, bool close) {
  TempDir tmp;
  const RigFiles rig = write_rig_files(tmp.path());
  Recorder rec = Recorder::create(tmp.path() / "session", rig.rig_toml, rig.calibration_yaml, "{}");
  for (const Record& r : records) append(rec, r);
  if (close) rec.close();
  return read_bytes(tmp.path() / "session" / "records.vcr");
}

std::vector<uint64_t> record_offsets(std::span<const uint8_t> bytes) {
  std::vector<uint64_t> offsets;
  uint64_t off = 0;
  while (off + format::kHeaderBytes <= bytes.size()) {
    format::Header h;
    if (!format::decode_header(bytes.data() + off, &h, nullptr))
      throw std::runtime_error("bad record header");
    offsets.push_back(off);
    off += format::kHeaderBytes + h.body_bytes + format::kTrailerBytes;
  }
  if (off != bytes.size()) throw std::runtime_error("records.vcr does not end on a record boundary");
  offsets.push_back(off);
  return offsets;
}

std::vector<uint8_t> read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const fs::path& path, std::span<const uint8_t> bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace vc::record::testing
