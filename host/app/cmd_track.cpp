// `voxcap track debug`: the GVD segmentation of the initialization frame (edge/segment) on every
// camera of the virtual rig (--sim) or of a real rig's images (--images), with a picture per camera
// and a JSON summary, so a person can check the five terminals before tracking starts. Masks come
// from the edge's own subtraction (edge/core: vc_subtract + vc_cleanup_radius with the defaults a
// rig starts from), or with --sim --true-masks from the simulator's true silhouettes.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <regex>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "commands.hpp"
#include "voxcap/edge/bgmodel.h"
#include "voxcap/edge/cleanup.h"
#include "voxcap/edge/segment.hpp"
#include "voxcap/sim/scene.hpp"
#include "voxcap/subtraction.h"

namespace vc::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kMaxSide = 4096;  // images larger than this are refused (bounds the work)

struct TrackDebugArgs {
  std::string sim;
  std::string images;
  std::string out;
  int cameras = 6;
  std::string size = "640x480";
  std::string appearance = "default";
  std::string room = "default";
  int frame = 0;
  int backgrounds = 20;
  double noise = 2.0;
  bool true_masks = false;
  int zoom = 0;
  bool quiet = false;
};

// The edge's mask of one camera: a background model learnt from empty frames, then subtraction and
// the clean-up pass, as voxcap-edge runs them (defaults of voxcap/subtraction.h).
class EdgeMasker {
 public:
  EdgeMasker(int width, int height) : w_(width), h_(height) {
    char why[160] = "";
    vc_bgmodel* m = nullptr;
    if (vc_bgmodel_new(width, height, &m, why, sizeof why) != 0)
      throw std::runtime_error(std::string("background model: ") + why);
    model_.reset(m);
  }
  void learn(const cv::Mat& rgb) {
    if (vc_bgmodel_learn(model_.get(), rgb.data, rgb.step) != 0)
      throw std::runtime_error("background model: learn failed");
  }
  void finish() {
    vc_subtract_params p;
    vc_subtract_params_default(&p);
    if (vc_bgmodel_finish(model_.get()) != 0 || vc_bgmodel_set_params(model_.get(), &p) != 0)
      throw std::runtime_error("background model: no background frames, or bad parameters");
  }
  cv::Mat1b mask(const cv::Mat& rgb) const {
    cv::Mat1b m(h_, w_);
    std::vector<uint8_t> scratch(vc_cleanup_radius_scratch_size(w_, VC_CLEANUP_RADIUS_PX));
    vc_subtract_stats st{};
    if (vc_subtract(model_.get(), rgb.data, rgb.step, m.data, &st) != 0 ||
        vc_cleanup_radius(m.data, w_, h_, VC_CLEANUP_RADIUS_PX, scratch.data(), scratch.size()) != 0)
      throw std::runtime_error("subtraction failed");
    return m;
  }

 private:
  struct Free {
    void operator()(vc_bgmodel* m) const { vc_bgmodel_free(m); }
  };
  int w_, h_;
  std::unique_ptr<vc_bgmodel, Free> model_;
};

struct CameraInput {
  int camera = 0;
  cv::Mat bgr;                           // the picture drawn on
  cv::Mat1b mask;                        // what is segmented
  std::vector<sim::FeatureTruth> truth;  // --sim only
};

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const size_t i = static_cast<size_t>(pos);
  const double t = pos - static_cast<double>(i);
  return i + 1 < v.size() ? v[i] * (1 - t) + v[i + 1] * t : v[i];
}

