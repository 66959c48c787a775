// rig.toml -> RigConfig: the one place where TOML is read. A small reader walks each table, checks
// every value's type, remembers the line of every key (so later validation errors can point at it)
// and rejects keys it was not asked for, suggesting the nearest known one.
#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include <fmt/format.h>

#include "voxcap/config/rig_config.hpp"
#include "voxcap/rig/input_file.hpp"

#ifndef VOXCAP_DEFAULT_RIG
#define VOXCAP_DEFAULT_RIG ""
#endif

namespace vc::config {

namespace {

// Every error is one line (a quoted TOML key or a parser's description may hold a newline).
std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

}  // namespace

ConfigError::ConfigError(std::string file, std::string key, std::string problem, int line)
    : std::runtime_error(one_line(fmt::format("{}: {}{}{}", file, key.empty() ? "" : key + ": ", problem,
                                              line > 0 ? fmt::format(" (line {})", line) : ""))),
      file_(std::move(file)),
      key_(std::move(key)),
      line_(line) {}

namespace {

std::string type_name(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::string:
      return "a string";
    case toml::node_type::integer:
      return "an integer";
    case toml::node_type::floating_point:
      return "a floating-point number";
    case toml::node_type::boolean:
      return "a boolean";
    case toml::node_type::table:
      return "a table";
    case toml::node_type::array:
      return "an array";
    default:
      return "a date/time";
  }
}

size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diag = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

// Shared state of one load: the file name for messages and the line of every key path seen.
struct Context {
  std::string file;
  std::map<std::string, int> lines;

  [[noreturn]] void fail(const std::string& key, const std::string& problem) const {
    throw ConfigError(file, key, problem, line_of(key));
  }
  // Line of a key path, or of its nearest recorded ancestor ("trigger.udp.targets[3]" -> "...targets").
  int line_of(std::string key) const {
    while (!key.empty()) {
      if (auto it = lines.find(key); it != lines.end()) return it->second;
      const size_t cut = key.find_last_of(".[");
      if (cut == std::string::npos) break;
      key.resize(cut);
    }
    return 0;
  }
  void note(const std::string& key, const toml::node& node) {
    const int line = static_cast<int>(node.source().begin.line);
    if (line > 0) lines.emplace(key, line);
  }
};

// One TOML table being read. Each get_* consumes a key; finish() rejects the ones nobody asked for.
class Reader {
 public:
  Reader(const toml::table& table, std::string path, Context& ctx)
      : table_(table), path_(std::move(path)), ctx_(ctx) {
    for (auto&& [k, v] : table_) ctx_.note(key(std::string(k.str())), v);
  }

  std::string key(std::string_view k) const {
    return path_.empty() ? std::string(k) : path_ + "." + std::string(k);
  }

  const toml::node* find(std::string_view k) {
    known_.insert(std::string(k));
    return table_.get(k);
  }

  bool get(std::string_view k, std::string* out) {
    const toml::node* n = find(k);
    if (!n) return false;
    if (!n->is_string()) ctx_.fail(key(k), "expected a string, got " + type_name(*n));
    *out = n->as_string()->get();
    return true;
  }

  bool get(std::string_view k, bool* out) {
    const toml::node* n = find(k);
    if (!n) return false;
    if (!n->is_boolean()) ctx_.fail(key(k), "expected true or false, got " + type_name(*n));
    *out = n->as_boolean()->get();
    return true;
  }

  bool get(std::string_view k, double* out) {
    const toml::node* n = find(k);
    if (!n) return false;
    *out = number(*n, key(k));
    return true;
  }

  // Integers are range-checked here (they are narrowed); finer limits are the option's valid().
  template <typename Int>
  bool get_int(std::string_view k, Int* out, int64_t lo, int64_t hi) {
    const toml::node* n = find(k);
    if (!n) return false;
    *out = static_cast<Int>(integer(*n, key(k), lo, hi));
    return true;
  }

  const toml::table* table(std::string_view k) {
    const toml::node* n = find(k);
    if (!n) return nullptr;
    if (!n->is_table()) ctx_.fail(key(k), "expected a table, got " + type_name(*n));
    return n->as_table();
  }

