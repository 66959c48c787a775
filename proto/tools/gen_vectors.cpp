// vc_proto_vectors DIR: regenerates the protocol test vectors into DIR (normally proto/vectors).
#include <cstdio>
#include <exception>

#include "vectors.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr,
                 "usage: %s DIR\n  writes the proto test vectors (*.bin, *.json, README.md) into DIR\n",
                 argv[0]);
    return 2;
  }
  try {
    auto files = vc::proto::vectors::write_all(argv[1]);
    std::printf("wrote %zu files to %s\n", files.size(), argv[1]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vc_proto_vectors: %s\n", e.what());
    return 1;
  }
  return 0;
}
