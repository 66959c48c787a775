// Importers of other systems' calibrations (voxcap calib import). Each parses a file a user hands us:
// the text is read bounded (kMaxImportBytes, a regular file), its nesting is checked before a parser
// recurses (JSON, TOML, XML), the camera count is bounded, every number must be finite, and every
// camera goes through one conversion (to_camera) that checks K, fixes nearly-orthonormal rotations and
// runs hw/rig's own Camera::valid. The formats' units and axes are in host/calib/README.md.
#include "voxcap/calib/import.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <set>
#include <sstream>
#include <utility>

#include <toml++/toml.h>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/persistence.hpp>
#include <opencv2/imgcodecs.hpp>

#include "voxcap/rig/input_file.hpp"
#include "xml_scan.hpp"

namespace vc::calib {
namespace {

namespace fs = std::filesystem;

[[noreturn]] void fail(const std::string& path, const std::string& camera, const std::string& what) {
  std::string msg = path + ": " + (camera.empty() ? "" : "camera '" + camera + "': ") + what;
  for (char& c : msg)
    if (c == '\n' || c == '\r') c = ' ';
  throw ImportError(msg);
}

// A camera as a source states it, already in voxcap's world frame and metres.
struct RawCamera {
  std::string name;
  double width = 0, height = 0;
  cv::Matx33d K = cv::Matx33d::eye();
  cv::Vec<double, 5> dist{0, 0, 0, 0, 0};
  cv::Matx33d R = cv::Matx33d::eye();  // R_cam_from_world
  cv::Vec3d t{0, 0, 0};                // t_cam_from_world, metres
};

bool finite_all(const double* v, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}

void check_name(const std::string& name, const std::string& path) {
  if (name.empty()) fail(path, "", "a camera has an empty name");
  if (name.size() > kMaxCameraName)
    fail(path, name.substr(0, 16) + "...", "name longer than " + std::to_string(kMaxCameraName) + " bytes");
  // rig.yaml writes names as plain scalars; keep to what it reads back unchanged.
  for (const char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' || c == '+'))
      fail(path, "", "camera name '" + name + "' may hold only letters, digits and _ - . +");
  if (name[0] == '.' || name[0] == '-' || name[0] == '+')
    fail(path, "", "camera name '" + name + "' must start with a letter, a digit or _");
}

// Converts, checks and repairs one camera (see import.hpp for the rotation rule).
rig::Camera to_camera(const RawCamera& raw, const std::string& path, ImportReport* report) {
  check_name(raw.name, path);
  const std::string& cam = raw.name;
  if (!finite_all(raw.K.val, 9) || !finite_all(raw.dist.val, 5) || !finite_all(raw.R.val, 9) ||
      !finite_all(raw.t.val, 3) || !std::isfinite(raw.width) || !std::isfinite(raw.height))
    fail(path, cam, "every number must be finite");
  if (raw.width != std::floor(raw.width) || raw.height != std::floor(raw.height) || raw.width < 1 ||
      raw.height < 1 || raw.width > rig::Camera::kMaxImageSide || raw.height > rig::Camera::kMaxImageSide)
    fail(path, cam,
         "image size must be whole pixels in [1, " + std::to_string(rig::Camera::kMaxImageSide) + "], got " +
             std::to_string(raw.width) + "x" + std::to_string(raw.height));
  cv::Matx33d K = raw.K;
  if (K(2, 0) != 0 || K(2, 1) != 0 || K(1, 0) != 0 || !(K(2, 2) > 0))
    fail(path, cam, "K must be [fx s cx; 0 fy cy; 0 0 k33] with k33 > 0");
  K = K * (1.0 / K(2, 2));
  if (!(K(0, 0) > 0) || !(K(1, 1) > 0)) fail(path, cam, "K's focal lengths must be positive");
  // OpenCV's model has no skew; a skew at print precision (|s| < 1e-9 fx) is zero, more is refused.
  if (std::abs(K(0, 1)) > 1e-9 * K(0, 0))
    fail(path, cam, "K has a skew of " + std::to_string(K(0, 1)) + " px (OpenCV's model has none)");
  K(0, 1) = 0;

  rig::Camera c;
  c.name = raw.name;
  c.width = static_cast<int>(raw.width);
  c.height = static_cast<int>(raw.height);
  c.K = K;
  c.dist = raw.dist;
  double change = 0, error = 0;
  c.R_cam_from_world = nearest_rotation(raw.R, path + ": camera '" + cam + "'", &change, &error);
  c.t_cam_from_world = raw.t;
  report->max_rotation_error = std::max(report->max_rotation_error, error);
  if (change > 0) {
    ++report->rotations_fixed;
    if (change >= report->max_rotation_change) {
      report->max_rotation_change = change;
      report->worst_rotation_camera = cam;
    }
  }
  std::string why;
  if (!c.valid(&why)) fail(path, cam, why);
  return c;
}

rig::Calibration finish(std::vector<RawCamera>& raws, const std::string& path, ImportReport* report) {
  if (raws.empty()) fail(path, "", "no cameras found");
  rig::Calibration cal;
  std::set<std::string> names;
  for (const RawCamera& raw : raws) {
    if (!names.insert(raw.name).second) fail(path, raw.name, "the name appears twice");
    cal.cameras.push_back(to_camera(raw, path, report));
  }
  report->cameras = static_cast<int>(cal.cameras.size());
  std::string why;
  if (!cal.valid(&why)) fail(path, "", why);
  return cal;
}

void add_camera(std::vector<RawCamera>* raws, RawCamera raw, const std::string& path) {
  if (static_cast<int>(raws->size()) >= kMaxImportCameras)
    fail(path, "", "more than " + std::to_string(kMaxImportCameras) + " cameras");
  raws->push_back(std::move(raw));
}

// A number as a whole token (locale-free), finite.
bool parse_number(std::string_view s, double* out) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), *out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

// Bracket nesting outside quoted strings (JSON, TOML): refused over kMaxImportNesting before a
// recursive parser sees it.
void check_brackets(std::string_view text, const std::string& path) {
  int depth = 0;
  char quote = 0;
  int line = 1;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') ++line;
    if (c == '\0') fail(path, "", "line " + std::to_string(line) + ": a NUL byte");
    if (quote) {
      if (c == '\\' && quote == '"' && i + 1 < text.size())
        ++i;
      else if (c == quote)
        quote = 0;
      continue;
    }
    if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxImportNesting)
        fail(path, "",
             "line " + std::to_string(line) + ": nested more than " + std::to_string(kMaxImportNesting) +
                 " levels deep");
    } else if (c == ']' || c == '}') {
      --depth;
    } else if (c == '#' && path.size() >= 5 && path.compare(path.size() - 5, 5, ".toml") == 0) {
      while (i + 1 < text.size() && text[i + 1] != '\n') ++i;  // a TOML comment
    }
  }
}

