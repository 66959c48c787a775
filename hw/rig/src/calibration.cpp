// Calibration file I/O: OpenCV FileStorage YAML, one map per camera (cam0 ... camN-1) and an
// optional voxel grid. Every error names the file and the node, because a rig.yaml is edited by hand.
//
// A rig.yaml may be hostile or broken, and OpenCV's YAML parser is neither bounded nor strict: it
// recurses once per nesting level (100,000 `[` overflow the stack), and it reads an integer with
// strtol into an int (a width of 99999999999 wraps silently). So the text is read first (a regular
// file of at most kMaxCalibrationBytes) and checked by check_yaml_limits() before OpenCV sees it:
// nesting (block indentation levels + `- ` indicators + flow brackets) at most kMaxYamlDepth, lines
// at most kMaxYamlLine bytes, no NUL bytes, every plain integer within int32. Only then is it parsed,
// from memory, and every value checked as before.
#include "voxcap/rig/calibration.hpp"

#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string_view>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/persistence.hpp>

#include "voxcap/rig/input_file.hpp"

namespace vc::rig {
namespace {

constexpr const char* kFormat = "voxcap-rig";
constexpr int kVersion = 1;

[[noreturn]] void fail(const std::string& path, const std::string& node, const std::string& what) {
  throw std::runtime_error(path + ": " + (node.empty() ? "" : node + ": ") + what);
}

// A real matrix node with `count` elements (any shape), as doubles in row-major order.
std::vector<double> read_values(const cv::FileNode& n, const std::string& path, const std::string& node,
                                std::size_t count_min, std::size_t count_max) {
  if (n.isNone()) fail(path, node, "missing");
  std::vector<double> values;
  if (n.isSeq()) {
    for (const auto& e : n) {
      if (!e.isReal() && !e.isInt()) fail(path, node, "expected a sequence of numbers");
      values.push_back(static_cast<double>(e));
    }
  } else if (n.isMap()) {
    // Sized before OpenCV allocates: rows x cols single-channel values, as many as the node may hold.
    const cv::FileNode rows = n["rows"], cols = n["cols"], dt = n["dt"], data = n["data"];
    if (!rows.isInt() || !cols.isInt() || !dt.isString() || !data.isSeq())
      fail(path, node, "expected an opencv-matrix (rows, cols, dt, data) or a sequence of numbers");
    const long long r = static_cast<int>(rows), c = static_cast<int>(cols);
    const std::string type = static_cast<std::string>(dt);
    if (r < 1 || c < 1 || r * c > static_cast<long long>(count_max) || type.size() != 1 ||
        std::string("ucswifd").find(type[0]) == std::string::npos ||
        data.size() != static_cast<std::size_t>(r * c))
      fail(path, node,
           "expected an opencv-matrix of at most " + std::to_string(count_max) +
               " single-channel numbers (rows x cols = the data's length)");
    cv::Mat m;
    try {
      n >> m;
    } catch (const cv::Exception&) {
      fail(path, node, "expected an opencv-matrix or a sequence of numbers");
    }
    if (m.empty() || m.channels() != 1) fail(path, node, "expected an opencv-matrix of numbers");
    m.convertTo(m, CV_64F);
    m = m.reshape(1, 1);
    values.assign(m.ptr<double>(), m.ptr<double>() + m.cols);
  } else {
    fail(path, node, "expected an opencv-matrix or a sequence of numbers");
  }
  if (values.size() < count_min || values.size() > count_max) {
    fail(path, node,
         "expected " + std::to_string(count_min) +
             (count_max != count_min ? ".." + std::to_string(count_max) : std::string()) + " numbers, got " +
             std::to_string(values.size()));
  }
  for (double v : values) {
    if (!std::isfinite(v)) fail(path, node, "values must be finite");
  }
  return values;
}

std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

// A plain scalar that OpenCV would read as an integer (strtol, base 0) must fit an int.
void check_integer(std::string_view token, const std::string& path, const std::string& where) {
  std::size_t i = (token[0] == '+' || token[0] == '-') ? 1 : 0;
  if (i == token.size()) return;
  const bool hex = token.size() > i + 2 && token[i] == '0' && (token[i + 1] == 'x' || token[i + 1] == 'X');
  for (std::size_t k = hex ? i + 2 : i; k < token.size(); ++k) {
    const char c = token[k];
    const bool digit = (c >= '0' && c <= '9') || (hex && ((c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F')));
    if (!digit) return;  // a real, a name, ...: OpenCV does not read it as an integer
  }
  const std::string t(token);
  errno = 0;
  const long long v = std::strtoll(t.c_str(), nullptr, 0);
  if (errno == ERANGE || v > INT_MAX || v < INT_MIN)
    fail(path, where,
         "integer " + t.substr(0, 40) + " is out of range (at most " + std::to_string(INT_MAX) + ")");
}

// One line of the YAML subset OpenCV writes, checked left to right. Anything else is refused: OpenCV's
// own parser loops forever or throws on some malformed text (found by fuzzing), so it only ever sees
// this grammar:
//   line   := indent ("- ")* (key ":" [" " value] | value) [comment]    (block context)
//           | items                                                      (inside an open "[")
//   value  := "!!opencv-matrix" | "[" items | scalar
//   items  := [scalar ("," scalar)*] [","] ["]"]                          (one flow level only)
//   scalar := plain (letters, digits, _ . + - / ( ) @, inner single spaces outside "[") | "..." | '...'
class YamlLine {
 public:
  YamlLine(const YamlLine&) = delete;
  YamlLine(std::string_view l, std::size_t pos, const std::string& path, const std::string& where)
      : l_(l), k_(pos), path_(path), where_(where) {}

  enum class Kind { Map, Seq };
  struct Level {
    std::size_t col;
    Kind kind;
  };
  struct Block {
    std::vector<Level> levels;  // the entries the line starts, left to right ("- - key:" gives three)
    bool opens = false;         // ends with "key:", "-" or a matrix tag: children follow, more indented
    bool flow = false;          // a "[" is still open at the end of the line
  };

  Block block_line() {
    Block b;
    while (k_ + 1 < l_.size() && l_[k_] == '-' && l_[k_ + 1] == ' ') {  // "- - x": nested sequences
      b.levels.push_back({k_, Kind::Seq});
      k_ += 2;
      spaces();
      if (k_ < l_.size() && l_[k_] == '\t') bad("a tab in the indentation");
    }
    if (k_ + 1 == l_.size() && l_[k_] == '-') {  // "-" alone: the item's value on the next lines
      b.levels.push_back({k_, Kind::Seq});
      b.opens = true;
      return b;
    }
    if (at_end()) {
      b.opens = true;
      return b;
    }
    const std::size_t start = k_;
    while (k_ < l_.size() && key_char(l_[k_])) ++k_;
    if (k_ > start && k_ < l_.size() && l_[k_] == ':' && (k_ + 1 == l_.size() || l_[k_ + 1] == ' ')) {
      b.levels.push_back({start, Kind::Map});
      ++k_;
      if (at_end()) {
        b.opens = true;
        return b;
      }
    } else if (b.levels.empty()) {
      bad("expected 'key: value' or '- value'");
    } else {
      k_ = start;
    }
    if (l_.substr(k_, 15) == "!!opencv-matrix") {
      k_ += 15;
      end();
      b.opens = true;
      return b;
    }
    if (l_[k_] == '[') {
      ++k_;
      b.flow = items();
      return b;
    }
    scalar(false);
    end();
    return b;
  }

  // Inside an open "[": returns whether it is still open.
  bool items() {
    for (;;) {
      spaces();
      if (at_end()) return true;
      if (l_[k_] == ']') {
        ++k_;
        end();
        return false;
      }
      scalar(true);
      spaces();
      if (at_end()) return true;
      if (l_[k_] == ',') {
        ++k_;
      } else if (l_[k_] != ']') {
        bad("expected ',' or ']' in a sequence");
      }
    }
  }

 private:
  static bool key_char(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.';
  }
  static bool plain_char(char c) {
    return key_char(c) || c == '+' || c == '/' || c == '(' || c == ')' || c == '@';
  }
  [[noreturn]] void bad(const std::string& what) const { fail(path_, where_, what); }
  void spaces() {
    while (k_ < l_.size() && (l_[k_] == ' ' || l_[k_] == '\t')) ++k_;
  }
  // End of line, or a comment.
  bool at_end() {
    spaces();
    return k_ == l_.size() || l_[k_] == '#';
  }
  void end() {
    if (!at_end()) bad("unexpected '" + std::string(1, l_[k_]) + "'");
  }
  void scalar(bool in_flow) {
    const char q = l_[k_];
    if (q == '"' || q == '\'') {
      const std::size_t close = l_.find(q, k_ + 1);
      if (close == std::string_view::npos) bad("unterminated quoted string");
      for (std::size_t i = k_ + 1; i < close; ++i)
        if (l_[i] == '\\' || static_cast<unsigned char>(l_[i]) < 0x20)
          bad("escapes and control characters are not allowed in strings");
      k_ = close + 1;
      return;
    }
    const std::size_t start = k_;
    while (k_ < l_.size()) {
      if (plain_char(l_[k_])) {
        ++k_;
      } else if (!in_flow && l_[k_] == ' ' && k_ + 1 < l_.size() && plain_char(l_[k_ + 1])) {
        k_ += 2;  // "front left": one inner space at a time
      } else {
        break;
      }
    }
    if (k_ == start) bad("unexpected '" + std::string(1, l_[k_]) + "'");
    check_integer(l_.substr(start, k_ - start), path_, where_);
  }

  std::string_view l_;
  std::size_t k_;
  const std::string& path_;
  const std::string& where_;
};

}  // namespace

void check_yaml_limits(std::string_view text, const std::string& path) {
  if (text.size() > kMaxCalibrationBytes)
    fail(path, "", "larger than " + std::to_string(kMaxCalibrationBytes) + " bytes");
  if (text.find('\0') != std::string_view::npos) fail(path, "", "contains a NUL byte (not a YAML text file)");
  std::vector<YamlLine::Level> levels;  // block entries open at this line (column, key or item)
  bool opens = false;                   // the last block line opens children
  bool flow = false;                    // a "[" open from an earlier line
  bool content = false;                 // a non-blank line seen
  bool ended = false;                   // a "..." document end seen: only "---" may follow
  int line = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    ++line;
    std::size_t eol = text.find('\n', pos);
    if (eol == std::string_view::npos) eol = text.size();
    std::string_view l = text.substr(pos, eol - pos);
    pos = eol + 1;
    if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
    const std::string where = "line " + std::to_string(line);
    if (l.size() > kMaxYamlLine) fail(path, where, "longer than " + std::to_string(kMaxYamlLine) + " bytes");
    std::size_t i = 0;
    while (i < l.size() && l[i] == ' ') ++i;
    if (i == l.size() || l[i] == '#') continue;  // blank or comment
    if (l[i] == '\t') fail(path, where, "a tab in the indentation");
    const bool first = !content;
    content = true;
    if (first && l.substr(0, 5) == "%YAML") {
      if (l != "%YAML:1.0" && l != "%YAML 1.0" && l != "%YAML:1.2" && l != "%YAML 1.2")
        fail(path, where, "expected the header %YAML:1.0");
      continue;
    }
    if (i == 0 && (l.substr(0, 3) == "---" || l.substr(0, 3) == "...")) {
      // A document marker stands alone, as OpenCV writes it (text after it can hang OpenCV's parser).
      const std::size_t k = l.find_first_not_of(' ', 3);
      if (k != std::string_view::npos && !(k > 3 && l[k] == '#'))
        fail(path, where, "text after the document marker " + std::string(l.substr(0, 3)));
      ended = l[0] == '.';
      continue;
    }
    // Content after a document end without a new "---" is no YAML document, and OpenCV 4.6's parser
    // can loop on it (rig_fuzz_calibration's find: "...", then "# v0:", then " -  versionA#]").
    if (ended) fail(path, where, "text after the document end marker ... (start a document with ---)");
    if (flow) {
      flow = YamlLine(l, i, path, where).items();
      continue;
    }
    const YamlLine::Block b = YamlLine(l, i, path, where).block_line();
    // The block structure, checked as YAML does (OpenCV's parser hangs on some that are not):
    // entries at one column are all keys or all items, a line may be more indented only under a
    // line that opens children, and the top level is a mapping.
    while (!levels.empty() && levels.back().col > i) levels.pop_back();
    const YamlLine::Level lead = b.levels.empty() ? YamlLine::Level{i, YamlLine::Kind::Map} : b.levels[0];
    if (!levels.empty() && levels.back().col == i) {
      if (levels.back().kind != lead.kind)
        fail(path, where,
             lead.kind == YamlLine::Kind::Seq ? "a '- ' item among the keys of a mapping"
                                              : "a key among the '- ' items of a sequence");
    } else {
      if (!levels.empty() && !opens) fail(path, where, "more indented than the line before allows");
      if (levels.empty() && (lead.kind != YamlLine::Kind::Map || i != 0))
        fail(path, where, "the top level must be a mapping of keys at column 0");
      levels.push_back(lead);
    }
    for (std::size_t n = 1; n < b.levels.size(); ++n) levels.push_back(b.levels[n]);
    opens = b.opens;
    flow = b.flow;
    if (static_cast<int>(levels.size()) + (flow ? 1 : 0) > kMaxYamlDepth)
      fail(path, where, "nested more than " + std::to_string(kMaxYamlDepth) + " levels deep");
  }
  if (flow) fail(path, "line " + std::to_string(line), "a '[' is not closed");
}

namespace {

int read_int(const cv::FileNode& n, const std::string& path, const std::string& node) {
  if (n.isNone()) fail(path, node, "missing");
  if (!n.isInt()) fail(path, node, "expected an integer");
  return static_cast<int>(n);
}

double read_real(const cv::FileNode& n, const std::string& path, const std::string& node) {
  if (n.isNone()) fail(path, node, "missing");
  if (!n.isReal() && !n.isInt()) fail(path, node, "expected a number");
  return static_cast<double>(n);
}

Camera read_camera(const cv::FileNode& n, const std::string& path, const std::string& key) {
  if (!n.isMap()) fail(path, key, "expected a map");
  Camera cam;
  const cv::FileNode name = n["name"];
  if (name.isNone()) {
    cam.name = key;
  } else if (name.isString()) {
    cam.name = static_cast<std::string>(name);
  } else {
    fail(path, key + ".name", "expected a string");
  }
  cam.width = read_int(n["width"], path, key + ".width");
  cam.height = read_int(n["height"], path, key + ".height");
  const auto k = read_values(n["K"], path, key + ".K", 9, 9);
  for (int i = 0; i < 9; ++i) cam.K.val[i] = k[i];
  if (!n["dist"].isNone()) {
    // 4 (k1 k2 p1 p2) or 5 coefficients; the rational and thin-prism models are not supported,
    // so longer vectors are accepted only when the extra terms are zero.
    const auto d = read_values(n["dist"], path, key + ".dist", 4, 14);
    for (std::size_t i = 0; i < d.size(); ++i) {
      if (i < 5) {
        cam.dist[static_cast<int>(i)] = d[i];
      } else if (d[i] != 0) {
        fail(path, key + ".dist",
             "only k1 k2 p1 p2 k3 are supported; coefficient " + std::to_string(i) + " is not zero");
      }
    }
  }
  if (!n["R"].isNone()) {
    const auto r = read_values(n["R"], path, key + ".R", 9, 9);
    for (int i = 0; i < 9; ++i) cam.R_cam_from_world.val[i] = r[i];
  } else if (!n["rvec"].isNone()) {
    const auto r = read_values(n["rvec"], path, key + ".rvec", 3, 3);
    cv::Rodrigues(cv::Vec3d(r[0], r[1], r[2]), cam.R_cam_from_world);
  } else {
    fail(path, key + ".R", "missing (give R as a 3x3 matrix or rvec as a Rodrigues vector)");
  }
  const auto t = read_values(n["t"], path, key + ".t", 3, 3);
  cam.t_cam_from_world = cv::Vec3d(t[0], t[1], t[2]);
  std::string why;
  if (!cam.valid(&why)) fail(path, key, why);
  return cam;
}

VoxelGrid read_grid(const cv::FileNode& n, const std::string& path) {
  if (!n.isMap()) fail(path, "grid", "expected a map");
  VoxelGrid g;
  const auto mn = read_values(n["min_m"], path, "grid.min_m", 3, 3);
  g.min_m = cv::Vec3d(mn[0], mn[1], mn[2]);
  g.voxel_m = read_real(n["voxel_m"], path, "grid.voxel_m");
  g.nx = read_int(n["nx"], path, "grid.nx");
  g.ny = read_int(n["ny"], path, "grid.ny");
  g.nz = read_int(n["nz"], path, "grid.nz");
  std::string why;
  if (!g.valid(&why)) fail(path, "grid", why);
  return g;
}

}  // namespace

bool Calibration::valid(std::string* why) const {
  if (cameras.empty()) {
    if (why) *why = "no cameras";
    return false;
  }
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    std::string w;
    if (!cameras[k].valid(&w)) {
      if (why) *why = "cam" + std::to_string(k) + ": " + w;
      return false;
    }
  }
  std::string w;
  if (grid && !grid->valid(&w)) {
    if (why) *why = "grid: " + w;
    return false;
  }
  return true;
}

namespace {

Calibration parse_checked(const std::string& text, const std::string& path) {
  cv::FileStorage fs;
  try {
    if (!fs.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML)) {
      fail(path, "", "cannot open as OpenCV FileStorage YAML");
    }
  } catch (const cv::Exception& e) {
    fail(path, "", "not a valid OpenCV FileStorage YAML file (" + one_line(e.msg) + ")");
  }
  const cv::FileNode root = fs.root();
  if (!root.isMap()) fail(path, "", "expected a YAML map at the top level");
  // format/version are optional (hand-written files may omit them) but must match when present.
  if (!fs["format"].isNone() &&
      (!fs["format"].isString() || static_cast<std::string>(fs["format"]) != kFormat)) {
    fail(path, "format", std::string("expected \"") + kFormat + "\"");
  }
  if (!fs["version"].isNone() && read_int(fs["version"], path, "version") != kVersion) {
    fail(path, "version", "unsupported (this build reads version " + std::to_string(kVersion) + ")");
  }
  Calibration calib;
  int n_cameras = -1;
  if (!fs["num_cameras"].isNone()) {
    n_cameras = read_int(fs["num_cameras"], path, "num_cameras");
    if (n_cameras < 1) fail(path, "num_cameras", "must be at least 1");
  }
  for (int k = 0;; ++k) {
    const std::string key = "cam" + std::to_string(k);
    const cv::FileNode n = fs[key];
    if (n.isNone()) {
      if (n_cameras >= 0 && k < n_cameras) {
        fail(path, key, "missing (num_cameras is " + std::to_string(n_cameras) + ")");
      }
      break;
    }
    if (n_cameras >= 0 && k >= n_cameras) {
      fail(path, key, "present but num_cameras is " + std::to_string(n_cameras));
    }
    calib.cameras.push_back(read_camera(n, path, key));
  }
  if (calib.cameras.empty()) fail(path, "cam0", "missing (no cameras in the file)");
  if (!fs["grid"].isNone()) calib.grid = read_grid(fs["grid"], path);
  return calib;
}

}  // namespace

Calibration read_calibration(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) fail(path, "", "no such file");
  return parse_calibration(read_input_file(path, kMaxCalibrationBytes), path);
}