std::vector<CameraInput> sim_inputs(const TrackDebugArgs& a) {
  sim::SceneOptions o;
  o.motion.source = a.sim;
  o.appearance = a.appearance;
  o.room = a.room;
  o.rig.cameras = a.cameras;
  int w = 0, h = 0;
  char tail = 0;
  if (std::sscanf(a.size.c_str(), "%dx%d%c", &w, &h, &tail) != 2 || w <= 0 || h <= 0 || w > kMaxSide ||
      h > kMaxSide)
    throw UsageError("track debug: --size must be WxH up to 4096x4096, e.g. 640x480 (got '" + a.size + "')");
  o.rig.width = w;
  o.rig.height = h;
  o.noise_sigma = a.noise;
  std::string why;
  if (!o.valid(&why)) throw UsageError("track debug: " + why);
  std::unique_ptr<sim::Scene> scene;
  try {
    scene = std::make_unique<sim::Scene>(o);
  } catch (const std::exception& e) {
    throw UsageError(std::string("track debug: ") + e.what());
  }
  std::vector<CameraInput> in;
  for (int cam = 0; cam < scene->camera_count(); cam++) {
    CameraInput c;
    c.camera = cam;
    cv::Mat rgb, sil;
    scene->render(a.frame, cam, rgb, &sil);
    if (a.true_masks) {
      c.mask = sil;
    } else {
      EdgeMasker m(rgb.cols, rgb.rows);
      cv::Mat bg;
      for (int i = 0; i < a.backgrounds; i++) {
        scene->render_background(cam, i, bg);
        m.learn(bg);
      }
      m.finish();
      c.mask = m.mask(rgb);
    }
    cv::cvtColor(rgb, c.bgr, cv::COLOR_RGB2BGR);
    c.truth = scene->features(a.frame, cam);
    in.push_back(std::move(c));
  }
  return in;
}

cv::Mat read_image(const fs::path& p) {
  cv::Mat img = cv::imread(p.string(), cv::IMREAD_COLOR);
  if (img.empty()) throw UsageError("track debug: cannot read image " + p.string());
  if (img.cols > kMaxSide || img.rows > kMaxSide)
    throw UsageError(fmt::format("track debug: {} is {}x{}, larger than {}x{}", p.string(), img.cols,
                                 img.rows, kMaxSide, kMaxSide));
  return img;
}

// DIR/camNN.png|jpg with DIR/camNN_bg*.png|jpg (one or more empty-scene frames) per camera.
std::vector<CameraInput> image_inputs(const TrackDebugArgs& a) {
  const fs::path dir(a.images);
  if (!fs::is_directory(dir)) throw UsageError("track debug: --images: no folder " + a.images);
  const std::regex frame_re(R"(cam(\d{1,3})\.(png|jpg|jpeg))", std::regex::icase);
  const std::regex bg_re(R"(cam(\d{1,3})_bg[^.]*\.(png|jpg|jpeg))", std::regex::icase);
  std::map<int, fs::path> frames;
  std::map<int, std::vector<fs::path>> bgs;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    std::smatch m;
    if (std::regex_match(name, m, frame_re))
      frames[std::stoi(m[1])] = e.path();
    else if (std::regex_match(name, m, bg_re))
      bgs[std::stoi(m[1])].push_back(e.path());
  }
  if (frames.empty()) throw UsageError("track debug: --images: no camNN.png or camNN.jpg in " + a.images);
  std::vector<CameraInput> in;
  for (const auto& [cam, path] : frames) {
    auto it = bgs.find(cam);
    if (it == bgs.end())
      throw UsageError(
          fmt::format("track debug: --images: cam{:02d} has no background (cam{:02d}_bg.png)", cam, cam));
    std::sort(it->second.begin(), it->second.end());
    CameraInput c;
    c.camera = cam;
    c.bgr = read_image(path);
    EdgeMasker m(c.bgr.cols, c.bgr.rows);
    cv::Mat rgb;
    for (const fs::path& b : it->second) {
      const cv::Mat bg = read_image(b);
      if (bg.size() != c.bgr.size())
        throw UsageError(fmt::format("track debug: {} is {}x{} but {} is {}x{}", b.string(), bg.cols, bg.rows,
                                     path.string(), c.bgr.cols, c.bgr.rows));
      cv::cvtColor(bg, rgb, cv::COLOR_BGR2RGB);
      m.learn(rgb);
    }
    m.finish();
    cv::cvtColor(c.bgr, rgb, cv::COLOR_BGR2RGB);
    c.mask = m.mask(rgb);
    in.push_back(std::move(c));
  }
  return in;
}