  const toml::array* array(std::string_view k) {
    const toml::node* n = find(k);
    if (!n) return nullptr;
    if (!n->is_array()) ctx_.fail(key(k), "expected an array, got " + type_name(*n));
    return n->as_array();
  }

  std::vector<std::string> strings(std::string_view k) {
    std::vector<std::string> out;
    const toml::array* a = array(k);
    if (!a) return out;
    for (size_t i = 0; i < a->size(); ++i) {
      const toml::node& n = *a->get(i);
      const std::string ki = fmt::format("{}[{}]", key(k), i);
      ctx_.note(ki, n);
      if (!n.is_string()) ctx_.fail(ki, "expected a string, got " + type_name(n));
      out.push_back(n.as_string()->get());
    }
    return out;
  }

  double number(const toml::node& n, const std::string& k) const {
    double v = 0;
    if (n.is_floating_point())
      v = n.as_floating_point()->get();
    else if (n.is_integer())
      v = static_cast<double>(n.as_integer()->get());
    else
      ctx_.fail(k, "expected a number, got " + type_name(n));
    if (!std::isfinite(v)) ctx_.fail(k, fmt::format("must be a finite number, got {}", v));  // nan, inf
    return v;
  }

  int64_t integer(const toml::node& n, const std::string& k, int64_t lo, int64_t hi) const {
    if (!n.is_integer()) ctx_.fail(k, "expected an integer, got " + type_name(n));
    const int64_t v = n.as_integer()->get();
    if (v < lo || v > hi) ctx_.fail(k, fmt::format("must be in [{}, {}], got {}", lo, hi, v));
    return v;
  }

  void finish() const {
    for (auto&& [k, v] : table_) {
      const std::string name(k.str());
      if (known_.count(name)) continue;
      std::string hint;
      size_t best = 3;
      for (const std::string& cand : known_) {
        const size_t d = edit_distance(name, cand);
        if (d < best) {
          best = d;
          hint = fmt::format(" (did you mean \"{}\"?)", cand);
        }
      }
      std::string known_list;
      for (const std::string& cand : known_) known_list += (known_list.empty() ? "" : ", ") + cand;
      ctx_.fail(key(name), fmt::format("unknown key{}; {} takes: {}", hint,
                                       path_.empty() ? "the top level" : "[" + path_ + "]", known_list));
    }
  }

  Context& ctx() { return ctx_; }

