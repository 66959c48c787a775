// `voxcap bench edge|host|silhouettes ...`: the benchmarks live in their own program, voxcap-bench
// (tests/bench), so that voxcap links none of the bench code. This execs voxcap-bench from beside this
// executable (as `voxcap rig --emulated` finds voxcap-edge) with every argument after the subcommand's name,
// --help included: flags, output, JSON keys and exit codes are voxcap-bench's. argv[0] becomes
// "<voxcap's argv[0]> bench" so that its usage lines and error prefixes read `voxcap bench ...`.
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/core.h>
#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "voxcap/base/programs.hpp"

namespace vc::cli {
namespace {

namespace fs = std::filesystem;

[[noreturn]] void exec_bench(const std::string& voxcap_argv0, const std::string& group,
                             const std::vector<std::string>& rest) {
  const fs::path bin = vc::find_program("voxcap-bench");
  if (bin.empty()) {
    std::string where;
    for (const fs::path& p : vc::program_candidates("voxcap-bench"))
      where += (where.empty() ? "" : ", ") + p.string();
    throw std::runtime_error(
        fmt::format("voxcap-bench not found (looked in {}; build the voxcap-bench target)", where));
  }
  std::vector<std::string> args{voxcap_argv0 + " bench", group};
  args.insert(args.end(), rest.begin(), rest.end());
  std::vector<char*> argv;
  argv.reserve(args.size() + 1);
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::fflush(stdout);
  std::fflush(stderr);
  execv(bin.c_str(), argv.data());
  throw std::runtime_error(fmt::format("cannot run {}: {}", bin.string(), std::strerror(errno)));
}

}  // namespace

void add_bench_commands(CLI::App& app) {
  auto* bench = app.add_subcommand("bench", "Benchmarks of the rig's hot paths");
  bench->require_subcommand(1, 1);
  struct Group {
    const char* name;
    const char* description;
  };
  // The descriptions `voxcap bench --help` lists; each group's own --help comes from voxcap-bench.
  for (const Group g :
       {Group{
            "edge",
            "Edge per-frame work (2 cameras: subtraction, clean-up, carving, RLE) vs OpenCV MOG2 and a plain "
            "LUT carve"},
        Group{"host",
              "Host: merge cost per frame (3/4/8 nodes, 64^3..256^3), the emulated rig's fps, latency and "
              "memory"},
        Group{"silhouettes",
              "The edge's masks (subtraction + clean-up) against hw/sim's truth: recall per camera and body "
              "part, "
              "precision, floor shadow kept"}}) {
    auto* sub = bench->add_subcommand(g.name, g.description);
    sub->prefix_command();  // every argument after the group's name goes to voxcap-bench as given
    sub->set_help_flag();   // --help too
    const std::string name = g.name;
    sub->callback([&app, sub, name] { exec_bench(app.get_name(), name, sub->remaining()); });
  }
}

}  // namespace vc::cli