void run_debug(const TrackDebugArgs& a) {
  if (a.sim.empty() == a.images.empty())
    throw UsageError("track debug: give one of --sim MOTION or --images DIR");
  if (a.out.empty()) throw UsageError("track debug: --out DIR is required");
  const std::vector<CameraInput> inputs = a.sim.empty() ? image_inputs(a) : sim_inputs(a);
  fs::create_directories(a.out);

  json cams = json::array();
  std::vector<double> errors;
  int ok = 0;
  for (const CameraInput& c : inputs) {
    const segment::Segmentation s = segment::segment(c.mask);
    cv::Mat pic;
    segment::draw(s, c.bgr, &pic);
    if (a.zoom > 0) {  // the silhouette's box with a margin, magnified
      cv::Rect box = cv::boundingRect(c.mask);
      const int m = 10 + box.height / 10;
      box = cv::Rect(box.x - m, box.y - m, box.width + 2 * m, box.height + 2 * m) &
            cv::Rect(0, 0, pic.cols, pic.rows);
      if (!box.empty()) cv::resize(pic(box).clone(), pic, {}, a.zoom, a.zoom, cv::INTER_NEAREST);
    }
    const std::string name = fmt::format("cam{:02d}.png", c.camera);
    if (!cv::imwrite((fs::path(a.out) / name).string(), pic))
      throw std::runtime_error("cannot write " + (fs::path(a.out) / name).string());
    json j = {{"camera", c.camera},
              {"image", name},
              {"ok", s.ok},
              {"why", s.why},
              {"regions", s.regions.size()},
              {"cuts", s.cuts.size()},
              {"critical", s.critical.size()}};
    json terms = json::object();
    std::array<size_t, segment::kFeatures> by_side{0, 1, 2, 3, 4};
    if (!c.truth.empty()) {
      for (size_t l : {size_t{1}, size_t{3}})  // the truth's "left" of a pair is the one on the image's right
        if (c.truth[l].uv.x < c.truth[l + 1].uv.x) std::swap(by_side[l], by_side[l + 1]);
    }
    std::string line = fmt::format("cam{:02d}: {}", c.camera, s.ok ? "ok" : "not ok: " + s.why);
    for (int f = 0; f < segment::kFeatures; f++) {
      const size_t fi = static_cast<size_t>(f);
      const bool labelled = s.ok && s.terminal[fi] >= 0;  // else not_visible (or the view refused)
      json t = {{"region", s.terminal[fi]}, {"state", labelled ? "labelled" : "not_visible"}};
      if (labelled) t["u"] = s.point[fi].x, t["v"] = s.point[fi].y;
      if (!c.truth.empty()) {
        // hw/sim's order is proto's (head, l/r hand, l/r foot); left/right by image side, like segment().
        const sim::FeatureTruth& tr = c.truth[by_side[fi]];
        t["truth"] = {{"feature", std::string(sim::feature_name(tr.feature))},
                      {"u", tr.uv.x},
                      {"v", tr.uv.y},
                      {"visible", tr.visible}};
        if (!labelled && s.ok) {
          line += fmt::format(" {} not_visible", segment::feature_name(f));
        } else if (labelled) {
          const double e = std::hypot(s.point[fi].x - tr.uv.x, s.point[fi].y - tr.uv.y);
          t["error_px"] = e;
          if (tr.visible) errors.push_back(e);
          line += fmt::format(" {} {:.1f}", segment::feature_name(f), e);
        }
      }
      terms[segment::feature_name(f)] = t;
    }
    j["terminals"] = terms;
    ok += s.ok;
    cams.push_back(j);
    if (!a.quiet) fmt::print("{}\n", line);
  }
  json doc = {{"source", a.sim.empty() ? "images" : "sim"},
              {"masks", a.true_masks ? "truth" : "edge"},
              {"left_right", "per image: left = the terminal on the image's right"},
              {"cameras", cams},
              {"ok_cameras", ok}};
  if (!a.sim.empty()) {
    doc["motion"] = a.sim;
    doc["frame"] = a.frame;
    doc["appearance"] = a.appearance;
    doc["room"] = a.room;
    doc["error_px"] = {{"count", errors.size()},
                       {"median", percentile(errors, 0.5)},
                       {"p95", percentile(errors, 0.95)},
                       {"max", errors.empty() ? 0.0 : *std::max_element(errors.begin(), errors.end())}};
  }
  const fs::path jp = fs::path(a.out) / "segmentation.json";
  std::ofstream f(jp);
  f << doc.dump(2) << "\n";
  if (!f) throw std::runtime_error("cannot write " + jp.string());
  if (!a.quiet) {
    fmt::print("{}/{} cameras segmented", ok, inputs.size());
    if (!a.sim.empty())
      fmt::print("; 2D error against the truth (visible features): median {:.1f} px, p95 {:.1f} px",
                 percentile(errors, 0.5), percentile(errors, 0.95));
    fmt::print("; wrote {} and camNN.png\n", jp.string());
  }
}

}  // namespace

