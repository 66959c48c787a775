// libFuzzer target for the viewer's request-target parser (http_path.hpp), the one place a browser's
// bytes become a file name. On every input: resolve_target() either refuses with a reason or gives a
// relative path of safe bytes only, no empty, "." or hidden segment, no leading '/', bounded in size;
// and asset_file() on an accepted path, under a scratch asset folder with a file beside it, never
// answers with a file outside that folder. mime_type() takes anything.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "voxcap/view/http_path.hpp"

namespace {

std::filesystem::path g_base;  // a scratch folder, removed at exit
std::filesystem::path g_root;  // g_base/www, with g_base/secret.txt beside it

void check(bool ok) {
  if (!ok) std::abort();
}

bool safe(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_' ||
         c == '.' || c == '/';
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  g_base = std::filesystem::temp_directory_path() / ("vc_fuzz_http_path_" + std::to_string(::getpid()));
  const std::filesystem::path& base = g_base;
  std::filesystem::create_directories(base / "www" / "lib");
  std::ofstream(base / "www" / "index.html") << "index";
  std::ofstream(base / "www" / "lib" / "a.js") << "a";
  std::ofstream(base / "secret.txt") << "secret";
  std::error_code ec;
  std::filesystem::create_symlink(base / "secret.txt", base / "www" / "lib" / "link.js", ec);  // leads out
  g_root = std::filesystem::canonical(base / "www");
  std::atexit([] {
    std::error_code e;
    std::filesystem::remove_all(g_base, e);
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view target(reinterpret_cast<const char*>(data), size);
  (void)vc::view::mime_type(target);
  std::string rel, why;
  if (!vc::view::resolve_target(target, &rel, &why)) {
    check(!why.empty());
    return 0;
  }
  check(!rel.empty() && rel.size() <= vc::view::kMaxTarget + 16);
  check(rel.front() != '/');
  size_t start = 0;
  for (;;) {
    const size_t end = rel.find('/', start);
    const std::string_view seg(rel.data() + start, (end == std::string::npos ? rel.size() : end) - start);
    check(!seg.empty() && seg.front() != '.');
    for (char c : seg) check(safe(c) && c != '/');
    if (end == std::string::npos) break;
    start = end + 1;
  }
  std::filesystem::path file;
  if (vc::view::asset_file(g_root, rel, &file, &why)) {
    const std::string f = file.string(), root = g_root.string() + "/";
    check(f.compare(0, root.size(), root) == 0);
    check(std::filesystem::is_regular_file(file));
  }
  return 0;
}