Calibration parse_calibration(const std::string& text, const std::string& path) {
  check_yaml_limits(text, path);
  try {
    return parse_checked(text, path);
  } catch (const std::runtime_error&) {
    throw;                            // ours, already one line naming the file and the node
  } catch (const cv::Exception& e) {  // anything OpenCV still refuses while we walk its nodes
    fail(path, "", "not a valid OpenCV FileStorage YAML file (" + one_line(e.msg) + ")");
  } catch (const std::exception& e) {  // its parser also throws std::length_error and the like
    fail(path, "", std::string("not a valid OpenCV FileStorage YAML file (") + one_line(e.what()) + ")");
  }
}

void write_calibration(const std::string& path, const Calibration& calib) {
  std::string why;
  if (!calib.valid(&why)) fail(path, "", "refusing to write an invalid calibration: " + why);
  cv::FileStorage fs;
  try {
    if (!fs.open(path, cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML)) {
      fail(path, "", "cannot open for writing");
    }
  } catch (const cv::Exception& e) {
    fail(path, "", "cannot open for writing (" + e.msg + ")");
  }
  fs.writeComment(
      "voxcap rig calibration (layout: hw/rig/README.md). World: metres, z up. "
      "x_cam = R * x_world + t; OpenCV pinhole model, dist = k1 k2 p1 p2 k3.");
  fs << "format" << kFormat;
  fs << "version" << kVersion;
  fs << "num_cameras" << static_cast<int>(calib.cameras.size());
  for (std::size_t k = 0; k < calib.cameras.size(); ++k) {
    const Camera& cam = calib.cameras[k];
    fs << "cam" + std::to_string(k) << "{";
    fs << "name" << cam.name;
    fs << "width" << cam.width << "height" << cam.height;
    fs << "K" << cv::Mat(cam.K);
    fs << "dist" << cv::Mat(cam.dist).reshape(1, 1);
    fs << "R" << cv::Mat(cam.R_cam_from_world);
    fs << "t" << cv::Mat(cam.t_cam_from_world);
    fs << "}";
  }
  if (calib.grid) {
    const VoxelGrid& g = *calib.grid;
    fs << "grid"
       << "{";
    fs << "min_m"
       << "[:" << g.min_m[0] << g.min_m[1] << g.min_m[2] << "]";
    fs << "voxel_m" << g.voxel_m;
    fs << "nx" << g.nx << "ny" << g.ny << "nz" << g.nz;
    fs << "}";
  }
  fs.release();
  if (!std::filesystem::is_regular_file(path)) fail(path, "", "was not written");
}

}  // namespace vc::rig
