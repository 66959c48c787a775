// voxcap-bench: the benchmarks behind `voxcap bench edge|host` (and `silhouettes`, run directly), as a
// program of their own so that the voxcap binary links none of tests/bench. `voxcap bench ARGS` execs
// `voxcap-bench ARGS` from beside itself with argv[0] = "<voxcap> bench", so usage lines and error prefixes
// read as they always did. Exit codes as voxcap's: 0 ok, 1 runtime failure, 2 bad input (CLI11's own codes
// for parse errors).
#include <cstdio>
#include <exception>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/core.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "edge_bench.hpp"
#include "host_bench.hpp"
#include "silhouette_bench.hpp"
#include "voxcap/edge/bgmodel.h"
#include "voxcap/subtraction.h"

namespace {

// Bad input from the user: exit code 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

constexpr const char* kEdgeKeys = R"(JSON keys (one object per grid; an array when --grid is repeated):
  grid, voxels, cameras, width, height, frames, bg_frames   the setting
  kernel                 kernel variant in use ("avx2" or "generic")
  subtract_ns            median ns per frame: subtraction of both cameras
  cleanup_ns             median ns per frame: 3x3 majority clean-up of both masks
  carve_ns               median ns per frame: partial-hull carving
  rle_ns                 median ns per frame: RLE of the hull bitset
  edge_frame_ms          median ms of the whole edge frame (2x subtract + 2x clean-up + carve + RLE)
  mog2_ns                median ns per frame: OpenCV MOG2 (shadows on, 1 thread), both cameras
  lut_carve_ns           median ns per frame: plain per-voxel lookup-table carve
  speedup_subtract_vs_mog2, speedup_carve_vs_lut   ratios of the medians
  lut_matches            the LUT carve and the edge carver produced the same bitset
  carver_setup_ms, carver_table_mb, lut_table_mb   configuration cost of the carver / LUT
  unseen_fraction        grid fraction not seen by both cameras
  band_fraction, shadow_fraction   pixels through the shadow test / classified shadow
  occupied_voxels, leaves_tested, rle_bytes         per-frame means
  peak_rss_mb            VmHWM of a child running only the edge pipeline (null with --no-rss)
  carve_footprint.*, carve_subpixel.*
                         the footprint and subpixel carve rules on the same masks: carve_ns,
                         edge_frame_ms, setup_ms, table_mb, scratch_mb, classes, unseen_fraction,
                         occupied_voxels, leaves_tested, holds_centre, cost_vs_centre, peak_rss_mb
                         (the keys above are the centre rule's)
  ir_per_pixel.{subtract,cleanup,mog2},
  ir_per_voxel.{carve,carve_footprint,carve_subpixel,rle,lut_carve}
                         callgrind instructions (null when callgrind is unavailable)
  callgrind              "ok" or why the instruction counts are null
  goals.*                the issue's targets and whether this run met them (reported, not asserted)
  track.*                edge/track on the virtual rig's front pair (wave, the edge's masks): init_frames,
                         frames, init_ms_per_camera, frame_ms_per_camera (median; _p95, _max),
                         tracking_share, losses, reacquisitions, goal_frame_ms_per_camera_max (0.3), goal_met)";

