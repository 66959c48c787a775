// Prints the folder the viewer would serve its page from (assets.hpp), for install_test.cmake: copied
// into an install tree's bin/, it must find that tree's page. Exit 1 with the viewer's one-line error
// when there is none.
#include <cstdio>

#include "voxcap/view/assets.hpp"

int main() {
  const vc::view::AssetSearch s = vc::view::find_assets();
  if (s.dir.empty()) {
    std::fprintf(stderr, "%s\n", vc::view::no_assets_message(s).c_str());
    return 1;
  }
  std::printf("%s\n", s.dir.c_str());
  return 0;
}