// ---- Middlebury *_par.txt ----------------------------------------------------------------------

cv::Size image_size_of(const std::string& file) {
  const std::string bytes = rig::read_input_file(file, std::size_t{256} << 20);
  const cv::Mat buf(1, static_cast<int>(bytes.size()), CV_8U, const_cast<char*>(bytes.data()));
  const cv::Mat img = cv::imdecode(buf, cv::IMREAD_UNCHANGED);
  if (img.empty()) throw ImportError(file + ": not an image OpenCV can read");
  return img.size();
}

rig::Calibration parse_middlebury(const std::string& text, const std::string& path, const ImportOptions& o,
                                  ImportReport* report) {
  std::vector<RawCamera> raws;
  std::vector<std::string> files;
  std::istringstream in(text);
  std::string line;
  int lineno = 0, skipped = 0;
  long long count = -1;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.size() > 4096) fail(path, "", "line " + std::to_string(lineno) + ": longer than 4096 bytes");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::vector<std::string_view> tok;
    std::string_view rest(line);
    while (!rest.empty()) {
      const std::size_t b = rest.find_first_not_of(" \t");
      if (b == std::string_view::npos) break;
      rest.remove_prefix(b);
      const std::size_t e = std::min(rest.find_first_of(" \t"), rest.size());
      tok.push_back(rest.substr(0, e));
      rest.remove_prefix(e);
      if (tok.size() > 32) break;
    }
    if (tok.empty()) continue;
    const std::string where = "line " + std::to_string(lineno) + ": ";
    double v = 0;
    if (tok.size() == 1 && raws.empty() && count < 0 && parse_number(tok[0], &v)) {
      if (v != std::floor(v) || v < 1 || v > kMaxImportCameras)
        fail(path, "", where + "the image count must be in [1, " + std::to_string(kMaxImportCameras) + "]");
      count = static_cast<long long>(v);
      continue;
    }
    bool numeric_after_name = false;
    for (std::size_t i = 1; i < tok.size(); ++i)
      numeric_after_name = numeric_after_name || parse_number(tok[i], &v);
    if (!numeric_after_name && raws.empty() && skipped < 2) {  // a column-header line (this copy has one)
      ++skipped;
      continue;
    }
    if (tok.size() != 22)
      fail(path, "",
           where + "expected an image name and 21 numbers, got " + std::to_string(tok.size()) + " fields");
    double n[21];
    for (int i = 0; i < 21; ++i)
      if (!parse_number(tok[static_cast<std::size_t>(i) + 1], &n[i]) || !std::isfinite(n[i]))
        fail(path, "", where + "field " + std::to_string(i + 2) + " is not a finite number");
    RawCamera r;
    const std::string file(tok[0]);
    r.name = fs::path(file).stem().string();
    r.K = cv::Matx33d(n);
    r.R = cv::Matx33d(n + 9);
    r.t = cv::Vec3d(n[18], n[19], n[20]);
    add_camera(&raws, std::move(r), path);
    files.push_back(file);
  }
  if (count >= 0 && count != static_cast<long long>(raws.size()))
    fail(path, "",
         "the first line says " + std::to_string(count) + " images, the file lists " +
             std::to_string(raws.size()));
  if (raws.empty()) fail(path, "", "no camera lines (NAME k11..k33 r11..r33 t1 t2 t3)");
  cv::Size size;
  if (o.image_size) {
    size = *o.image_size;
    report->notes.push_back("image size " + std::to_string(size.width) + "x" + std::to_string(size.height) +
                            " from --image-size");
  } else {
    const fs::path dir = fs::path(path).parent_path();
    for (const std::string& f : files) {
      if (f.find('/') != std::string::npos || f.find("..") != std::string::npos) continue;
      for (const fs::path& cand : {dir / f, dir / "images" / f}) {
        std::error_code ec;
        if (fs::is_regular_file(cand, ec)) {
          size = image_size_of(cand.string());
          report->notes.push_back("image size " + std::to_string(size.width) + "x" +
                                  std::to_string(size.height) + " read from " + cand.string());
          break;
        }
      }
      if (size.width > 0) break;
    }
    if (size.width <= 0)
      fail(path, "",
           "the file holds no image size and no listed image was found beside it: pass --image-size W H");
  }
  for (RawCamera& r : raws) {
    r.width = size.width;
    r.height = size.height;
  }
  report->notes.push_back("middlebury: P = K [R | t], metres, the source's own frame kept (it has no floor)");
  return finish(raws, path, report);
}