 private:
  const toml::table& table_;
  std::string path_;
  Context& ctx_;
  std::set<std::string> known_;
};

// Throws a ConfigError for a failed valid(): `why` starts with a key path relative to `section`.
[[noreturn]] void fail_validation(const Context& ctx, const std::string& section, const std::string& why) {
  const size_t colon = why.find(": ");
  std::string key = colon == std::string::npos ? std::string() : why.substr(0, colon);
  const std::string problem = colon == std::string::npos ? why : why.substr(colon + 2);
  if (!section.empty()) key = key.empty() ? section : section + "." + key;
  ctx.fail(key, problem);
}

void read_subtraction(Reader& r, SubtractionOptions* o) {
  r.get("t_upper", &o->t_upper);
  r.get("t_lower", &o->t_lower);
  r.get("shadow_angle_deg", &o->shadow_angle_deg);
  r.get_int("cleanup_radius_px", &o->cleanup_radius_px, 0, 1000);
  r.get_int("background_frames", &o->background_frames, 0, 100000);
  r.finish();
}

void read_carving(Reader& r, CarvingOptions* o) {
  std::string rule;
  if (r.get("rule", &rule) && !parse_carve_rule(rule, &o->rule))
    r.ctx().fail(r.key("rule"),
                 fmt::format("must be \"subpixel\", \"footprint\" or \"centre\", got \"{}\"", rule));
  r.finish();
}

void read_silhouettes(Reader& r, SilhouetteOptions* o) {
  r.get_int("every", &o->every, 0, 100000);
  r.get_int("scale", &o->scale, 0, 100000);
  r.finish();
}

void read_triangulation(Reader& r, TriangulationOptions* o) {
  r.get("enabled", &o->enabled);
  r.get("min_confidence", &o->min_confidence);
  r.get("predicted_weight", &o->predicted_weight);
  r.get("inlier_px", &o->inlier_px);
  r.get_int("refine_iterations", &o->refine_iterations, 0, 1000);
  r.get("confident", &o->confident);
  r.get("swap_ratio", &o->swap_ratio);
  r.get_int("identity_gap_frames", &o->identity_gap_frames, 0, 10000000);
  r.finish();
}

void read_fitting(Reader& r, FittingOptions* o, const std::filesystem::path& source) {
  r.get("enabled", &o->enabled);
  r.get_int("samples", &o->samples, 0, 1000000);
  r.get_int("steps", &o->steps, 0, 1000000);
  r.get("span_deg", &o->span_deg);
  r.get("k", &o->k);
  r.get("straight_deg", &o->straight_deg);
  std::string smoothing;
  if (r.get("smoothing", &smoothing)) {
    if (smoothing == "none")
      o->smoothing = Smoothing::None;
    else if (smoothing == "one-euro")
      o->smoothing = Smoothing::OneEuro;
    else
      r.ctx().fail(r.key("smoothing"),
                   fmt::format("must be \"none\" or \"one-euro\", got \"{}\"", smoothing));
  }
  r.get("one_euro_min_cutoff", &o->one_euro_min_cutoff);
  r.get("one_euro_beta", &o->one_euro_beta);
  std::string body;
  if (r.get("body", &body) && !body.empty()) {
    std::filesystem::path p(body);
    if (p.is_relative()) p = source.parent_path() / p;
    o->body = std::filesystem::absolute(p).lexically_normal();
  }
  r.get_int("init_frames", &o->init_frames, 0, 10000000);
  r.get_int("reinit_after_frames", &o->reinit_after_frames, 0, 10000000);
  r.get_int("predict_frames", &o->predict_frames, 0, 10000000);
  r.get("follow_pair_swaps", &o->follow_pair_swaps);
  r.finish();
}

void read_trigger(Reader& r, TriggerOptions* o) {
  std::string backend;
  if (r.get("backend", &backend) && !parse_trigger_backend(backend, &o->backend))
    r.ctx().fail(r.key("backend"),
                 fmt::format("must be \"udp\", \"gpiod\" or \"ftdi\", got \"{}\"", backend));
  r.get("rate_hz", &o->rate_hz);
  r.get("pulse_width_us", &o->pulse_width_us);
  r.get("active_low", &o->active_low);
  r.get_int("rt_priority", &o->rt_priority, 0, 99);
  r.get("late_threshold_us", &o->late_threshold_us);

  if (const toml::table* t = r.table("udp")) {
    Reader u(*t, r.key("udp"), r.ctx());
    const std::vector<std::string> targets = u.strings("targets");
    o->udp.targets.clear();
    for (size_t i = 0; i < targets.size(); ++i) {
      Endpoint e;
      std::string why;
      if (!Endpoint::parse(targets[i], &e, &why))
        r.ctx().fail(fmt::format("{}[{}]", u.key("targets"), i), why);
      o->udp.targets.push_back(e);
    }
    u.finish();
  }
  if (const toml::table* t = r.table("gpiod")) {
    Reader g(*t, r.key("gpiod"), r.ctx());
    g.get("chip", &o->gpiod.chip);
    if (const toml::node* line = g.find("line")) {
      if (line->is_integer()) {
        o->gpiod.line_offset = static_cast<int>(g.integer(*line, g.key("line"), 0, 1023));
        o->gpiod.line_name.clear();
      } else if (line->is_string()) {
        o->gpiod.line_name = line->as_string()->get();
        o->gpiod.line_offset = -1;
        if (o->gpiod.line_name.empty()) r.ctx().fail(g.key("line"), "a line name must not be empty");
      } else {
        r.ctx().fail(g.key("line"),
                     "expected a line offset (integer) or a line name (string), got " + type_name(*line));
      }
    }
    g.finish();
  }
  if (const toml::table* t = r.table("ftdi")) {
    Reader f(*t, r.key("ftdi"), r.ctx());
    f.get_int("vid", &o->ftdi.vid, 0, 0xffff);
    f.get_int("pid", &o->ftdi.pid, 0, 0xffff);
    f.get("serial", &o->ftdi.serial);
    f.get("description", &o->ftdi.description);
    std::string iface;
    if (f.get("interface", &iface)) {
      if (iface.size() != 1)
        r.ctx().fail(f.key("interface"),
                     fmt::format("must be \"A\", \"B\", \"C\" or \"D\", got \"{}\"", iface));
      o->ftdi.interface = iface[0];
    }
    f.get_int("pin", &o->ftdi.pin, 0, 255);
    f.get_int("sample_rate_hz", &o->ftdi.sample_rate_hz, 1, std::numeric_limits<uint32_t>::max());
    f.get_int("buffer_ms", &o->ftdi.buffer_ms, 0, 100000);
    f.finish();
  }
  r.finish();
}

void read_assembly(Reader& r, AssemblyOptions* o) {
  r.get("deadline_ms", &o->deadline_ms);
  std::string policy;
  if (r.get("missing_node_policy", &policy)) {
    if (policy == "drop")
      o->missing_node_policy = MissingNodePolicy::Drop;
    else if (policy == "degraded")
      o->missing_node_policy = MissingNodePolicy::Degraded;
    else
      r.ctx().fail(r.key("missing_node_policy"),
                   fmt::format("must be \"drop\" or \"degraded\", got \"{}\"", policy));
  }
  r.finish();
}

void read_node(Reader& r, NodeConfig* n) {
  if (!r.get("id", &n->id)) r.ctx().fail(r.key("id"), "missing (every node needs an id)");
  r.get("address", &n->address);
  uint16_t number = 0;
  if (r.get_int("number", &number, 0, 65535)) n->number = number;
  n->cameras = r.strings("cameras");
  if (!r.find("cameras")) r.ctx().fail(r.key("cameras"), "missing (the node's two camera names)");
  std::string role;
  if (r.get("role", &role)) {
    if (role == "front")
      n->role = NodeRole::Front;
    else if (role == "side")
      n->role = NodeRole::Side;
    else
      r.ctx().fail(r.key("role"), fmt::format("must be \"front\" or \"side\", got \"{}\"", role));
  }
  bool track = false;
  if (r.get("track", &track)) n->track = track;
  r.find("ssh");     // the board's ssh target and its own [deploy] overrides: read by host/deploy
  r.find("deploy");  // (voxcap deploy), which checks them; the host itself never uses them
  r.finish();
}

bool read_grid(Reader& r, rig::VoxelGrid* g) {
  const toml::array* min = r.array("min_m");
  if (!min) r.ctx().fail(r.key("min_m"), "missing (the grid's min corner [x, y, z] in metres)");
  if (min->size() != 3)
    r.ctx().fail(r.key("min_m"), fmt::format("expected 3 numbers [x, y, z], got {}", min->size()));
  for (int i = 0; i < 3; ++i)
    g->min_m[i] = r.number(*min->get(static_cast<size_t>(i)), fmt::format("{}[{}]", r.key("min_m"), i));
  if (!r.get("voxel_m", &g->voxel_m)) r.ctx().fail(r.key("voxel_m"), "missing (the voxel edge in metres)");
  const char* dims[] = {"nx", "ny", "nz"};
  int* out[] = {&g->nx, &g->ny, &g->nz};
  for (int i = 0; i < 3; ++i)
    if (!r.get_int(dims[i], out[i], 1, 4096)) r.ctx().fail(r.key(dims[i]), "missing (voxels along the axis)");
  r.finish();
  return true;
}

// [hil.loopback], [hil.edge_input]: a GPIO input line, by offset or by name (as [trigger.gpiod]).
void read_hil_line(Reader& r, HilLine* l) {
  r.get("chip", &l->chip);
  if (l->chip.empty()) r.ctx().fail(r.key("chip"), "missing (the input's GPIO chip, e.g. \"gpiochip0\")");
  const toml::node* line = r.find("line");
  if (!line) r.ctx().fail(r.key("line"), "missing (the input line's offset or name, e.g. 17 or \"GPIO17\")");
  if (line->is_integer()) {
    l->line_offset = static_cast<int>(r.integer(*line, r.key("line"), 0, 1023));
  } else if (line->is_string() && !line->as_string()->get().empty()) {
    l->line_name = line->as_string()->get();
  } else {
    r.ctx().fail(r.key("line"),
                 "expected a line offset (integer) or a line name (string), got " + type_name(*line));
  }
  bool active_low = false;
  if (r.get("active_low", &active_low)) l->active_low = active_low;
  r.get_int("debounce_us", &l->debounce_us, 0, 100000);
  r.finish();
}

void read_hil(Reader& r, HilOptions* o) {
  o->present = true;
  if (const toml::table* t = r.table("loopback")) {
    Reader l(*t, r.key("loopback"), r.ctx());
    read_hil_line(l, &o->loopback);
  }
  if (const toml::table* t = r.table("edge_input")) {
    Reader l(*t, r.key("edge_input"), r.ctx());
    read_hil_line(l, &o->edge_input);
  }
  if (const toml::array* cams = r.array("cameras")) {
    if (cams->size() > 16)
      r.ctx().fail(r.key("cameras"), fmt::format("at most 16 cameras, got {}", cams->size()));
    for (size_t i = 0; i < cams->size(); ++i) {
      const std::string key = fmt::format("{}[{}]", r.key("cameras"), i);
      const toml::node& n = *cams->get(i);
      r.ctx().note(key, n);
      if (!n.is_table()) r.ctx().fail(key, "expected a table ([[hil.cameras]]), got " + type_name(n));
      Reader c(*n.as_table(), key, r.ctx());
      HilCamera cam;
      c.get("backend", &cam.backend);
      c.get("device", &cam.device);
      c.get("format", &cam.format);
      c.get_int("width", &cam.width, 0, 16384);
      c.get_int("height", &cam.height, 0, 16384);
      c.get_int("exposure_us", &cam.exposure_us, 0, 10000000);
      c.get("latency_us", &cam.latency_us);
      c.finish();
      o->cameras.push_back(std::move(cam));
    }
  }
  r.get_int("pulses", &o->pulses, 1, 1000000);
  if (const toml::array* rates = r.array("rates_hz")) {
    o->rates_hz.clear();
    for (size_t i = 0; i < rates->size() && i < 9; ++i)
      o->rates_hz.push_back(r.number(*rates->get(i), fmt::format("{}[{}]", r.key("rates_hz"), i)));
  }
  r.get("smoke_seconds", &o->smoke_seconds);
  r.get("max_jitter_us", &o->max_jitter_us);
  r.get("max_offset_us", &o->max_offset_us);
  r.finish();
}

// The checks that need nothing but this file (RigConfig::valid() repeats them with the cross-checks).
void check_sections(const RigConfig& c, const Context& ctx) {
  std::string why;
  for (size_t i = 0; i < c.nodes.size(); ++i)
    if (!c.nodes[i].valid(&why)) fail_validation(ctx, fmt::format("nodes[{}]", i), why);
  if (!c.subtraction.valid(&why)) fail_validation(ctx, "subtraction", why);
  if (!c.carving.valid(&why)) fail_validation(ctx, "carving", why);
  if (!c.silhouettes.valid(&why)) fail_validation(ctx, "silhouettes", why);
  if (!c.triangulation.valid(&why)) fail_validation(ctx, "triangulation", why);
  if (!c.fitting.valid(&why)) fail_validation(ctx, "fitting", why);
  if (!c.trigger.valid(&why)) fail_validation(ctx, "trigger", why);
  if (!c.assembly.valid(&why)) fail_validation(ctx, "assembly", why);
  if (!c.recording.valid(&why)) fail_validation(ctx, "recording", why);
  if (!c.network.valid(&why)) fail_validation(ctx, "network", why);
  if (!c.hil.valid(&why)) fail_validation(ctx, "hil", why);
  if (!c.vmc.valid(&why)) fail_validation(ctx, "vmc", why);
  if (!c.viewer.valid(&why)) fail_validation(ctx, "viewer", why);
}

void collect_warnings(RigConfig* c) {
  if (c->vmc.enabled && !c->vmc.target.is_loopback())
    c->warnings.push_back(fmt::format(
        "vmc.target: {} is not on this machine: every pose goes out on the network, unauthenticated",
        c->vmc.target.str()));
  if (c->trigger.backend == TriggerBackend::Udp && c->trigger.udp.targets.size() > c->nodes.size())
    c->warnings.push_back(
        fmt::format("trigger.udp.targets: {} targets for {} nodes; the extra ones get pulses too",
                    c->trigger.udp.targets.size(), c->nodes.size()));
  for (size_t k = 0; k < c->calibration.cameras.size(); ++k) {
    const std::string& name = c->calibration.cameras[k].name;
    bool used = false;
    for (const NodeConfig& n : c->nodes)
      for (const std::string& cam : n.cameras)
        if (c->camera_index(cam) == static_cast<int>(k)) used = true;
    if (!used)
      c->warnings.push_back(fmt::format("calibration camera {} (cam{}) is not driven by any node", name, k));
  }
}

}  // namespace

