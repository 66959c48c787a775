// The files `voxcap sim` writes: names, contents equal to the in-process renderer, and the 2D
// truth equal to the projection of the 3D truth with the written rig.yaml (within 0.01 px).
#include "voxcap/sim/dataset.hpp"

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "voxcap/body/bvh.hpp"

namespace vc::sim {
namespace {

namespace fs = std::filesystem;

std::vector<std::vector<std::string>> read_csv(const fs::path& p, std::string* header) {
  std::ifstream f(p);
  std::string line;
  std::getline(f, *header);
  std::vector<std::vector<std::string>> rows;
  while (std::getline(f, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    rows.push_back(cells);
  }
  return rows;
}

TEST(SimDataset, WritesTheDocumentedLayoutAndConsistentTruth) {
  SceneOptions o;
  o.motion.source = "wave";
  o.motion.lead_hold_s = 0.1;
  o.motion.lead_blend_s = 0.1;
  o.rig.cameras = 3;
  o.rig.width = 120;
  o.rig.height = 90;
  o.rig.distortion = true;
  o.seed = 9;
  const Scene scene(o);
  const fs::path dir = fs::path(::testing::TempDir()) / "vc_sim_dataset";
  fs::remove_all(dir);
  DatasetOptions d;
  d.frames = 30;
  d.backgrounds = 3;
  d.threads = 2;
  int last_progress = 0;
  d.progress = [&](int done, int total) {
    EXPECT_LE(done, total);
    last_progress = done;
  };
  const DatasetSummary sum = write_dataset(scene, d, dir.string());
  EXPECT_EQ(sum.frames, 30);
  EXPECT_EQ(sum.cameras, 3);
  EXPECT_EQ(last_progress, 3 * 3 + 30 * 3);
  EXPECT_TRUE(sum.notes.empty());

  for (int k = 0; k < 3; ++k) {
    const std::string ck = "cam" + std::to_string(k);
    EXPECT_TRUE(fs::is_regular_file(dir / "background" / ck / "2.png"));
    EXPECT_FALSE(fs::exists(dir / "background" / ck / "3.png"));
    EXPECT_FALSE(fs::exists(dir / ck / "30.png"));
    for (int f : {0, 17, 29}) {
      const std::string name = std::to_string(f) + ".png";
      cv::Mat img = cv::imread((dir / ck / name).string(), cv::IMREAD_COLOR);
      cv::Mat sil = cv::imread((dir / "truth" / "silhouettes" / ck / name).string(), cv::IMREAD_GRAYSCALE);
      cv::Mat shadow = cv::imread((dir / "truth" / "shadows" / ck / name).string(), cv::IMREAD_GRAYSCALE);
      ASSERT_FALSE(img.empty());
      ASSERT_FALSE(sil.empty());
      ASSERT_FALSE(shadow.empty());
      cv::cvtColor(img, img, cv::COLOR_BGR2RGB);
      cv::Mat want, want_sil;
      scene.render(f, k, want, &want_sil);
      EXPECT_EQ(cv::norm(img, want, cv::NORM_INF), 0.0);
      EXPECT_EQ(cv::norm(sil, want_sil, cv::NORM_INF), 0.0);
    }
    cv::Mat bg = cv::imread((dir / "background" / ck / "1.png").string(), cv::IMREAD_COLOR), want_bg;
    cv::cvtColor(bg, bg, cv::COLOR_BGR2RGB);
    scene.render_background(k, 1, want_bg);
    EXPECT_EQ(cv::norm(bg, want_bg, cv::NORM_INF), 0.0);
  }

  // joints.csv and features.csv against the written calibration.
  const rig::Calibration calib = rig::read_calibration((dir / "rig.yaml").string());
  ASSERT_EQ(calib.cameras.size(), 3u);
  ASSERT_TRUE(calib.grid.has_value());
  std::string header;
  const auto joints = read_csv(dir / "truth" / "joints.csv", &header);
  EXPECT_EQ(header, "frame,joint,x,y,z");
  ASSERT_EQ(joints.size(), static_cast<std::size_t>(30 * kJointCount));
  std::map<std::pair<int, std::string>, cv::Vec3d> p;
  for (const auto& r : joints) {
    ASSERT_EQ(r.size(), 5u);
    p[{std::stoi(r[0]), r[1]}] = cv::Vec3d(std::stod(r[2]), std::stod(r[3]), std::stod(r[4]));
  }
  const auto feats = read_csv(dir / "truth" / "features.csv", &header);
  EXPECT_EQ(header, "frame,camera,feature,u,v,visible");
  ASSERT_EQ(feats.size(), static_cast<std::size_t>(30 * 3 * kFeatureCount));
  const std::map<std::string, std::string> joint_of = {{"head", "head"},
                                                       {"l_hand", "l_wrist"},
                                                       {"r_hand", "r_wrist"},
                                                       {"l_foot", "l_ankle"},
                                                       {"r_foot", "r_ankle"}};
  int visible = 0;
  double worst = 0;
  for (const auto& r : feats) {
    ASSERT_EQ(r.size(), 6u);
    const int f = std::stoi(r[0]), k = std::stoi(r[1]);
    const cv::Point2d uv = calib.cameras[static_cast<std::size_t>(k)].project(p.at({f, joint_of.at(r[2])}));
    worst = std::max({worst, std::abs(uv.x - std::stod(r[3])), std::abs(uv.y - std::stod(r[4]))});
    visible += r[5] == "1";
    EXPECT_TRUE(r[5] == "0" || r[5] == "1");
  }
  EXPECT_LT(worst, 0.01) << "worst " << worst << " px";
  EXPECT_GT(visible, static_cast<int>(feats.size()) / 2);

  const vc::body::BvhClip motion = vc::body::read_bvh((dir / "truth" / "motion.bvh").string());
  EXPECT_EQ(motion.frames, 30);
  cv::FileStorage info((dir / "truth" / "scene.yaml").string(), cv::FileStorage::READ);
  EXPECT_EQ(static_cast<std::string>(info["motion"]), "wave");
  EXPECT_EQ(static_cast<int>(info["frames"]), 30);
}

TEST(SimDataset, RejectsBadOptionsAndUnwritableFolders) {
  SceneOptions o;
  o.rig.width = 32;
  o.rig.height = 24;
  o.rig.cameras = 2;
  const Scene scene(o);
  DatasetOptions d;
  d.frames = -1;
  EXPECT_THROW(write_dataset(scene, d, (fs::path(::testing::TempDir()) / "x").string()),
               std::invalid_argument);
  d.frames = 1;
  const fs::path file = fs::path(::testing::TempDir()) / "vc_sim_dataset_file";
  std::ofstream(file) << "not a folder";
  EXPECT_THROW(write_dataset(scene, d, (file / "sub").string()), std::runtime_error);
}

}  // namespace
}  // namespace vc::sim
