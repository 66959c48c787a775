// `voxcap proto dump FILE|-`: prints the messages of a capture (a raw message stream, as TCP carries it
// and as the protocol test vectors store it), one block per message with the header fields and then
// the message's fields named as in proto/SPEC.md, or one JSON object per line with --json. A decode
// error is printed with its code and stream offset and makes the command exit non-zero.
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "voxcap/proto.h"
#include "voxcap/proto_json.hpp"

namespace vc::cli {
namespace {

struct DumpArgs {
  std::string file;
  proto::DumpOptions opt;
};

void run_dump(const DumpArgs& a) {
  std::string why;
  if (!a.opt.valid(&why)) throw UsageError(why);
  std::ifstream file;
  std::istream* in = &std::cin;
  if (a.file != "-") {
    file.open(a.file, std::ios::binary);
    if (!file) throw UsageError(fmt::format("cannot open {}", a.file));
    in = &file;
  }
  const proto::DumpResult r = proto::dump(*in, std::cout, a.opt);
  if (!a.opt.json)
    std::cout << fmt::format("# {} message{}, {} rejected{}\n", r.messages, r.messages == 1 ? "" : "s",
                             r.rejected,
                             r.fatal ? fmt::format(", stream unusable from offset {}", r.fatal_offset) : "");
  std::cout.flush();
  if (r.fatal)
    throw std::runtime_error(fmt::format("{}: decode error at offset {}: {} ({}): {}", a.file, r.fatal_offset,
                                         vc_proto_error_name(r.fatal), vc_proto_strerror(r.fatal),
                                         r.fatal_detail));
  if (r.rejected)
    throw std::runtime_error(
        fmt::format("{}: {} message{} rejected (see above)", a.file, r.rejected, r.rejected == 1 ? "" : "s"));
}

}  // namespace

void add_proto_commands(CLI::App& app) {
  CLI::App* proto = app.add_subcommand("proto", "Wire-protocol tools (proto/SPEC.md)");
  proto->require_subcommand(1, 1);
  auto args = std::make_shared<DumpArgs>();
  CLI::App* dump = proto->add_subcommand(
      "dump",
      "Print every message of a capture file or stream: header fields, then the message's fields as named in "
      "proto/SPEC.md. Exits 1 at a decode error (printed with its code and offset) or if a message was "
      "rejected.");
  dump->add_option("FILE", args->file,
                   "Capture to read: a raw stream of messages as TCP carries them; - for stdin")
      ->required();
  dump->add_flag("--json", args->opt.json,
                 "Print one JSON object per line (message or error event) instead of text");
  dump->add_option("--max-payload", args->opt.max_payload,
                   "Reject messages with a larger payload, in bytes, like a receiver created with this limit "
                   "(default and maximum: 8388608)");
  dump->add_option("--hex-bytes", args->opt.fields.max_hex_bytes,
                   "Show at most this many bytes of HULL RLE and of unknown payloads as hex")
      ->default_val(64);
  dump->add_option("--runs", args->opt.fields.max_runs, "List the first N runs of each HULL (0: none)")
      ->default_val(16);
  dump->callback([args] { run_dump(*args); });
}

}  // namespace vc::cli
