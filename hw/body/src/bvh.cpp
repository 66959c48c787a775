// BVH reader and writer. The reader is a bounds-checked tokenizer over the whole text (it is fed
// user files and is fuzzed): HIERARCHY with ROOT/JOINT/End Site blocks, OFFSET and CHANNELS per
// joint, then MOTION with "Frames:", "Frame Time:" and frames * channels numbers. Channel order is
// kept per joint, exactly as written, because real files mix orders (ZYX legs with ZXY arms).
#include "voxcap/body/bvh.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <glm/matrix.hpp>

#include "voxcap/body/joints.hpp"

namespace vc::body {
namespace {

class Lexer {
 public:
  Lexer(std::string_view text, const std::string& source) : text_(text), source_(source) {}

  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error(source_ + ":" + std::to_string(line_) + ": " + what);
  }

  bool at_end() {
    skip_space();
    return pos_ >= text_.size();
  }

  std::string_view token() {
    skip_space();
    if (pos_ >= text_.size()) fail("unexpected end of file");
    const std::size_t start = pos_;
    while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
    return text_.substr(start, pos_ - start);
  }

  std::string_view peek() {
    const std::size_t save_pos = pos_;
    const int save_line = line_;
    skip_space();
    std::string_view t;
    if (pos_ < text_.size()) t = token();
    pos_ = save_pos;
    line_ = save_line;
    return t;
  }

  void expect(std::string_view want) {
    const std::string_view got = token();
    if (got != want)
      fail("expected '" + std::string(want) + "', got '" + std::string(got.substr(0, 40)) + "'");
  }

  // The rest of the current line, trimmed (joint names may contain spaces or colons).
  std::string rest_of_line() {
    while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\t')) ++pos_;
    const std::size_t start = pos_;
    while (pos_ < text_.size() && text_[pos_] != '\n' && text_[pos_] != '\r') ++pos_;
    std::size_t end = pos_;
    while (end > start && (text_[end - 1] == ' ' || text_[end - 1] == '\t')) --end;
    return std::string(text_.substr(start, end - start));
  }

  double number() {
    const std::string_view t = token();
    double v = 0;
    const char* first = t.data();
    const char* last = t.data() + t.size();
    if (first != last && *first == '+') ++first;
    const auto [ptr, ec] = std::from_chars(first, last, v);
    if (ec != std::errc() || ptr != last || !std::isfinite(v)) {
      fail("expected a number, got '" + std::string(t.substr(0, 40)) + "'");
    }
    // Finite but absurd (1e308 overflows forward kinematics into inf and NaN): no motion file needs
    // more than kBvhMaxMagnitude (10,000 km in millimetres).
    if (std::abs(v) > kBvhMaxMagnitude)
      fail("number out of range (|x| > 1e10): '" + std::string(t.substr(0, 40)) + "'");
    return v;
  }

  long integer() {
    const std::string_view t = token();
    long v = 0;
    const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
    if (ec != std::errc() || ptr != t.data() + t.size()) {
      fail("expected an integer, got '" + std::string(t.substr(0, 40)) + "'");
    }
    return v;
  }

  std::size_t remaining() const { return text_.size() - pos_; }

 private:
  static bool is_space(char c) {
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v';
  }
  void skip_space() {
    while (pos_ < text_.size() && is_space(text_[pos_])) {
      if (text_[pos_] == '\n') ++line_;
      ++pos_;
    }
  }