// ---- Qualisys .qca (XML) -------------------------------------------------------------------------

double attr_number(const XmlTag& tag, const char* name, const std::string& path, const std::string& cam) {
  const std::string* s = tag.attr(name);
  if (!s) fail(path, cam, "<" + tag.name + "> has no " + name);
  double v = 0;
  if (!parse_number(*s, &v) || !std::isfinite(v))
    fail(path, cam, "<" + tag.name + "> " + name + "=\"" + s->substr(0, 32) + "\" is not a finite number");
  return v;
}

rig::Calibration parse_qualisys(const std::string& text, const std::string& path, ImportReport* report) {
  std::vector<RawCamera> raws;
  struct Pending {
    bool open = false, fov = false, transform = false, intrinsic = false;
    RawCamera raw;
  } p;
  int index = 0;
  scan_xml(text, path, kMaxImportNesting, [&](const XmlTag& tag) {
    if (tag.name == "camera" && !tag.closing) {
      if (p.open) fail(path, p.raw.name, "<camera> inside <camera>");
      p = Pending{};
      p.open = true;
      const std::string* serial = tag.attr("serial");
      p.raw.name = serial && !serial->empty() ? *serial : "cam" + std::to_string(index);
      if (tag.self_closing) fail(path, p.raw.name, "<camera/> is empty");
      return;
    }
    if (!p.open) return;
    const std::string& cam = p.raw.name;
    if (tag.name == "camera" && tag.closing) {
      if (!p.fov) fail(path, cam, "no <fov_video>");
      if (!p.transform) fail(path, cam, "no <transform>");
      if (!p.intrinsic) fail(path, cam, "no <intrinsic>");
      add_camera(&raws, p.raw, path);
      p.open = false;
      ++index;
    } else if (tag.name == "fov_video" && !tag.closing) {
      const double left = attr_number(tag, "left", path, cam), top = attr_number(tag, "top", path, cam);
      const double right = attr_number(tag, "right", path, cam),
                   bottom = attr_number(tag, "bottom", path, cam);
      p.raw.width = right - left + 1;
      p.raw.height = bottom - top + 1;
      p.raw.K(0, 2) = -left;  // the principal point is added below (intrinsic may come first)
      p.raw.K(1, 2) = -top;
      if (p.intrinsic || p.fov) fail(path, cam, "one <fov_video>, before <intrinsic>");
      p.fov = true;
    } else if (tag.name == "transform" && !tag.closing) {
      static constexpr const char* kR[9] = {"r11", "r12", "r13", "r21", "r22", "r23", "r31", "r32", "r33"};
      cv::Matx33d Rq;
      for (int i = 0; i < 9; ++i) Rq.val[i] = attr_number(tag, kR[i], path, cam);
      const cv::Vec3d C_mm(attr_number(tag, "x", path, cam), attr_number(tag, "y", path, cam),
                           attr_number(tag, "z", path, cam));
      // QTM's rotation maps the world to a camera frame with y up and z backwards; OpenCV's has y down,
      // z forward: R = diag(1, -1, -1) Rq. The centre is in millimetres.
      p.raw.R = cv::Matx33d(1, 0, 0, 0, -1, 0, 0, 0, -1) * Rq;
      p.raw.t = -(p.raw.R * (C_mm * 0.001));
      p.transform = true;
    } else if (tag.name == "intrinsic" && !tag.closing) {
      if (!p.fov) fail(path, cam, "<fov_video> must come before <intrinsic>");
      // QTM stores focal lengths and the principal point x64, on the sensor (fov_video's offset).
      p.raw.K(0, 0) = attr_number(tag, "focalLengthU", path, cam) / 64.0;
      p.raw.K(1, 1) = attr_number(tag, "focalLengthV", path, cam) / 64.0;
      p.raw.K(0, 2) += attr_number(tag, "centerPointU", path, cam) / 64.0;
      p.raw.K(1, 2) += attr_number(tag, "centerPointV", path, cam) / 64.0;
      const std::string* skew = tag.attr("skew");
      double s = 0;
      if (skew && (!parse_number(*skew, &s) || s != 0)) fail(path, cam, "a non-zero skew is not supported");
      p.raw.dist = cv::Vec<double, 5>(attr_number(tag, "radialDistortion1", path, cam),
                                      attr_number(tag, "radialDistortion2", path, cam),
                                      attr_number(tag, "tangentalDistortion1", path, cam),
                                      attr_number(tag, "tangentalDistortion2", path, cam),
                                      attr_number(tag, "radialDistortion3", path, cam));
      p.intrinsic = true;
    }
  });
  if (p.open) fail(path, p.raw.name, "<camera> is not closed");
  report->notes.push_back(
      "qualisys: lab frame kept (z up), millimetres -> metres; R = diag(1,-1,-1) R_qca, t = -R C; "
      "K = QTM's values / 64 less fov_video's offset; distortion taken as OpenCV k1 k2 p1 p2 k3");
  return finish(raws, path, report);
}