RigConfig parse_rig_config(std::string_view toml_text, const std::filesystem::path& source,
                           const LoadOptions& options) {
  Context ctx;
  ctx.file = source.string();
  toml::table root;
  try {
    root = toml::parse(toml_text, ctx.file);
  } catch (const toml::parse_error& e) {
    throw ConfigError(ctx.file, "", fmt::format("TOML syntax error: {}", e.description()),
                      static_cast<int>(e.source().begin.line));
  }

  RigConfig c;
  c.source = source;
  c.name = source.stem().string();
  Reader top(root, "", ctx);
  int64_t version = 1;
  if (top.get_int("version", &version, 1, 1000) && version != 1)
    ctx.fail("version", fmt::format("this voxcap reads version 1 rig files, got {}", version));
  top.get("name", &c.name);
  std::string calibration;
  if (!top.get("calibration", &calibration) || calibration.empty())
    ctx.fail("calibration", "missing (the rig.yaml calibration file, relative to this file)");
  c.calibration_path = std::filesystem::path(calibration);
  if (c.calibration_path.is_relative()) c.calibration_path = source.parent_path() / c.calibration_path;
  c.calibration_path = std::filesystem::absolute(c.calibration_path).lexically_normal();
  std::string key_file;  // the rig key file (`voxcap key new`), relative to this file; none: loopback only
  if (top.get("key", &key_file) && !key_file.empty()) {
    c.key_path = std::filesystem::path(key_file);
    if (c.key_path.is_relative()) c.key_path = source.parent_path() / c.key_path;
    c.key_path = std::filesystem::absolute(c.key_path).lexically_normal();
  }

  bool have_grid = false;
  if (const toml::table* t = top.table("grid")) {
    Reader r(*t, "grid", ctx);
    have_grid = read_grid(r, &c.grid);
  }
  if (const toml::array* nodes = top.array("nodes")) {
    for (size_t i = 0; i < nodes->size(); ++i) {
      const std::string key = fmt::format("nodes[{}]", i);
      const toml::node& n = *nodes->get(i);
      ctx.note(key, n);
      if (!n.is_table()) ctx.fail(key, "expected a table ([[nodes]]), got " + type_name(n));
      Reader r(*n.as_table(), key, ctx);
      NodeConfig node;
      read_node(r, &node);
      if (!node.number) {  // once, here: an explicit `number`, else the number the id is or ends in
        std::string why;
        node.number = parse_node_number(node.id, &why);
        if (!node.number) ctx.fail(key + ".id", why + ", or give the node a `number` (0..65535)");
      }
      c.nodes.push_back(std::move(node));
    }
  }
  if (const toml::table* t = top.table("subtraction")) {
    Reader r(*t, "subtraction", ctx);
    read_subtraction(r, &c.subtraction);
  }
  if (const toml::table* t = top.table("carving")) {
    Reader r(*t, "carving", ctx);
    read_carving(r, &c.carving);
  }
  if (const toml::table* t = top.table("silhouettes")) {
    Reader r(*t, "silhouettes", ctx);
    read_silhouettes(r, &c.silhouettes);
  }
  if (const toml::table* t = top.table("features")) {
    Reader r(*t, "features", ctx);
    r.get("enabled", &c.features.enabled);
    r.finish();
  }
  // [tracking]: which nodes track head, hands and feet (a node's own `track` key wins).
  if (const toml::table* t = top.table("tracking")) {
    Reader r(*t, "tracking", ctx);
    std::string nodes;
    if (r.get("nodes", &nodes) && !parse_tracking_nodes(nodes, &c.tracking.nodes))
      r.ctx().fail(r.key("nodes"), fmt::format("must be \"all\" or \"front\", got \"{}\"", nodes));
    r.finish();
  }
  if (const toml::table* t = top.table("triangulation")) {
    Reader r(*t, "triangulation", ctx);
    read_triangulation(r, &c.triangulation);
  }
  if (const toml::table* t = top.table("fitting")) {
    Reader r(*t, "fitting", ctx);
    read_fitting(r, &c.fitting, source);
  }
  if (const toml::table* t = top.table("trigger")) {
    Reader r(*t, "trigger", ctx);
    read_trigger(r, &c.trigger);
  }
  if (const toml::table* t = top.table("assembly")) {
    Reader r(*t, "assembly", ctx);
    read_assembly(r, &c.assembly);
  }
  if (const toml::table* t = top.table("recording")) {
    Reader r(*t, "recording", ctx);
    std::string dir;
    if (r.get("dir", &dir)) c.recording.dir = dir;
    r.finish();
  }
  if (const toml::table* t = top.table("network")) {
    Reader r(*t, "network", ctx);
    r.get("listen", &c.network.listen);
    r.get_int("port", &c.network.port, 1, 65535);
    // Narrowed to int here; the finer bounds are NetworkOptions::valid's (its message says why).
    constexpr int64_t kHi = NetworkOptions::kMaxHeartbeatTimeoutMs;
    r.get_int("heartbeat_interval_ms", &c.network.heartbeat_interval_ms, 0, kHi);
    r.get_int("heartbeat_timeout_ms", &c.network.heartbeat_timeout_ms, 0, kHi);
    r.finish();
  }
  if (const toml::table* t = top.table("hil")) {
    Reader r(*t, "hil", ctx);
    read_hil(r, &c.hil);
  }
  top.find("deploy");  // [deploy]: how voxcap deploy reaches and sets up the boards (host/deploy checks it)
  if (const toml::table* t = top.table("vmc")) {  // the live pose stream out (host/stream)
    Reader r(*t, "vmc", ctx);
    r.get("enabled", &c.vmc.enabled);
    std::string target, why;
    if (r.get("target", &target) && !Endpoint::parse(target, &c.vmc.target, &why))
      r.ctx().fail(r.key("target"), why);
    r.get("rate_hz", &c.vmc.rate_hz);
    r.finish();
  }
  if (const toml::table* t = top.table("viewer")) {
    Reader r(*t, "viewer", ctx);
    r.get("enabled", &c.viewer.enabled);
    r.get("bind", &c.viewer.bind);
    r.get_int("port", &c.viewer.port, 1, 65535);
    std::string assets;
    if (r.get("assets", &assets)) {
      c.viewer.assets = assets;
      if (c.viewer.assets.is_relative()) c.viewer.assets = source.parent_path() / c.viewer.assets;
      c.viewer.assets = std::filesystem::absolute(c.viewer.assets).lexically_normal();
    }
    r.finish();
  }
  top.finish();

  // Errors in this file first, then those that need the calibration file.
  check_sections(c, ctx);
  if (options.load_calibration) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(c.calibration_path, ec))
      ctx.fail("calibration", fmt::format("file not found: {}", c.calibration_path.string()));
    try {
      c.calibration = rig::read_calibration(c.calibration_path.string());
    } catch (const std::exception& e) {
      ctx.fail("calibration", e.what());
    }
  }
  if (have_grid) {
    c.grid_source = GridSource::Config;
  } else if (c.calibration.grid) {
    c.grid = *c.calibration.grid;
    c.grid_source = GridSource::Calibration;
  } else {
    ctx.fail("grid", options.load_calibration
                         ? fmt::format("missing, and the calibration file {} has no grid either",
                                       c.calibration_path.filename().string())
                         : std::string("missing (needed when the calibration is not loaded)"));
  }

  std::string why;
  if (!c.valid(&why)) fail_validation(ctx, "", why);
  collect_warnings(&c);
  return c;
}

