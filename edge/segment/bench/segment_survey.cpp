// edge_segment_survey: how well edge/segment labels the five terminals on hw/sim's initialization
// frames, over every appearance preset x room x rig size (4, 6, 8 cameras), with the true silhouettes
// and the edge's own masks (tests/sim_views.hpp: edge/core's subtraction and clean-up). Per camera:
// ok or the reason, and per terminal whether it is labelled correctly (tests/sim_views.hpp's rule:
// within 5 % of the body's height of the true 2D feature, nearer it than any other, not_visible for a
// hidden one) and its 2D error. The figures of edge/segment/README.md come from here.
//
//   edge_segment_survey [--frames 0,30] [--cameras 4,6,8] [--appearances a,b] [--rooms default,camouflage]
//                       [--masks edge,truth] [--size 640x480] [--quiet] [--pictures DIR] [--tolerance R]
// --pictures writes draw()'s picture of every camera not all correct (DIR/<masks>_<rig>_<room>_...png).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <initializer_list>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "sim_views.hpp"
#include "voxcap/sim/body.hpp"
#include "voxcap/sim/scene.hpp"

namespace {

using namespace vc::segment;

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(q * static_cast<double>(v.size() - 1) + 0.5)];
}

struct Tally {
  int cameras = 0, all_correct = 0, terminals = 0, correct = 0, refused = 0;
  std::vector<double> errors;  // visible, labelled
  double seconds = 0;
  void add(const testing::CameraScore& c) {
    cameras++;
    all_correct += c.all_correct();
    refused += !c.ok;
    for (const auto& t : c.t) {
      terminals++;
      correct += t.correct;
      if (t.visible && t.labelled) errors.push_back(t.error_px);
    }
  }
  std::string line() const {
    char b[256];
    std::snprintf(
        b, sizeof b, "cameras %d/%d all correct, terminals %d/%d, refused %d, error median %.1f p95 %.1f",
        all_correct, cameras, correct, terminals, refused, percentile(errors, 0.5), percentile(errors, 0.95));
    return b;
  }
};

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> frames{0, 30}, rigs{4, 6, 8};
  std::vector<std::string> appearances, rooms{"default", "camouflage"}, masks{"edge", "truth"};
  for (const auto& a : vc::sim::appearance_presets()) appearances.push_back(a.name);
  int width = 640, height = 480;
  bool quiet = false;
  double tolerance = testing::kToleranceRatio;
  std::string pictures;
  for (int i = 1; i < argc; i++) {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    auto ints = [](const std::string& s) {
      std::vector<int> v;
      for (const auto& x : split(s)) v.push_back(std::atoi(x.c_str()));
      return v;
    };
    if (a == "--frames" && has)
      frames = ints(argv[++i]);
    else if (a == "--cameras" && has)
      rigs = ints(argv[++i]);
    else if (a == "--appearances" && has)
      appearances = split(argv[++i]);
    else if (a == "--rooms" && has)
      rooms = split(argv[++i]);
    else if (a == "--masks" && has)
      masks = split(argv[++i]);
    else if (a == "--size" && has && std::sscanf(argv[i + 1], "%dx%d", &width, &height) == 2)
      i++;
    else if (a == "--quiet")
      quiet = true;
    else if (a == "--tolerance" && has)
      tolerance = std::atof(argv[++i]);
    else if (a == "--pictures" && has)
      pictures = argv[++i];
    else {
      std::fprintf(stderr,
                   "usage: edge_segment_survey [--frames 0,30] [--cameras 4,6,8] [--appearances a,b] "
                   "[--rooms default,camouflage] [--masks edge,truth] [--size 640x480] [--quiet] [--pictures "
                   "DIR] [--tolerance 0.08]\n");
      return 2;
    }
  }
  std::map<std::string, Tally> by;  // "masks", "masks room", "masks appearance", "masks N cameras"
  try {
    for (int cameras : rigs)
      for (const std::string& room : rooms)
        for (const std::string& appearance : appearances) {
          const vc::sim::Scene scene(testing::init_scene(cameras, appearance, room, width, height));
          const bool want_edge = std::find(masks.begin(), masks.end(), "edge") != masks.end();
          const std::unique_ptr<testing::EdgeMasks> edge(want_edge ? new testing::EdgeMasks(scene) : nullptr);
          for (int frame : frames)
            for (const testing::View& v : testing::views(scene, frame, edge.get()))
              for (const std::string& m : masks) {
                const cv::Mat1b& mask = m == "edge" ? v.edge_mask : v.truth_mask;
                const std::clock_t t0 = std::clock();  // CPU time: this machine is loaded
                const Segmentation s = segment(mask);
                const double sec = static_cast<double>(std::clock() - t0) / CLOCKS_PER_SEC;
                const testing::CameraScore c = testing::score(s, v, tolerance);
                auto key_of = [&m](std::initializer_list<std::string> parts) {
                  std::string k = m;
                  for (const std::string& p : parts) k.append(" ").append(p);
                  return k;
                };
                for (const std::string& key : {m, key_of({"room", room}), key_of({appearance}),
                                               key_of({std::to_string(cameras), "cameras"})}) {
                  by[key].add(c);
                  by[key].seconds += sec;
                }
                if (c.all_correct()) {
                  if (quiet) continue;
                } else if (!pictures.empty()) {
                  cv::Mat pic;
                  draw(s, cv::Mat(), &pic);
                  for (size_t f = 0; f < kFeatures; f++)  // the truth: small white crosses
                    cv::drawMarker(pic, v.truth[f], cv::Scalar(255, 0, 255), cv::MARKER_TILTED_CROSS, 9, 2);
                  cv::Rect box = cv::boundingRect(v.truth_mask | mask);  // magnified x3 around the body
                  box = cv::Rect(box.x - 12, box.y - 12, box.width + 24, box.height + 24) &
                        cv::Rect(0, 0, pic.cols, pic.rows);
                  cv::resize(pic(box).clone(), pic, {}, 3, 3, cv::INTER_NEAREST);
                  char name[160];
                  std::snprintf(name, sizeof name, "/%s_%d_%s_%s_f%d_cam%d.png", m.c_str(), cameras,
                                room.c_str(), appearance.c_str(), frame, v.camera);
                  cv::imwrite(pictures + name, pic);
                }
                std::printf("%-5s %d cams %-10s %-7s f%-3d cam%d %s", m.c_str(), cameras, room.c_str(),
                            appearance.c_str(), frame, v.camera, c.ok ? "ok" : "REFUSED");
                for (int f = 0; f < kFeatures; f++) {
                  const auto& t = c.t[static_cast<size_t>(f)];
                  std::printf("  %s%s %s", t.correct ? "" : "!", feature_name(f),
                              t.labelled ? std::to_string(static_cast<int>(std::lround(t.error_px))).c_str()
                                         : (t.visible ? "miss" : "hidden"));
                }
                if (!c.ok) std::printf("  (%s)", c.why.c_str());
                for (int f = 0; f < kFeatures; f++)  // where the wrong ones are, and the truth
                  if (!c.t[static_cast<size_t>(f)].correct)
                    std::printf("\n    %s at (%.0f, %.0f); truth %s", feature_name(f),
                                s.point[static_cast<size_t>(f)].x, s.point[static_cast<size_t>(f)].y,
                                [&] {
                                  std::string t;
                                  for (size_t g = 0; g < kFeatures; g++)
                                    t += " " + std::string(feature_name(static_cast<int>(g))) + " (" +
                                         std::to_string(static_cast<int>(v.truth[g].x)) + ", " +
                                         std::to_string(static_cast<int>(v.truth[g].y)) + ")" +
                                         (v.visible[g] ? "" : " hidden");
                                  return t;
                                }()
                                    .c_str());
                std::printf("\n");
              }
        }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "edge_segment_survey: %s\n", e.what());
    return 1;
  }
  for (const auto& [key, t] : by)
    std::printf("%-22s %s, %.1f ms CPU per camera\n", key.c_str(), t.line().c_str(),
                1e3 * t.seconds / std::max(1, t.cameras));
  return 0;
}