// ---- CMU Panoptic calibration*.json / camera_parameters.json ---------------------------------------

using json = nlohmann::json;

std::vector<double> json_numbers(const json& j, const std::string& key, std::size_t n_min, std::size_t n_max,
                                 const std::string& path, const std::string& cam) {
  if (!j.contains(key)) fail(path, cam, "no \"" + key + "\"");
  std::vector<double> out;
  const auto take = [&](const json& v) {
    if (!v.is_number()) fail(path, cam, "\"" + key + "\" must hold numbers");
    if (out.size() >= n_max)
      fail(path, cam, "\"" + key + "\" holds more than " + std::to_string(n_max) + " numbers");
    out.push_back(v.get<double>());
  };
  const json& v = j.at(key);
  if (!v.is_array()) fail(path, cam, "\"" + key + "\" must be an array");
  for (const json& row : v) {
    if (row.is_array()) {
      for (const json& e : row) take(e);
    } else {
      take(row);
    }
  }
  if (out.size() < n_min)
    fail(path, cam,
         "\"" + key + "\" holds " + std::to_string(out.size()) + " numbers, expected " +
             std::to_string(n_min));
  for (const double d : out)
    if (!std::isfinite(d)) fail(path, cam, "\"" + key + "\" holds a non-finite number");
  return out;
}

rig::Calibration parse_panoptic(const std::string& text, const std::string& path, ImportReport* report) {
  check_brackets(text, path);
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::exception& e) {
    fail(path, "", std::string("not JSON: ") + e.what());
  }
  if (!doc.is_object() || !doc.contains("cameras") || !doc["cameras"].is_array())
    fail(path, "", "expected an object with a \"cameras\" array");
  // Panoptic's world: centimetres, the floor y = 0, up -y. voxcap's: p_v = M p_p / 100 with
  // M = [1 0 0; 0 0 1; 0 -1 0] (x kept, z_v = -y_p, y_v = z_p: right-handed), so R_v = R M^T, t_v = t / 100.
  const cv::Matx33d M(1, 0, 0, 0, 0, 1, 0, -1, 0);
  std::vector<RawCamera> raws;
  int index = 0;
  for (const json& c : doc["cameras"]) {
    if (!c.is_object()) fail(path, "", "cameras[" + std::to_string(index) + "] is not an object");
    RawCamera r;
    r.name = c.contains("name") && c["name"].is_string() ? c["name"].get<std::string>()
                                                         : "cam" + std::to_string(index);
    if (r.name.size() > kMaxCameraName)
      fail(path, "", "a camera name is longer than " + std::to_string(kMaxCameraName) + " bytes");
    const std::vector<double> res = json_numbers(c, "resolution", 2, 2, path, r.name);
    const std::vector<double> K = json_numbers(c, "K", 9, 9, path, r.name);
    const std::vector<double> R = json_numbers(c, "R", 9, 9, path, r.name);
    const std::vector<double> t = json_numbers(c, "t", 3, 3, path, r.name);
    std::vector<double> d(5, 0.0);
    if (c.contains("distCoef")) {
      d = json_numbers(c, "distCoef", 4, 5, path, r.name);
      d.resize(5, 0.0);
    }
    r.width = res[0];
    r.height = res[1];
    r.K = cv::Matx33d(K.data());
    r.dist = cv::Vec<double, 5>(d.data());
    r.R = cv::Matx33d(R.data()) * M.t();
    r.t = cv::Vec3d(t[0], t[1], t[2]) * 0.01;
    add_camera(&raws, std::move(r), path);
    ++index;
  }
  report->notes.push_back(
      "panoptic: centimetres -> metres, up -y -> +z: p_voxcap = [x, z, -y] / 100, origin kept");
  return finish(raws, path, report);
}