void print_edge_table(const nlohmann::json& j) {
  auto num = [&](const nlohmann::json& v, const char* fmtspec) {
    return v.is_null() ? std::string("n/a") : fmt::format(fmt::runtime(fmtspec), v.get<double>());
  };
  fmt::print("edge bench: 2 cameras {}x{}, grid {}^3, {} frames, kernel {}\n", j["width"].get<int>(),
             j["height"].get<int>(), j["grid"].get<int>(), j["frames"].get<int>(),
             j["kernel"].get<std::string>());
  fmt::print("  subtract   {:>10.0f} ns   (MOG2 {:>10.0f} ns, x{:.1f})   Ir/px {} (MOG2 {})\n",
             j["subtract_ns"].get<double>(), j["mog2_ns"].get<double>(),
             j["speedup_subtract_vs_mog2"].get<double>(), num(j["ir_per_pixel"]["subtract"], "{:.2f}"),
             num(j["ir_per_pixel"]["mog2"], "{:.1f}"));
  fmt::print("  clean-up   {:>10.0f} ns                                     Ir/px {}\n",
             j["cleanup_ns"].get<double>(), num(j["ir_per_pixel"]["cleanup"], "{:.2f}"));
  fmt::print("  carve      {:>10.0f} ns   (LUT  {:>10.0f} ns, x{:.1f})   Ir/voxel {} (LUT {})\n",
             j["carve_ns"].get<double>(), j["lut_carve_ns"].get<double>(),
             j["speedup_carve_vs_lut"].get<double>(), num(j["ir_per_voxel"]["carve"], "{:.3f}"),
             num(j["ir_per_voxel"]["lut_carve"], "{:.2f}"));
  for (const char* rule : {"footprint", "subpixel"}) {
    const std::string key = std::string("carve_") + rule;
    const auto& o = j[key];
    fmt::print("  {:<9}  {:>10.0f} ns   (x{:.2f} the centre rule)              Ir/voxel {}\n", rule,
               o["carve_ns"].get<double>(), o["cost_vs_centre"].get<double>(),
               num(j["ir_per_voxel"][key], "{:.3f}"));
  }
  fmt::print("  rle        {:>10.0f} ns   ({:.0f} bytes)                        Ir/voxel {}\n",
             j["rle_ns"].get<double>(), j["rle_bytes"].get<double>(),
             num(j["ir_per_voxel"]["rle"], "{:.3f}"));
  fmt::print("  edge frame {:>10.3f} ms   peak RSS {} MB   carver tables {:.1f} MB\n",
             j["edge_frame_ms"].get<double>(), num(j["peak_rss_mb"], "{:.1f}"),
             j["carver_table_mb"].get<double>());
  for (const char* rule : {"footprint", "subpixel"}) {
    const auto& o = j[std::string("carve_") + rule];
    fmt::print(
        "  {:<9} frame {:>5.3f} ms   peak RSS {} MB   tables {:.1f} MB (scratch {:.1f} MB, {}+{} "
        "classes)\n",
        rule, o["edge_frame_ms"].get<double>(), num(o["peak_rss_mb"], "{:.1f}"), o["table_mb"].get<double>(),
        o["scratch_mb"].get<double>(), o["classes"][0].get<int>(), o["classes"][1].get<int>());
  }
  fmt::print("  callgrind: {}\n", j["callgrind"].get<std::string>());
  const auto& t = j["track"];
  fmt::print(
      "  tracking   {:>10.3f} ms per camera frame (p95 {:.3f}; init {:.3f} ms), {:.0f} % tracked, {} "
      "losses\n",
      t["frame_ms_per_camera"].get<double>(), t["frame_ms_per_camera_p95"].get<double>(),
      t["init_ms_per_camera"].get<double>(), 100.0 * t["tracking_share"].get<double>(),
      t["losses"].get<int>());
}