  std::string_view text_;
  const std::string& source_;
  std::size_t pos_ = 0;
  int line_ = 1;
};

BvhChannel parse_channel(Lexer& lx) {
  const std::string_view t = lx.token();
  if (t == "Xposition") return BvhChannel::Xposition;
  if (t == "Yposition") return BvhChannel::Yposition;
  if (t == "Zposition") return BvhChannel::Zposition;
  if (t == "Xrotation") return BvhChannel::Xrotation;
  if (t == "Yrotation") return BvhChannel::Yrotation;
  if (t == "Zrotation") return BvhChannel::Zrotation;
  lx.fail("unknown channel '" + std::string(t.substr(0, 40)) + "'");
}

glm::dvec3 parse_offset(Lexer& lx) {
  lx.expect("OFFSET");
  const double x = lx.number(), y = lx.number(), z = lx.number();
  return {x, y, z};
}

// Parses the block after "ROOT name" / "JOINT name" (the name already read).
void parse_joint(Lexer& lx, BvhClip& clip, const std::string& name, int parent, int depth) {
  if (depth > 256) lx.fail("hierarchy nested too deeply");
  if (static_cast<int>(clip.skeleton.joints.size()) >= kBvhMaxJoints) lx.fail("too many joints");
  const int index = static_cast<int>(clip.skeleton.joints.size());
  clip.skeleton.joints.push_back({name, parent, {0, 0, 0}, false});
  clip.channels.emplace_back();
  clip.first_channel.push_back(clip.channel_count);
  lx.expect("{");
  clip.skeleton.joints[static_cast<std::size_t>(index)].offset = parse_offset(lx);
  if (lx.peek() == "CHANNELS") {
    lx.token();
    const long n = lx.integer();
    if (n < 0 || n > 6) lx.fail("CHANNELS count must be 0..6");
    for (long i = 0; i < n; ++i) clip.channels[static_cast<std::size_t>(index)].push_back(parse_channel(lx));
    clip.channel_count += static_cast<int>(n);
  }
  for (;;) {
    const std::string_view t = lx.token();
    if (t == "}") return;
    if (t == "JOINT") {
      const std::string child = lx.rest_of_line();
      if (child.empty()) lx.fail("JOINT without a name");
      parse_joint(lx, clip, child, index, depth + 1);
    } else if (t == "End") {
      lx.expect("Site");
      if (static_cast<int>(clip.skeleton.joints.size()) >= kBvhMaxJoints) lx.fail("too many joints");
      lx.expect("{");
      const glm::dvec3 off = parse_offset(lx);
      lx.expect("}");
      clip.skeleton.joints.push_back({name + "_end", index, off, true});
      clip.channels.emplace_back();
      clip.first_channel.push_back(clip.channel_count);
    } else {
      lx.fail("expected JOINT, End Site or '}', got '" + std::string(t.substr(0, 40)) + "'");
    }
  }
}

glm::dmat3 axis_rotation(BvhChannel c, double degrees) {
  const double a = degrees * M_PI / 180.0;
  switch (c) {
    case BvhChannel::Xrotation:
      return rot_x(a);
    case BvhChannel::Yrotation:
      return rot_y(a);
    default:
      return rot_z(a);
  }
}

}  // namespace

BvhClip parse_bvh(std::string_view text, const std::string& source_name) {
  Lexer lx(text, source_name);
  BvhClip clip;
  lx.expect("HIERARCHY");
  lx.expect("ROOT");
  const std::string root = lx.rest_of_line();
  if (root.empty()) lx.fail("ROOT without a name");
  parse_joint(lx, clip, root, -1, 0);
  const std::string_view after = lx.token();
  if (after == "ROOT") lx.fail("more than one ROOT is not supported");
  if (after != "MOTION") lx.fail("expected MOTION, got '" + std::string(after.substr(0, 40)) + "'");
  lx.expect("Frames:");
  const long frames = lx.integer();
  if (frames < 0 || frames > kBvhMaxFrames) lx.fail("Frames: out of range");
  lx.expect("Frame");
  lx.expect("Time:");
  {
    const std::string_view t = lx.peek();
    const auto dot = t.find('.');
    if (dot != std::string_view::npos) {
      std::size_t e = dot + 1;
      while (e < t.size() && t[e] >= '0' && t[e] <= '9') ++e;
      clip.frame_time_decimals = static_cast<int>(e - dot - 1);
    }
  }
  clip.frame_time_s = lx.number();
  if (!(clip.frame_time_s > 0) || clip.frame_time_s > 10) lx.fail("Frame Time: must be in (0, 10] seconds");
  clip.frames = static_cast<int>(frames);
  const std::size_t count = static_cast<std::size_t>(frames) * static_cast<std::size_t>(clip.channel_count);
  // Every value takes at least two bytes ("0 "), so a count the text cannot hold is an error
  // before any allocation.
  if (count > lx.remaining() / 2 + 1) lx.fail("Frames x channels is larger than the file holds");
  clip.values.reserve(count);
  for (std::size_t i = 0; i < count; ++i) clip.values.push_back(lx.number());
  if (!lx.at_end()) lx.fail("more values than Frames x channels");
  // Position channels that repeat the OFFSET (absolute) or move away from it (added).
  clip.positions_absolute.assign(clip.skeleton.joints.size(), 0);
  for (std::size_t j = 0; j < clip.skeleton.joints.size(); ++j) {
    double from_offset = 0, from_zero = 0;
    bool any = false;
    for (std::size_t c = 0; c < clip.channels[j].size(); ++c) {
      const int axis = static_cast<int>(clip.channels[j][c]);
      if (axis > 2) continue;
      any = true;
      const double off = clip.skeleton.joints[j].offset[axis];
      for (long f = 0; f < frames; ++f) {
        const double v = clip.frame_values(static_cast<int>(f))[clip.first_channel[j] + static_cast<int>(c)];
        from_offset += std::abs(v - off);
        from_zero += std::abs(v);
      }
    }
    clip.positions_absolute[j] = any && from_offset < from_zero ? 1 : 0;
  }
  std::string why;
  if (!clip.skeleton.valid(&why)) lx.fail(why);
  return clip;
}