// ---- Pose2Sim / anipose / FreeMoCap .toml ----------------------------------------------------------

std::vector<double> toml_numbers(const toml::table& t, const char* key, std::size_t n_min, std::size_t n_max,
                                 const std::string& path, const std::string& cam) {
  const toml::node* node = t.get(key);
  if (!node) fail(path, cam, std::string("no ") + key);
  std::vector<double> out;
  bool ok = true;
  const auto take = [&](const toml::node& v) {
    if (const auto d = v.value<double>(); d && out.size() < n_max)
      out.push_back(*d);
    else
      ok = false;
  };
  if (const toml::array* a = node->as_array()) {
    for (const toml::node& e : *a) {
      if (const toml::array* row = e.as_array()) {
        for (const toml::node& x : *row) take(x);
      } else {
        take(e);
      }
    }
  } else {
    ok = false;
  }
  if (!ok || out.size() < n_min)
    fail(path, cam,
         std::string(key) + " must be an array of " + std::to_string(n_min) +
             (n_min == n_max ? "" : " to " + std::to_string(n_max)) + " numbers");
  for (const double d : out)
    if (!std::isfinite(d)) fail(path, cam, std::string(key) + " holds a non-finite number");
  return out;
}

rig::Calibration parse_toml(const std::string& text, const std::string& path, const ImportOptions& o,
                            ImportReport* report) {
  check_brackets(text, path + (path.ends_with(".toml") ? "" : ".toml"));
  toml::table doc;
  try {
    doc = toml::parse(text, std::string_view(path));
  } catch (const toml::parse_error& e) {
    fail(path, "",
         std::string("not TOML: ") + std::string(e.description()) + " (line " +
             std::to_string(e.source().begin.line) + ")");
  }
  const double unit = o.unit_m.value_or(1.0);
  std::vector<RawCamera> raws;
  for (const auto& [key, node] : doc) {
    const toml::table* t = node.as_table();
    if (!t || !t->contains("matrix")) continue;  // [metadata] and the like
    RawCamera r;
    r.name = std::string(key.str());
    if (const auto n = (*t)["name"].value<std::string>()) r.name = *n;
    if (r.name.size() > kMaxCameraName)
      fail(path, "", "a camera name is longer than " + std::to_string(kMaxCameraName) + " bytes");
    if ((*t)["fisheye"].value_or(false))
      fail(path, r.name, "fisheye cameras are not supported (OpenCV pinhole model only)");
    const std::vector<double> size = toml_numbers(*t, "size", 2, 2, path, r.name);
    const std::vector<double> K = toml_numbers(*t, "matrix", 9, 9, path, r.name);
    std::vector<double> d = toml_numbers(*t, "distortions", 4, 5, path, r.name);
    d.resize(5, 0.0);
    const std::vector<double> rot = toml_numbers(*t, "rotation", 3, 9, path, r.name);
    const std::vector<double> tr = toml_numbers(*t, "translation", 3, 3, path, r.name);
    r.width = size[0];
    r.height = size[1];
    r.K = cv::Matx33d(K.data());
    r.dist = cv::Vec<double, 5>(d.data());
    if (rot.size() == 3) {
      cv::Rodrigues(cv::Vec3d(rot[0], rot[1], rot[2]), r.R);
    } else if (rot.size() == 9) {
      r.R = cv::Matx33d(rot.data());
    } else {
      fail(path, r.name, "rotation must be a Rodrigues vector (3 numbers) or a 3x3 matrix");
    }
    r.t = cv::Vec3d(tr[0], tr[1], tr[2]) * unit;
    add_camera(&raws, std::move(r), path);
  }
  report->notes.push_back(
      "toml: rotation a Rodrigues vector (world -> camera), axes kept (Pose2Sim's z up); "
      "translation x " +
      std::to_string(unit) +
      " m (--units; Pose2Sim writes metres, "
      "anipose and FreeMoCap the board's unit, usually mm)");
  return finish(raws, path, report);
}

// ---- OpenCV FileStorage (YAML / XML) ---------------------------------------------------------------

