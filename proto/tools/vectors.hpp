// The test-vector generator behind proto/vectors/ (see proto/vectors/README.md, which it also writes).
// Every vector is a byte stream <name>.bin and <name>.json: the events a conforming decoder must
// produce from it (decoded fields of each message, or the error code and offset of each rejection).
// Expected fields come from the structures the generator encoded, not from decoding its output.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace vc::proto::vectors {

// Writes all vector files into `dir` (created if missing) and returns their names, sorted.
// Deterministic: the same library version writes byte-identical files on every platform.
std::vector<std::string> write_all(const std::filesystem::path& dir);

}  // namespace vc::proto::vectors