void print_host_text(const nlohmann::json& j) {
  for (const auto& t : j["triangulate"])
    fmt::print("triangulate {} cameras: {:.1f} us per frame (p99 {:.1f} us), 3D error p50 {:.1f} mm\n",
               t["cameras"].get<int>(), t["ns_per_frame"].get<double>() / 1e3,
               t["ns_p99"].get<double>() / 1e3, t["err3d_mm_p50"].get<double>());
  if (j.contains("fit")) {
    const auto& f = j["fit"];
    const auto& p = f["paper_table1_ms"];
    auto us = [&f](const char* k) { return f[k]["us"].get<double>(); };
    fmt::print(
        "fit {} at {}^3 ({} samples, {} steps), {} of {} frames fitted, MPJPE {:.1f} mm; median per frame "
        "(the method's Table 1, 1 GHz):\n",
        f["motion"].get<std::string>(), f["grid"][0].get<int>(), f["samples"].get<int>(),
        f["steps"].get<int>(), f["fitted_frames"].get<int>(), f["frames"].get<int>(),
        f["mpjpe_mm"].get<double>());
    fmt::print("  decode hull        {:8.1f} us\n", us("decode"));
    fmt::print("  torso segmentation {:8.1f} us  ({} ms)\n", us("torso_segmentation"),
               p["torso_segmentation"].get<double>());
    fmt::print("  PCA                {:8.1f} us  ({} ms)\n", us("pca"), p["pca"].get<double>());
    fmt::print("  layer 1            {:8.1f} us  ({} ms)\n", us("layer1"), p["layer1"].get<double>());
    fmt::print("  one layer-2 limb   {:8.1f} us  ({} ms)\n", us("layer2_segment"),
               p["layer2_segment"].get<double>());
    fmt::print("  all stages         {:8.1f} us  (p99 {:.1f} us; goal < 1000 us)\n", us("total"),
               f["total"]["us_p99"].get<double>());
  }
  for (const auto& m : j["merge"])
    fmt::print("merge {} nodes at {}^3: {:.1f} us per frame (p99 {:.1f} us), {} B RLE per node\n",
               m["nodes"].get<int>(), m["grid"].get<int>(), m["merge_ns_per_frame"].get<double>() / 1e3,
               m["merge_ns_p99"].get<double>() / 1e3, m["rle_bytes_per_node"].get<uint64_t>());
  if (j.contains("rig")) {
    const auto& r = j["rig"];
    fmt::print(
        "rig {} nodes {} {}^3 for {:.0f} s: {:.1f} fps, {} frames ({} complete), trigger->merged p50 {:.2f} "
        "ms "
        "p99 {:.2f} ms, host RSS {} -> {} kB\n",
        r["nodes"].get<int>(), r["size"].get<std::string>(), r["grid"].get<int>(), r["seconds"].get<double>(),
        r["fps"].get<double>(), r["frames"].get<uint64_t>(), r["complete"].get<uint64_t>(),
        r["trigger_to_merged_ms"]["p50"].get<double>(), r["trigger_to_merged_ms"]["p99"].get<double>(),
        r["host_rss_kb"]["start"].get<long>(), r["host_rss_kb"]["end"].get<long>());
  }
}

