// `voxcap sim`: renders the virtual rig (hw/sim) to a folder — camera frames, empty-room frames,
// the calibration and the ground truth (layout in hw/sim/README.md). Thin: options -> SceneOptions
// and DatasetOptions, then vc::sim::write_dataset.
#include <cstdio>
#include <string>
#include <thread>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "voxcap/sim/dataset.hpp"
#include "voxcap/sim/scene.hpp"

namespace vc::cli {
namespace {

struct SimArgs {
  std::string motion = "walk";
  int frames = 0;
  int cameras = 6;
  std::string size = "640x480";
  std::string out;
  std::uint64_t seed = 1;
  double noise = 2.0;
  double flicker = 0.0;
  std::string appearance = "default";
  std::string room = "default";
  bool distortion = false;
  double fps = 60;
  int backgrounds = 30;
  std::string calibration;
  double height_m = 1.75;
  bool no_shadows = false;
  double bvh_fps = 0;
  double bvh_scale = 0;
  bool loop = false;
  int jobs = 0;
  bool list = false;
  bool quiet = false;
};

void list_choices() {
  fmt::print("built-in motions (or a .bvh file):\n");
  for (const auto& m : sim::builtin_motions())
    fmt::print("  {:<14} {} ({} s cycle)\n", m.name, m.description, m.cycle_s);
  fmt::print("appearances:\n");
  for (const auto& a : sim::appearance_presets()) fmt::print("  {}\n", a.name);
  fmt::print("rooms:\n");
  for (const auto& r : sim::room_presets()) fmt::print("  {:<14} {}\n", r.name, r.description);
}

void run(const SimArgs& a) {
  if (a.list) {
    list_choices();
    return;
  }
  if (a.out.empty()) throw UsageError("sim: --out DIR is required");
  sim::SceneOptions o;
  o.motion.source = a.motion;
  o.motion.fps = a.fps;
  o.motion.bvh_frame_time_s = a.bvh_fps > 0 ? 1.0 / a.bvh_fps : 0.0;
  o.motion.bvh_scale = a.bvh_scale;
  o.motion.loop = a.loop;
  o.body = sim::BodyDescription::adult(a.height_m);
  o.appearance = a.appearance;
  o.room = a.room;
  o.rig.cameras = a.cameras;
  int w = 0, h = 0;
  char tail = 0;
  if (std::sscanf(a.size.c_str(), "%dx%d%c", &w, &h, &tail) != 2 || w <= 0 || h <= 0) {
    throw UsageError("sim: --size must be WxH, e.g. 640x480 (got '" + a.size + "')");
  }
  o.rig.width = w;
  o.rig.height = h;
  o.rig.distortion = a.distortion;
  o.noise_sigma = a.noise;
  o.flicker = a.flicker;
  o.seed = a.seed;
  o.shadows = !a.no_shadows;
  if (!a.calibration.empty()) {
    try {
      o.calibration = rig::read_calibration(a.calibration);
    } catch (const std::exception& e) {
      throw UsageError(std::string("sim: --calibration: ") + e.what());
    }
  }
  std::string why;
  if (!o.valid(&why)) throw UsageError("sim: " + why);
  sim::DatasetOptions d;
  d.frames = a.frames;
  d.backgrounds = a.backgrounds;
  d.threads = a.jobs;
  if (!d.valid(&why)) throw UsageError("sim: " + why);

  std::unique_ptr<sim::Scene> scene;
  try {
    scene = std::make_unique<sim::Scene>(o);
  } catch (const std::exception& e) {
    // Unknown motion, unreadable or non-humanoid BVH, bad appearance: the user's input.
    throw UsageError(std::string("sim: ") + e.what());
  }
  if (!a.quiet) {
    d.progress = [](int done, int total) {
      if (done == total || done % 50 == 0) {
        std::fprintf(stderr, "\rvoxcap sim: %d/%d images", done, total);
        if (done == total) std::fputc('\n', stderr);
      }
    };
  }
  const sim::DatasetSummary s = sim::write_dataset(*scene, d, a.out);
  for (const std::string& note : s.notes) fmt::print(stderr, "voxcap sim: {}\n", note);
  fmt::print(
      "wrote {} cameras x {} frames (+{} background frames) of '{}' to {} in {:.1f} s ({} files; {:.2f} ms "
      "render per camera frame)\n",
      s.cameras, s.frames, s.backgrounds, a.motion, a.out, s.seconds, s.files, s.render_ms_per_image);
}

}  // namespace

void add_sim_commands(CLI::App& app) {
  auto args = std::make_shared<SimArgs>();
  CLI::App* cmd = app.add_subcommand(
      "sim", "Render the virtual rig (synthetic performer, room, cameras) with ground truth to a folder");
  cmd->add_option("--motion", args->motion, "Built-in motion name (see --list) or a BVH file (*.bvh)")
      ->capture_default_str();
  cmd->add_option("--frames", args->frames,
                  "Frames to render (0: the motion's length: 1.5 s lead-in + the clip or one cycle)")
      ->check(CLI::Range(0, 1000000))
      ->capture_default_str();
  cmd->add_option("--cameras", args->cameras,
                  "Cameras in the default ring (2..64; the first two are the front pair)")
      ->check(CLI::Range(2, 64))
      ->capture_default_str();
  cmd->add_option("--size", args->size, "Image size WxH in pixels")->capture_default_str();
  cmd->add_option("--out", args->out, "Output folder (created; existing files are overwritten)");
  cmd->add_option("--seed", args->seed, "Seed of the sensor noise and flicker")->capture_default_str();
  cmd->add_option("--noise", args->noise, "Gaussian sensor noise sigma in 8-bit levels (0..50)")
      ->capture_default_str();
  cmd->add_option("--flicker", args->flicker, "Illumination flicker: per-frame gain in [1-f, 1+f] (0..0.5)")
      ->capture_default_str();
  cmd->add_option("--appearance", args->appearance, "Appearance preset (skin and clothes, see --list)")
      ->capture_default_str();
  cmd->add_option("--room", args->room, "Room preset (floor and wall textures, see --list)")
      ->capture_default_str();
  cmd->add_flag("--distortion", args->distortion, "Mild barrel lens distortion (k1 ~ -0.1, k2 ~ 0.03)");
  cmd->add_option("--fps", args->fps, "Camera frame rate (frame f is at f/fps seconds)")
      ->capture_default_str();
  cmd->add_option("--backgrounds", args->backgrounds, "Empty-room frames for learning the background model")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  cmd->add_option(
      "--calibration", args->calibration,
      "Render with the cameras of this rig.yaml instead of the default ring (ignores --cameras, --size)");
  cmd->add_option("--height", args->height_m, "Performer height in metres (1.0..2.3)")->capture_default_str();
  cmd->add_flag("--no-shadows", args->no_shadows, "Do not cast the performer's shadow on the floor");
  cmd->add_option("--bvh-fps", args->bvh_fps, "Override the BVH clip's frame rate (0: from the file)")
      ->capture_default_str();
  cmd->add_option(
         "--bvh-scale", args->bvh_scale,
         "Metres per BVH unit (0: by naming convention, rest-pose size in m/cm/mm, else body height)")
      ->capture_default_str();
  cmd->add_flag("--loop", args->loop, "Loop a BVH clip instead of holding its last frame");
  cmd->add_option("--jobs", args->jobs, "Render threads (0: one per hardware thread)")
      ->check(CLI::Range(0, 256))
      ->capture_default_str();
  cmd->add_flag("--list", args->list, "List the built-in motions, appearances and rooms, then exit");
  cmd->add_flag("--quiet", args->quiet, "No progress on stderr");
  cmd->callback([args] { run(*args); });
}

}  // namespace vc::cli