std::vector<double> fs_numbers(const cv::FileNode& n, std::size_t n_min, std::size_t n_max,
                               const std::string& path, const std::string& cam, const std::string& key) {
  std::vector<double> out;
  const auto take = [&](const cv::FileNode& e) {
    if (!e.isReal() && !e.isInt()) fail(path, cam, key + ": expected numbers");
    if (out.size() >= n_max) fail(path, cam, key + ": more than " + std::to_string(n_max) + " numbers");
    out.push_back(static_cast<double>(e));
  };
  if (n.isMap()) {  // an opencv-matrix: rows, cols, dt, data; sized before anything is read
    const cv::FileNode rows = n["rows"], cols = n["cols"], data = n["data"];
    if (!rows.isInt() || !cols.isInt() || !data.isSeq())
      fail(path, cam, key + ": expected an opencv-matrix or a sequence");
    const long long r = static_cast<int>(rows), c = static_cast<int>(cols);
    if (r < 1 || c < 1 || r * c > static_cast<long long>(n_max) ||
        data.size() != static_cast<std::size_t>(r * c))
      fail(
          path, cam,
          key + ": expected at most " + std::to_string(n_max) + " numbers (rows x cols = the data's length)");
    for (const auto& e : data) take(e);
  } else if (n.isSeq()) {
    if (n.size() > n_max) fail(path, cam, key + ": more than " + std::to_string(n_max) + " numbers");
    for (const auto& e : n) take(e);
  } else if (n.isReal() || n.isInt()) {
    take(n);
  } else {
    fail(path, cam, key + ": expected numbers");
  }
  if (out.size() < n_min)
    fail(path, cam,
         key + ": expected " + std::to_string(n_min) + " numbers, got " + std::to_string(out.size()));
  for (const double d : out)
    if (!std::isfinite(d)) fail(path, cam, key + ": a non-finite number");
  return out;
}

cv::FileNode first_of(const cv::FileNode& map, std::initializer_list<const char*> keys, std::string* which) {
  for (const char* k : keys) {
    const cv::FileNode n = map[k];
    if (!n.isNone()) {
      *which = k;
      return n;
    }
  }
  return {};
}

// One camera from a map holding some of OpenCV's usual keys (calibrate sample, voxcap's rig.yaml, ...).
RawCamera fs_camera(const cv::FileNode& m, std::string name, const ImportOptions& o, double unit,
                    const std::string& path) {
  RawCamera r;
  if (m["name"].isString()) name = static_cast<std::string>(m["name"]);
  r.name = std::move(name);
  if (r.name.size() > kMaxCameraName)
    fail(path, "", "a camera name is longer than " + std::to_string(kMaxCameraName) + " bytes");
  std::string key;
  const cv::FileNode k = first_of(m, {"K", "camera_matrix", "cameraMatrix", "M"}, &key);
  r.K = cv::Matx33d(fs_numbers(k, 9, 9, path, r.name, key).data());
  const cv::FileNode d =
      first_of(m, {"dist", "D", "distortion_coefficients", "distCoeffs", "dist_coeffs"}, &key);
  if (!d.isNone()) {
    std::vector<double> v = fs_numbers(d, 4, 14, path, r.name, key);
    for (std::size_t i = 5; i < v.size(); ++i)
      if (v[i] != 0)
        fail(
            path, r.name,
            key + ": only k1 k2 p1 p2 k3 are supported (coefficient " + std::to_string(i + 1) + " is not 0)");
    v.resize(5, 0.0);
    r.dist = cv::Vec<double, 5>(v.data());
  }
  const cv::FileNode R = first_of(m, {"R", "rotation_matrix", "rvec", "rotation"}, &key);
  if (!R.isNone()) {
    const std::vector<double> v = fs_numbers(R, 3, 9, path, r.name, key);
    if (v.size() == 3)
      cv::Rodrigues(cv::Vec3d(v[0], v[1], v[2]), r.R);
    else if (v.size() == 9)
      r.R = cv::Matx33d(v.data());
    else
      fail(path, r.name, key + ": a 3x3 matrix or a Rodrigues vector");
  }
  const cv::FileNode t = first_of(m, {"t", "T", "tvec", "translation"}, &key);
  if (!t.isNone()) {
    const std::vector<double> v = fs_numbers(t, 3, 3, path, r.name, key);
    r.t = cv::Vec3d(v[0], v[1], v[2]) * unit;
  }
  const cv::FileNode w = first_of(m, {"width", "image_width", "imageWidth"}, &key);
  const cv::FileNode h = first_of(m, {"height", "image_height", "imageHeight"}, &key);
  const cv::FileNode s = first_of(m, {"image_size", "imageSize", "size"}, &key);
  if (!w.isNone() && !h.isNone()) {
    r.width = fs_numbers(w, 1, 1, path, r.name, "width")[0];
    r.height = fs_numbers(h, 1, 1, path, r.name, "height")[0];
  } else if (!s.isNone()) {
    const std::vector<double> v = fs_numbers(s, 2, 2, path, r.name, key);
    r.width = v[0];
    r.height = v[1];
  } else if (o.image_size) {
    r.width = o.image_size->width;
    r.height = o.image_size->height;
  } else {
    fail(path, r.name,
         "no image size (width/height, image_width/image_height or image_size): pass --image-size W H");
  }
  return r;
}