void add_edge_command(CLI::App& app) {
  struct EdgeArgs {
    std::vector<int> grids;
    vc::bench::EdgeBenchOptions opt;
    bool json = false, no_callgrind = false, no_rss = false;
    std::string child, frames_file, size;
  };
  auto args = std::make_shared<EdgeArgs>();
  auto* edge = app.add_subcommand("edge",
                                  "Edge per-frame work (2 cameras: subtraction, clean-up, carving, RLE) vs "
                                  "OpenCV MOG2 and a plain LUT carve");
  edge->footer(kEdgeKeys);
  edge->add_option("--grid", args->grids,
                   "Voxels per axis of the cubic grid; repeat for several (default 128)")
      ->check(CLI::Range(4, 1024));
  edge->add_option("--frames", args->opt.frames, "Measured frames; medians are reported")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  edge->add_option("--bg-frames", args->opt.bg_frames, "Empty-room frames the background model learns from")
      ->check(CLI::Range(2, 1000))
      ->capture_default_str();
  auto* width = edge->add_option("--width", args->opt.width, "Image width per camera")
                    ->check(CLI::Range(16, 4096))
                    ->capture_default_str();
  auto* height = edge->add_option("--height", args->opt.height, "Image height per camera")
                     ->check(CLI::Range(16, 4096))
                     ->capture_default_str();
  edge->add_option("--size", args->size,
                   "Image size per camera WxH, each 16..4096, instead of --width/--height (1456x1088: the "
                   "Raspberry Pi Global Shutter camera's native size)")
      ->excludes(width)
      ->excludes(height);
  edge->add_flag("--json", args->json, "Print JSON (keys below) instead of a table");
  edge->add_flag("--no-callgrind", args->no_callgrind, "Skip the instruction counts (no valgrind child)");
  edge->add_flag("--no-rss", args->no_rss, "Skip the peak-memory child");
  edge->add_option(
          "--grow-px", args->opt.grow_px,
          "The subtraction's limb-scale cue, pixels (0 = off; default that of voxcap/edge/bgmodel.h)")
      ->check(CLI::Range(0, static_cast<int>(VC_SUBTRACT_GROW_PX_MAX)));
  edge->add_option("--grow-flat", args->opt.grow_flat,
                   "The limb-scale cue in the shadow band where the background is flat (noise variances per "
                   "pixel; 0 = never; default that of voxcap/edge/bgmodel.h)")
      ->check(CLI::Range(0.0, VC_SUBTRACT_GROW_FLAT_MAX));
  edge->add_option(
          "--child", args->child,
          "Internal: run as the benchmark's own measuring child (rss, rss-footprint, rss-subpixel or "
          "callgrind); not for users")
      ->check(CLI::IsMember({"rss", "rss-footprint", "rss-subpixel", "callgrind"}));
  edge->add_option("--frames-file", args->frames_file, "Internal: frames written by the parent, for --child");

  edge->callback([args] {
    vc::bench::EdgeBenchOptions opt = args->opt;
    if (!args->size.empty()) {
      int w = 0, h = 0;
      char tail = 0;
      if (std::sscanf(args->size.c_str(), "%dx%d%c", &w, &h, &tail) != 2 || w < 16 || w > 4096 || h < 16 ||
          h > 4096)
        throw UsageError("--size: expected WxH with each side 16..4096 (e.g. 1456x1088), got '" + args->size +
                         "'");
      opt.width = w;
      opt.height = h;
    }
    opt.callgrind = !args->no_callgrind;
    opt.rss = !args->no_rss;
    std::vector<int> grids = args->grids.empty() ? std::vector<int>{128} : args->grids;
    if (!args->child.empty()) {
      if (args->frames_file.empty() || grids.size() != 1)
        throw UsageError("--child needs --frames-file and one --grid");
      opt.grid = grids[0];
      nlohmann::json j = vc::bench::run_edge_bench_child(opt, args->child, args->frames_file);
      if (!j.empty()) fmt::print("{}\n", j.dump());
      return;
    }
    nlohmann::json all = nlohmann::json::array();
    for (int g : grids) {
      opt.grid = g;
      std::string why;
      if (!opt.valid(&why)) throw UsageError(why);
      nlohmann::json j = vc::bench::run_edge_bench(opt);
      if (!args->json) print_edge_table(j);
      all.push_back(std::move(j));
    }
    if (args->json) fmt::print("{}\n", (all.size() == 1 ? all[0] : all).dump(2));
  });
}