void add_track_commands(CLI::App& app) {
  CLI::App* track = app.add_subcommand("track", "Head, hands and feet: segmentation and tracking tools");
  track->require_subcommand(1, 1);
  auto a = std::make_shared<TrackDebugArgs>();
  CLI::App* dbg = track->add_subcommand(
      "debug",
      "Segment the initialization frame of every camera (GVD: regions, cuts, head/hands/feet) and write "
      "DIR/camNN.png (image, regions, GVD, critical points, cuts, labels) and DIR/segmentation.json (per "
      "camera: ok/why, terminals with state and u, v, or not_visible; with --sim the truth and the 2D "
      "error). Left/right are per "
      "image: left = the terminal on the image's right.");
  dbg->add_option("--sim", a->sim,
                  "Render the virtual rig's initialization frame of this motion (built-in or .bvh)");
  dbg->add_option(
      "--images", a->images,
      "A real rig's images: DIR/camNN.png|jpg per camera (NN = 0..999) and one or more empty-scene "
      "frames DIR/camNN_bg*.png|jpg each; masks by the edge's subtraction");
  dbg->add_option("--out", a->out, "Output folder (created; files overwritten)");
  dbg->add_option("--cameras", a->cameras, "--sim: cameras in the default ring (4..8 usual)")
      ->check(CLI::Range(2, 64))
      ->capture_default_str();
  dbg->add_option("--size", a->size, "--sim: image size WxH")->capture_default_str();
  dbg->add_option("--appearance", a->appearance, "--sim: appearance preset (voxcap sim --list)")
      ->capture_default_str();
  dbg->add_option("--room", a->room, "--sim: room preset (voxcap sim --list)")->capture_default_str();
  dbg->add_option("--frame", a->frame, "--sim: frame (the initialization pose is held for the first second)")
      ->check(CLI::Range(0, 1000000))
      ->capture_default_str();
  dbg->add_option("--backgrounds", a->backgrounds, "--sim: empty-room frames the background model learns")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  dbg->add_option("--noise", a->noise, "--sim: sensor noise sigma (8-bit levels)")
      ->check(CLI::Range(0.0, 50.0))
      ->capture_default_str();
  dbg->add_flag("--true-masks", a->true_masks,
                "--sim: segment the simulator's true silhouettes, not the edge's masks");
  dbg->add_option("--zoom", a->zoom,
                  "Pictures of the silhouette's box only, magnified this many times (0: whole image)")
      ->check(CLI::Range(0, 8))
      ->capture_default_str();
  dbg->add_flag("--quiet", a->quiet, "Print nothing on success");
  dbg->callback([a] { run_debug(*a); });
}

}  // namespace vc::cli
