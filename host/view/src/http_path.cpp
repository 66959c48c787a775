#include "voxcap/view/http_path.hpp"

#include <system_error>

namespace vc::view {
namespace {

bool fail(std::string* why, std::string text) {
  if (why) *why = std::move(text);
  return false;
}

int hex(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

bool safe_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_' ||
         c == '.' || c == '/';
}

bool ends_with(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

}  // namespace

bool resolve_target(std::string_view target, std::string* relative, std::string* why) {
  if (target.size() > kMaxTarget) return fail(why, "target too long");
  if (target.empty() || target[0] != '/') return fail(why, "target is not an absolute path");
  const size_t q = target.find_first_of("?#");
  if (q != std::string_view::npos) target = target.substr(0, q);
  std::string path;
  path.reserve(target.size());
  for (size_t i = 0; i < target.size(); i++) {
    char c = target[i];
    if (c == '%') {
      if (i + 2 >= target.size()) return fail(why, "bad percent-encoding");
      const int hi = hex(target[i + 1]), lo = hex(target[i + 2]);
      if (hi < 0 || lo < 0) return fail(why, "bad percent-encoding");
      c = static_cast<char>(hi * 16 + lo);
      i += 2;
    }
    if (!safe_char(c)) return fail(why, "unsafe character in the path");
    path.push_back(c);
  }
  // Segments: no "", ".", "..", nor hidden names; "/" alone is the index.
  std::string out;
  size_t start = 1;
  while (start <= path.size()) {
    size_t end = path.find('/', start);
    if (end == std::string::npos) end = path.size();
    const std::string_view seg(path.data() + start, end - start);
    if (seg.empty()) {
      if (end != path.size()) return fail(why, "empty path segment");
    } else {
      if (seg[0] == '.') return fail(why, "a path segment starts with '.'");
      if (!out.empty()) out.push_back('/');
      out.append(seg);
    }
    start = end + 1;
  }
  if (out.empty() || path.back() == '/') out += out.empty() ? "index.html" : "/index.html";
  *relative = std::move(out);
  return true;
}

std::string_view mime_type(std::string_view path) {
  struct Ext {
    std::string_view ext, type;
  };
  static constexpr Ext kTypes[] = {
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".json", "application/json"},
      {".md", "text/markdown; charset=utf-8"},
      {".txt", "text/plain; charset=utf-8"},
      {".png", "image/png"},
      {".svg", "image/svg+xml"},
      {".ico", "image/x-icon"},
      {".wasm", "application/wasm"},
  };
  for (const Ext& e : kTypes)
    if (ends_with(path, e.ext)) return e.type;
  return "application/octet-stream";
}

bool asset_file(const std::filesystem::path& root, const std::string& relative, std::filesystem::path* out,
                std::string* why) {
  std::error_code ec;
  const std::filesystem::path base = std::filesystem::canonical(root, ec);
  if (ec) return fail(why, "no asset folder");
  const std::filesystem::path p = std::filesystem::canonical(base / relative, ec);
  if (ec) return fail(why, "not found");
  // Inside root after symlinks: base must be a prefix of p, segment by segment.
  auto b = base.begin();
  auto i = p.begin();
  for (; b != base.end(); ++b, ++i)
    if (i == p.end() || *i != *b) return fail(why, "outside the asset folder");
  if (!std::filesystem::is_regular_file(p, ec)) return fail(why, "not a file");
  const auto size = std::filesystem::file_size(p, ec);
  if (ec || size > kMaxAssetBytes) return fail(why, "too large");
  *out = p;
  return true;
}

}  // namespace vc::view