RigConfig load_rig_config(const std::filesystem::path& path, const LoadOptions& options) {
  std::string text;
  try {  // a regular file of at most kMaxRigTomlBytes: a FIFO or a device is refused, never waited on
    text = rig::read_input_file(path.string(), kMaxRigTomlBytes);
  } catch (const std::runtime_error& e) {
    std::string what = e.what();  // "PATH: problem"
    const std::string prefix = path.string() + ": ";
    if (what.rfind(prefix, 0) == 0) what.erase(0, prefix.size());
    throw ConfigError(path.string(), "", "cannot open the rig configuration: " + what);
  }
  return parse_rig_config(text, path, options);
}

// Here rather than in options.cpp: [triangulation] is read and checked in this file alone.
bool TriangulationOptions::valid(std::string* why) const {
  auto bad = [why](std::string m) {
    if (why) *why = std::move(m);
    return false;
  };
  auto unit = [](double x) { return x >= 0 && x <= 1; };
  if (!unit(min_confidence))
    return bad(fmt::format("min_confidence: must be in [0, 1], got {}", min_confidence));
  if (!unit(predicted_weight))
    return bad(fmt::format("predicted_weight: must be in [0, 1], got {}", predicted_weight));
  if (!(inlier_px > 0 && inlier_px <= 1000))
    return bad(fmt::format("inlier_px: must be in (0, 1000], got {}", inlier_px));
  if (refine_iterations < 0 || refine_iterations > 50)
    return bad(fmt::format("refine_iterations: must be in [0, 50], got {}", refine_iterations));
  if (!unit(confident)) return bad(fmt::format("confident: must be in [0, 1], got {}", confident));
  if (!(swap_ratio > 0 && swap_ratio < 1))
    return bad(fmt::format("swap_ratio: must be in (0, 1), got {}", swap_ratio));
  if (identity_gap_frames < 1 || identity_gap_frames > 100000)
    return bad(fmt::format("identity_gap_frames: must be in [1, 100000], got {}", identity_gap_frames));
  return true;
}