BvhClip read_bvh(const std::string& path) {
  // As hw/rig's read_input_file (hw/body links GLM only): O_NONBLOCK so that a FIFO cannot block the
  // open, fstat for a regular file, a size limit before reading.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) throw std::runtime_error(path + ": cannot open: " + std::strerror(errno));
  std::string text;
  struct stat st {};
  const char* problem = nullptr;
  if (::fstat(fd, &st) != 0)
    problem = "cannot read";
  else if (!S_ISREG(st.st_mode))
    problem = S_ISDIR(st.st_mode) ? "not a regular file (a directory)" : "not a regular file";
  else if (static_cast<unsigned long long>(st.st_size) > kBvhMaxFileBytes)
    problem = "larger than 1 GiB";
  if (!problem) {
    (void)::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
    text.resize(static_cast<std::size_t>(st.st_size));
    std::size_t got = 0;
    while (got < text.size()) {
      const ssize_t n = ::read(fd, text.data() + got, text.size() - got);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) break;
      got += static_cast<std::size_t>(n);
    }
    if (got != text.size()) problem = "read error (the file shrank?)";
  }
  ::close(fd);
  if (problem) throw std::runtime_error(path + ": " + problem);
  return parse_bvh(text, path);
}

Pose BvhClip::pose(int frame, double scale) const {
  if (frame < 0 || frame >= frames) throw std::out_of_range("BvhClip::pose: frame out of range");
  const double* v = frame_values(frame);
  const std::size_t n = skeleton.joints.size();
  Pose pose;
  pose.local.assign(n, glm::dmat3(1.0));
  bool any_translation = false;
  std::vector<glm::dvec3> translation(n, glm::dvec3(0, 0, 0));
  for (std::size_t j = 0; j < n; ++j) {
    const double* jv = v + first_channel[j];
    glm::dmat3 R(1.0);
    glm::dvec3 t(0, 0, 0);
    // Absolute positions: the offset is added back in forward kinematics.
    const glm::dvec3 base =
        j < positions_absolute.size() && positions_absolute[j] ? skeleton.joints[j].offset : glm::dvec3(0);
    for (std::size_t c = 0; c < channels[j].size(); ++c) {
      switch (channels[j][c]) {
        case BvhChannel::Xposition:
          t[0] = (jv[c] - base[0]) * scale;
          break;
        case BvhChannel::Yposition:
          t[1] = (jv[c] - base[1]) * scale;
          break;
        case BvhChannel::Zposition:
          t[2] = (jv[c] - base[2]) * scale;
          break;
        default:
          R = R * axis_rotation(channels[j][c], jv[c]);
          break;
      }
    }
    pose.local[j] = R;
    if (j == 0) {
      pose.root_position = t;
    } else if (t != glm::dvec3(0, 0, 0)) {
      translation[j] = t;
      any_translation = true;
    }
  }
  if (any_translation) pose.translation = std::move(translation);
  return pose;
}

Skeleton BvhClip::scaled_skeleton(double scale) const {
  Skeleton s = skeleton;
  for (auto& j : s.joints) j.offset *= scale;
  return s;
}

bool BvhWriteOptions::valid(std::string* why) const {
  std::ostringstream os;
  const double det = glm::determinant(R_file_from_world);
  const glm::dmat3 should_be_eye = glm::transpose(R_file_from_world) * R_file_from_world;
  double off = 0;
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r < 3; ++r) off = std::max(off, std::abs(should_be_eye[c][r] - (r == c ? 1.0 : 0.0)));
  }
  if (!(std::abs(det - 1) < 1e-9 && off < 1e-9)) {
    os << "R_file_from_world must be a rotation";
  } else if (!(units_per_metre > 0 && units_per_metre <= 1e6)) {
    os << "units_per_metre must be in (0, 1e6]";
  } else if (decimals < 1 || decimals > 12) {
    os << "decimals must be in [1, 12]";
  } else {
    return true;
  }
  if (why) *why = os.str();
  return false;
}

BvhWriteOptions BvhWriteOptions::blender() {
  BvhWriteOptions o;
  // rot_x(-pi/2) with exact zeros: world z -> file Y, world y -> file -Z.
  o.R_file_from_world = from_rows(1, 0, 0, 0, 0, 1, 0, -1, 0);
  o.units_per_metre = 1.0;
  o.standard_names = true;
  return o;
}