void add_host_command(CLI::App& app) {
  auto hopt = std::make_shared<vc::bench::HostBenchOptions>();
  auto hjson = std::make_shared<bool>(false);
  auto hsize = std::make_shared<std::string>("640x480");
  auto grids = std::make_shared<std::vector<int>>();
  auto nodes = std::make_shared<std::vector<int>>();
  auto* host =
      app.add_subcommand("host",
                         "Host: merge cost per frame (3/4/8 nodes, 64^3..256^3), triangulation cost "
                         "per frame (6/8 cameras), the fitting's cost per stage, the emulated rig's fps, "
                         "latency and memory");
  host->footer(
      "JSON keys: merge[] {nodes, grid, voxels, rle_bytes_per_node, merged_occupied, merge_ns_per_frame "
      "(median), "
      "merge_ns_p99}; triangulate[] {cameras, frames, ns_per_frame, ns_p99, err3d_mm_p50}; fit {motion, "
      "grid, "
      "voxel_m, samples, steps, frames, fitted_frames, decode|torso_segmentation|pca|layer1|layer2_segment|"
      "layer2_all|total {us, us_p99}, mpjpe_mm, paper_table1_ms}; rig {nodes, size, "
      "grid, seconds, pulses, frames, complete, degraded, fps, "
      "trigger_to_merged_ms {p50, p99}, host_rss_kb {start, end}}. Keys also in tests/bench/README.md.");
  host->add_option("--grid", *grids,
                   "merge: voxels per axis, 8..512; repeat for several (default 64 128 256)")
      ->check(CLI::Range(8, 512));
  host->add_option("--nodes", *nodes, "merge: node counts, 1..64; repeat for several (default 3 4 8)")
      ->check(CLI::Range(1, 64));
  host->add_option("--repeats", hopt->repeats, "merge: timed merges per configuration (1..1000000)")
      ->check(CLI::Range(1, 1000000))  // 0 timed nothing and read the median of an empty list
      ->capture_default_str();
  host->add_option("--tri-frames", hopt->tri_frames, "triangulate: frames timed per camera count")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  host->add_option("--fit-frames", hopt->fit_frames, "fit: frames fitted (0: the whole motion)")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  host->add_option("--fit-motion", hopt->fit_motion, "fit: the hw/sim motion fitted")->capture_default_str();
  host->add_option("--fit-grid", hopt->fit_grid, "fit: voxels across the default volume")
      ->check(CLI::Range(16, 512))
      ->capture_default_str();
  host->add_option("--minutes", hopt->rig_minutes,
                   "rig: how long the emulated rig runs (memory at start and end)")
      ->check(CLI::Range(0.0, 1440.0))
      ->capture_default_str();
  host->add_option("--size", *hsize, "rig: camera size WxH")->capture_default_str();
  host->add_option("--rig-grid", hopt->rig_grid, "rig: voxels per axis")
      ->check(CLI::Range(16, 512))
      ->capture_default_str();
  host->add_option("--rig-nodes", hopt->rig_nodes, "rig: edge nodes")
      ->check(CLI::Range(1, 8))
      ->capture_default_str();
  host->add_flag(
      "--no-rig", [hopt](int64_t) { hopt->rig = false; }, "merge figures only");
  host->add_flag("--json", *hjson, "Print JSON (keys below) instead of text");
  host->callback([=] {
    vc::bench::HostBenchOptions o = *hopt;
    if (!grids->empty()) o.grids = *grids;
    if (!nodes->empty()) o.nodes = *nodes;
    if (std::sscanf(hsize->c_str(), "%dx%d", &o.width, &o.height) != 2)
      throw UsageError("--size: expected WxH");
    nlohmann::json j = vc::bench::run_host_bench(o);
    if (*hjson) {
      fmt::print("{}\n", j.dump(2));
      return;
    }
    print_host_text(j);
  });
}