bool has_camera_matrix(const cv::FileNode& m) {
  return m.isMap() && (!m["K"].isNone() || !m["camera_matrix"].isNone() || !m["cameraMatrix"].isNone() ||
                       !m["M"].isNone());
}

rig::Calibration parse_opencv(const std::string& text, const std::string& path, const ImportOptions& o,
                              ImportReport* report) {
  const std::size_t first = text.find_first_not_of(" \t\r\n");
  const bool xml = first != std::string::npos && text[first] == '<';
  if (xml) {
    scan_xml(text, path, kMaxImportNesting, [](const XmlTag&) {});  // bounded and well-formed first
  } else {
    try {
      rig::check_yaml_limits(text, path);
    } catch (const std::runtime_error& e) {
      throw ImportError(e.what());
    }
  }
  cv::FileStorage fs;
  try {
    fs.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY |
                      (xml ? cv::FileStorage::FORMAT_XML : cv::FileStorage::FORMAT_YAML));
  } catch (const cv::Exception& e) {
    fail(path, "", "OpenCV cannot parse it: " + e.msg);
  }
  if (!fs.isOpened()) fail(path, "", "OpenCV cannot parse it");
  const double unit = o.unit_m.value_or(1.0);
  std::vector<RawCamera> raws;
  const cv::FileNode root = fs.root();
  try {
    if (has_camera_matrix(root)) {  // one camera at the top level (OpenCV's calibration sample)
      add_camera(&raws, fs_camera(root, fs::path(path).stem().string(), o, unit, path), path);
    } else if (!root["M1"].isNone() && !root["M2"].isNone()) {  // stereo_calib: M1 D1 M2 D2 R T
      RawCamera a, b;
      std::string key;
      a.name = "cam0";
      b.name = "cam1";
      a.K = cv::Matx33d(fs_numbers(root["M1"], 9, 9, path, "cam0", "M1").data());
      b.K = cv::Matx33d(fs_numbers(root["M2"], 9, 9, path, "cam1", "M2").data());
      for (auto [raw, dk] : {std::pair{&a, "D1"}, std::pair{&b, "D2"}}) {
        if (root[dk].isNone()) continue;
        std::vector<double> v = fs_numbers(root[dk], 4, 14, path, raw->name, dk);
        v.resize(5, 0.0);
        raw->dist = cv::Vec<double, 5>(v.data());
      }
      const std::vector<double> R = fs_numbers(root["R"], 9, 9, path, "cam1", "R");
      const std::vector<double> T = fs_numbers(root["T"], 3, 3, path, "cam1", "T");
      b.R = cv::Matx33d(R.data());
      b.t = cv::Vec3d(T[0], T[1], T[2]) * unit;
      const cv::FileNode s = first_of(root, {"image_size", "imageSize"}, &key);
      cv::Size size = o.image_size.value_or(cv::Size());
      if (!s.isNone()) {
        const std::vector<double> v = fs_numbers(s, 2, 2, path, "", key);
        size = cv::Size(static_cast<int>(std::clamp(v[0], -1.0, 1e6)),
                        static_cast<int>(std::clamp(v[1], -1.0, 1e6)));
      }
      if (size.width <= 0) fail(path, "", "no image_size: pass --image-size W H");
      a.width = b.width = size.width;
      a.height = b.height = size.height;
      add_camera(&raws, a, path);
      add_camera(&raws, b, path);
    } else {  // one map per camera (voxcap's rig.yaml: cam0, cam1, ...; other tools' per-camera maps)
      for (const cv::FileNode& n : root) {
        if (!has_camera_matrix(n)) continue;
        add_camera(&raws, fs_camera(n, n.name(), o, unit, path), path);
      }
    }
  } catch (const cv::Exception& e) {
    fail(path, "", "OpenCV cannot read a value: " + e.msg);
  }
  report->notes.push_back("opencv: x_cam = R x_world + t, axes kept, translation x " + std::to_string(unit) +
                          " m (--units)");
  return finish(raws, path, report);
}

}  // namespace

std::optional<Format> parse_format(std::string_view name) {
  if (name == "opencv") return Format::OpenCV;
  if (name == "qualisys") return Format::Qualisys;
  if (name == "panoptic") return Format::Panoptic;
  if (name == "toml") return Format::Toml;
  if (name == "middlebury") return Format::Middlebury;
  return std::nullopt;
}