std::string format_bvh(const Skeleton& skeleton, const std::vector<Pose>& poses, double frame_time_s,
                       const BvhWriteOptions& options) {
  std::string why;
  if (!skeleton.valid(&why)) throw std::invalid_argument("format_bvh: " + why);
  if (!options.valid(&why)) throw std::invalid_argument("format_bvh: " + why);
  if (!(frame_time_s > 0 && frame_time_s <= 10))
    throw std::invalid_argument("format_bvh: frame time must be in (0, 10] s");
  if (skeleton.joints[0].end_site) throw std::invalid_argument("format_bvh: the root cannot be an End Site");
  if (options.standard_names && !is_standard(skeleton)) {
    throw std::invalid_argument("format_bvh: standard names need the standard skeleton");
  }
  const std::size_t n = skeleton.joints.size();
  const glm::dmat3& A = options.R_file_from_world;
  const glm::dmat3 At = glm::transpose(A);
  const double u = options.units_per_metre;
  const int d = options.decimals;
  auto name_of = [&](int j) {
    return options.standard_names ? std::string(joint_bvh_name(j))
                                  : skeleton.joints[static_cast<std::size_t>(j)].name;
  };
  std::string out = "HIERARCHY\n";
  char buf[256];
  // Values that print as zero print as "0.000", never "-0.000" (-0.0 and -1e-17 from rotations).
  const double zero_below = 0.5 * std::pow(10.0, -d);
  auto clean = [&](double x) { return std::abs(x) < zero_below ? 0.0 : x; };
  auto vec3 = [&](const glm::dvec3& v) {
    std::snprintf(buf, sizeof buf, "%.*f %.*f %.*f", d, clean(v[0]), d, clean(v[1]), d, clean(v[2]));
    return std::string(buf);
  };
  // Depth-first in index order (parents precede children, so children lists are in order).
  std::vector<std::vector<int>> kids(n);
  for (std::size_t j = 1; j < n; ++j)
    kids[static_cast<std::size_t>(skeleton.joints[j].parent)].push_back(static_cast<int>(j));
  for (std::size_t j = 0; j < n; ++j) {
    if (skeleton.joints[j].end_site && !kids[j].empty()) {
      throw std::invalid_argument("format_bvh: End Site " + skeleton.joints[j].name + " has children");
    }
  }
  std::vector<int> order;  // joints with channels, in the order they appear in the file
  auto emit = [&](auto&& self, int j, int depth) -> void {
    const SkeletonJoint& jt = skeleton.joints[static_cast<std::size_t>(j)];
    const std::string ind(static_cast<std::size_t>(depth), '\t');
    const std::string offset = vec3(A * jt.offset * u);
    if (jt.end_site) {
      out += ind + "End Site\n" + ind + "{\n" + ind + "\tOFFSET " + offset + "\n" + ind + "}\n";
      return;
    }
    out += ind + (j == 0 ? "ROOT " : "JOINT ") + name_of(j) + "\n" + ind + "{\n";
    out += ind + "\tOFFSET " + offset + "\n";
    out += ind + (j == 0 ? "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"
                         : "\tCHANNELS 3 Zrotation Yrotation Xrotation\n");
    order.push_back(j);
    const auto& ch = kids[static_cast<std::size_t>(j)];
    if (ch.empty()) {
      // BVH wants every chain to end in an End Site.
      out += ind + "\tEnd Site\n" + ind + "\t{\n" + ind + "\t\tOFFSET " + vec3(glm::dvec3(0)) + "\n" + ind +
             "\t}\n";
    }
    for (int c : ch) self(self, c, depth + 1);
    out += ind + "}\n";
  };
  emit(emit, 0, 0);
  out += "MOTION\n";
  out += "Frames: " + std::to_string(poses.size()) + "\n";
  std::snprintf(buf, sizeof buf, "Frame Time: %.9f\n", frame_time_s);
  out += buf;
  std::string line;
  for (const Pose& pose : poses) {
    if (pose.local.size() != n) throw std::invalid_argument("format_bvh: pose of another skeleton");
    for (std::size_t j = 1; j < pose.translation.size(); ++j) {
      if (pose.translation[j] != glm::dvec3(0, 0, 0)) {
        throw std::invalid_argument("format_bvh: joint translations are not representable");
      }
    }
    line.clear();
    for (std::size_t i = 0; i < order.size(); ++i) {
      const int j = order[i];
      if (j == 0) line += vec3(A * pose.root_position * u) + " ";
      line += vec3(euler_from_matrix("ZYX", A * pose.local[static_cast<std::size_t>(j)] * At));
      line += i + 1 < order.size() ? " " : "\n";
    }
    out += line;
  }
  return out;
}

void write_bvh(const std::string& path, const Skeleton& skeleton, const std::vector<Pose>& poses,
               double frame_time_s, const BvhWriteOptions& options) {
  const std::string text = format_bvh(skeleton, poses, frame_time_s, options);
  std::ofstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error(path + ": cannot open for writing");
  f << text;
  if (!f) throw std::runtime_error(path + ": write error");
}

}  // namespace vc::body