void add_silhouettes_command(CLI::App& app) {
  auto opt = std::make_shared<vc::bench::SilhouetteBenchOptions>();
  auto json = std::make_shared<bool>(false);
  auto size = std::make_shared<std::string>("640x480");
  auto* sil =
      app.add_subcommand("silhouettes",
                         "The edge's silhouettes (subtraction + clean-up) against hw/sim's truth: recall "
                         "per camera and body part, precision, floor shadow kept");
  sil->footer(
      "JSON keys in tests/bench/README.md. Masks are the edge's real ones (vc_subtract + "
      "vc_cleanup_radius, defaults of voxcap/subtraction.h).");
  sil->add_option("--motion", opt->motion, "A built-in motion (voxcap sim --list) or a .bvh file")
      ->capture_default_str();
  sil->add_option("--appearance", opt->appearance, "Appearance preset of the performer")
      ->capture_default_str();
  sil->add_option("--room", opt->room, "Room preset (floor and wall textures; voxcap sim --list)")
      ->capture_default_str();
  sil->add_option("--frames", opt->frames, "Frames evaluated per camera")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  sil->add_option("--every", opt->every, "Frames between two evaluated ones (from the end of the lead-in)")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  sil->add_option("--rig-cameras", opt->rig_cameras, "Cameras of the sim rig layout")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  sil->add_option("--cameras", opt->cameras, "Cameras evaluated, by index (default all)")->delimiter(',');
  sil->add_option("--size", *size, "Camera size WxH")->capture_default_str();
  sil->add_option("--bg-frames", opt->bg_frames, "Empty-room frames the background model learns from")
      ->check(CLI::Range(VC_BACKGROUND_FRAMES_MIN, VC_BACKGROUND_FRAMES_MAX))
      ->capture_default_str();
  sil->add_option("--png", opt->png_dir,
                  "Write each camera's worst frame here (green body kept, red missed, blue other "
                  "foreground, yellow shadow kept)");
  sil->add_option("--shadow-texture-k", opt->shadow_texture_k,
                  "The texture test's k (noise sigmas; 0 = off; default that of voxcap/subtraction.h)")
      ->check(CLI::Range(0.0, VC_SUBTRACT_SHADOW_TEXTURE_K_MAX));
  sil->add_option("--shadow-flat-margin", opt->shadow_flat_margin,
                  "The flat-patch test's margin (noise variances per pixel; 0 = off; default that of "
                  "voxcap/edge/bgmodel.h)")
      ->check(CLI::Range(0.0, VC_SUBTRACT_SHADOW_FLAT_MARGIN_MAX));
  sil->add_option("--grow-px", opt->grow_px,
                  "The limb-scale cue's reach (4-connected pixels; 0 = off; default that of "
                  "voxcap/edge/bgmodel.h)")
      ->check(CLI::Range(0, static_cast<int>(VC_SUBTRACT_GROW_PX_MAX)));
  sil->add_option("--grow-sigma", opt->grow_sigma,
                  "The limb-scale cue's weak pixel (noise sigmas pooled over the channels; default that "
                  "of voxcap/edge/bgmodel.h)")
      ->check(CLI::Range(0.01, VC_SUBTRACT_GROW_SIGMA_MAX));
  sil->add_option("--grow-flat", opt->grow_flat,
                  "The limb-scale cue in the shadow band where the background is flat (noise variances "
                  "per pixel; 0 = never; default that of voxcap/edge/bgmodel.h)")
      ->check(CLI::Range(0.0, VC_SUBTRACT_GROW_FLAT_MAX));
  sil->add_option("--nodes", opt->nodes,
                  "Score a rig of N nodes (2 cameras each, all of them): each node's hull carved from its "
                  "masks, merged, against the true occupancy (0 = masks only)")
      ->check(CLI::Range(0, 32))
      ->capture_default_str();
  sil->add_option("--grid", opt->grid, "With --nodes: voxels per axis of the emulated rig's volume")
      ->check(CLI::Range(8, 512))
      ->capture_default_str();
  sil->add_option("--carve", opt->carve, "With --nodes: the edges' carve rule (centre, footprint, subpixel)")
      ->capture_default_str();
  sil->add_flag("--json", *json, "Print JSON instead of a table");
  sil->callback([=] {
    vc::bench::SilhouetteBenchOptions o = *opt;
    if (std::sscanf(size->c_str(), "%dx%d", &o.width, &o.height) != 2)
      throw UsageError("--size: expected WxH");
    std::string why;
    if (!o.valid(&why)) throw UsageError(why);
    nlohmann::json j;
    try {
      j = vc::bench::run_silhouette_bench(o);
    } catch (const std::invalid_argument& e) {
      throw UsageError(e.what());  // an unknown motion, appearance or room
    }
    if (*json)
      fmt::print("{}\n", j.dump(2));
    else
      vc::bench::print_silhouette_table(j);
  });
}

// "voxcap" when run as `voxcap bench` (argv[0] "<path>/voxcap bench"), else this program's name.
std::string program_name(const char* argv0) {
  std::string first = argv0 ? argv0 : "voxcap-bench";
  first = first.substr(0, first.find(' '));
  const size_t slash = first.rfind('/');
  return slash == std::string::npos ? first : first.substr(slash + 1);
}

}  // namespace

int main(int argc, char** argv) {
  std::string name = "voxcap-bench";
  try {
    name = program_name(argc > 0 ? argv[0] : nullptr);
    CLI::App app{"voxcap-bench — the benchmarks behind `voxcap bench` (keys in tests/bench/README.md)"};
    app.require_subcommand(1, 1);
    add_edge_command(app);
    add_host_command(app);
    add_silhouettes_command(app);
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);  // --help
      std::string msg = e.what();  // bad input: one line and exit 2, as `voxcap` (not CLI11's 105, 106)
      for (char& c : msg)
        if (c == '\n') c = ' ';
      std::fprintf(stderr, "%s: %s (see --help)\n", name.c_str(), msg.c_str());
      return 2;
    }
  } catch (const UsageError& e) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), e.what());
    return 1;
  }
  return 0;
}