// Here rather than in options.cpp: [fitting] is read and checked in this file alone.
bool FittingOptions::valid(std::string* why) const {
  auto bad = [why](std::string m) {
    if (why) *why = std::move(m);
    return false;
  };
  if (samples < 8 || samples > 4096)
    return bad(fmt::format("samples: must be in [8, 4096], got {}", samples));
  if (steps < 1 || steps > 360) return bad(fmt::format("steps: must be in [1, 360], got {}", steps));
  if (!(span_deg > 0 && span_deg <= 180))
    return bad(fmt::format("span_deg: must be in (0, 180], got {}", span_deg));
  if (!(k >= 1 && k <= 16)) return bad(fmt::format("k: must be in [1, 16], got {}", k));
  if (!(straight_deg >= 0 && straight_deg < 90))
    return bad(fmt::format("straight_deg: must be in [0, 90), got {}", straight_deg));
  if (!(one_euro_min_cutoff > 0 && one_euro_min_cutoff <= 1000))
    return bad(fmt::format("one_euro_min_cutoff: must be in (0, 1000] Hz, got {}", one_euro_min_cutoff));
  if (!(one_euro_beta >= 0 && one_euro_beta <= 1000))
    return bad(fmt::format("one_euro_beta: must be in [0, 1000], got {}", one_euro_beta));
  if (init_frames < 1 || init_frames > 600)
    return bad(fmt::format("init_frames: must be in [1, 600], got {}", init_frames));
  if (reinit_after_frames < 1 || reinit_after_frames > 100000)
    return bad(fmt::format("reinit_after_frames: must be in [1, 100000], got {}", reinit_after_frames));
  if (predict_frames < 0 || predict_frames > 100000)
    return bad(fmt::format("predict_frames: must be in [0, 100000], got {}", predict_frames));
  return true;
}

std::filesystem::path default_rig_config_path() {
  if (const char* env = std::getenv("VOXCAP_RIG"); env && *env) return env;
  std::error_code ec;
  if (std::filesystem::is_regular_file("rig.toml", ec)) return "rig.toml";
  return VOXCAP_DEFAULT_RIG;
}

}  // namespace vc::config
