// Blender, where users take BVH (label client): `voxcap export`'s take.bvh imported headless with
// Blender's stock importer (blender -b --python blender_check.py): joint count, frame count, frame time
// and the world positions of the hips, wrists and ankles against joints.csv within 1 mm. Skips with a
// message when blender is not installed (deploy/install-deps.sh installs Debian's).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "truth_session.hpp"

namespace vc::testing {
namespace {

namespace fs = std::filesystem;

std::string find_blender() {
  if (const char* b = std::getenv("VOXCAP_BLENDER"); b && *b) return b;
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "";
  size_t start = 0;
  while (start <= dirs.size()) {
    const size_t end = dirs.find(':', start);
    const fs::path p = fs::path(dirs.substr(start, end - start)) / "blender";
    std::error_code ec;
    if (fs::exists(p, ec)) return p.string();
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return "";
}

TEST(Blender, ImportsTheExportedBvhWithTheStockImporter) {
  const std::string blender = find_blender();
  if (blender.empty())
    GTEST_SKIP()
        << "blender is not installed (Debian: apt-get install blender; deploy/install-deps.sh does it)";
  char t[] = "/tmp/voxcap-blender-XXXXXX";
  const fs::path tmp = mkdtemp(t);
  TruthSessionOptions o;
  o.motion = "wave";
  o.frames = 90;
  o.init_frames = 3;
  o.rate_hz = 50;
  write_truth_session(tmp / "s", o);
  const CommandResult e =
      run(std::string("'") + VOXCAP_BINARY + "' export '" + (tmp / "s").string() + "' --bvh '" +
              (tmp / "take.bvh").string() + "' --csv '" + (tmp / "joints.csv").string() + "'",
          tmp);
  ASSERT_EQ(e.code, 0) << e.err;
  const JointsCsv csv = read_joints_csv(tmp / "joints.csv");
  const int64_t first = csv.p.begin()->first;
  const std::vector<int> ks = {0, 1, 30, 57, 86};  // take frames (joints.csv frame = first + k)
  std::string cmd = "'" + blender + "' -b --factory-startup --python '" + VOXCAP_SOURCE_DIR +
                    "/tests/client/blender_check.py' -- '" + (tmp / "take.bvh").string() + "' '" +
                    (tmp / "blender.json").string() + "'";
  for (int k : ks) cmd += " " + std::to_string(k);
  const CommandResult b = run(cmd, tmp);
  ASSERT_EQ(b.code, 0) << b.out << b.err;
  std::ifstream f(tmp / "blender.json");
  ASSERT_TRUE(f) << "blender wrote no result:\n" << b.out << b.err;
  const nlohmann::json j = nlohmann::json::parse(f);
  RecordProperty("blender", j["blender"].get<std::string>());
  EXPECT_EQ(j["bones"].size(), 18u) << j["bones"].dump();  // every named joint; End Sites are bone tails
  EXPECT_EQ(j["bones"][0], "Hips");
  EXPECT_EQ(j["action_frames"], 87) << "keyframes per channel: one per take frame";
  EXPECT_EQ(j["action_range"][1].get<double>() - j["action_range"][0].get<double>() + 1, 87);
  EXPECT_NEAR(j["fps_base"].get<double>() / j["fps"].get<double>(), 1.0 / 50, 1e-9);
  for (int k : ks) {
    for (const char* joint : {"Hips", "LeftHand", "RightHand", "LeftFoot", "RightFoot"}) {
      const auto& got = j["frames"][std::to_string(k)][joint];
      ASSERT_EQ(got.size(), 3u) << k << " " << joint;
      const glm::dvec3 p(got[0].get<double>(), got[1].get<double>(), got[2].get<double>());
      EXPECT_LT(glm::length(p - csv.p.at(first + k).at(joint)), 1e-3) << "take frame " << k << " " << joint;
    }
  }
  std::error_code ec;
  fs::remove_all(tmp, ec);
}

}  // namespace
}  // namespace vc::testing