const char* format_name(Format format) {
  switch (format) {
    case Format::OpenCV:
      return "opencv";
    case Format::Qualisys:
      return "qualisys";
    case Format::Panoptic:
      return "panoptic";
    case Format::Toml:
      return "toml";
    case Format::Middlebury:
      return "middlebury";
  }
  return "?";
}

const char* format_convention(Format format) {
  switch (format) {
    case Format::OpenCV:
      return "OpenCV FileStorage YAML/XML: x_cam = R x + t, axes kept, lengths in --units (default m)";
    case Format::Qualisys:
      return "Qualisys .qca: lab frame (z up) kept, mm -> m, R = diag(1,-1,-1) R_qca, t = -R C, K / 64";
    case Format::Panoptic:
      return "CMU Panoptic JSON: cm -> m, up -y -> +z (p = [x, z, -y] / 100), origin kept";
    case Format::Toml:
      return "Pose2Sim/anipose/FreeMoCap TOML: Rodrigues rotation, axes kept, lengths in --units (default m)";
    case Format::Middlebury:
      return "Middlebury *_par.txt: P = K [R | t], the source's frame and metres kept (no floor)";
  }
  return "?";
}

bool ImportOptions::valid(std::string* why) const {
  if (unit_m && !(std::isfinite(*unit_m) && *unit_m > 0 && *unit_m <= 1000)) {
    if (why) *why = "the unit must be in (0, 1000] metres";
    return false;
  }
  if (image_size &&
      (image_size->width < 1 || image_size->height < 1 || image_size->width > rig::Camera::kMaxImageSide ||
       image_size->height > rig::Camera::kMaxImageSide)) {
    if (why)
      *why = "the image size must be in [1, " + std::to_string(rig::Camera::kMaxImageSide) + "] pixels";
    return false;
  }
  if (why) why->clear();
  return true;
}

cv::Matx33d nearest_rotation(const cv::Matx33d& R, const std::string& where, double* change, double* error) {
  const double err = cv::norm(R.t() * R - cv::Matx33d::eye(), cv::NORM_INF);
  if (error) *error = err;
  if (!(err <= kMaxRotationError))
    throw ImportError(where + ": R is not a rotation (|R^T R - I| = " + std::to_string(err) + ", over " +
                      std::to_string(kMaxRotationError) + ")");
  if (cv::determinant(R) < 0) throw ImportError(where + ": R is a reflection (det < 0)");
  if (err <= 1e-12) {  // orthonormal to double precision: kept as given
    if (change) *change = 0;
    return R;
  }
  cv::Matx33d U, Vt;
  cv::Matx31d w;
  cv::SVD::compute(R, w, U, Vt);
  const cv::Matx33d Rn = U * Vt;
  if (cv::determinant(Rn) < 0) throw ImportError(where + ": R is a reflection (det < 0)");
  double d = 0;
  for (int i = 0; i < 9; ++i) d = std::max(d, std::abs(Rn.val[i] - R.val[i]));
  if (change) *change = d;
  return Rn;
}

Imported parse_import(Format format, const std::string& text, const std::string& path,
                      const ImportOptions& options) {
  std::string why;
  if (!options.valid(&why)) throw ImportError(path + ": " + why);
  if (text.size() > kMaxImportBytes)
    throw ImportError(path + ": larger than " + std::to_string(kMaxImportBytes) + " bytes");
  // Every format here is text. A NUL byte is not, and OpenCV's FileStorage reads its in-memory XML and
  // YAML as a C string: "<?xml version=" followed by NULs crashed it (a null read in libopencv_core
  // 4.6, found by calib_fuzz_import).
  if (const std::size_t nul = text.find('\0'); nul != std::string::npos)
    throw ImportError(path + ": a NUL byte at offset " + std::to_string(nul) + ": not a text file");
  if ((format == Format::Qualisys || format == Format::Panoptic || format == Format::Middlebury) &&
      options.unit_m)
    throw ImportError(path + ": " + format_name(format) +
                      " states its own units (--units is for toml and opencv)");
  Imported out;
  switch (format) {
    case Format::Middlebury:
      out.calibration = parse_middlebury(text, path, options, &out.report);
      break;
    case Format::Qualisys:
      out.calibration = parse_qualisys(text, path, &out.report);
      break;
    case Format::Panoptic:
      out.calibration = parse_panoptic(text, path, &out.report);
      break;
    case Format::Toml:
      out.calibration = parse_toml(text, path, options, &out.report);
      break;
    case Format::OpenCV:
      out.calibration = parse_opencv(text, path, options, &out.report);
      break;
  }
  return out;
}

Imported import_calibration(Format format, const std::string& path, const ImportOptions& options) {
  return parse_import(format, rig::read_input_file(path, kMaxImportBytes), path, options);
}

}  // namespace vc::calib
