// Running a shell script on a board. The real backend is the OpenSSH client as a subprocess (BatchMode,
// the inventory's known_hosts, connect and step timeouts); its twin runs the script with the local sh,
// for tests of the deploy logic without an ssh server. The script goes in on stdin, never in argv, so
// the rig key it may carry never shows in a process list.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "voxcap/deploy/inventory.hpp"

namespace vc::deploy {

struct ProcessResult {
  int exit_code = -1;  // the process's exit code; -1 when it did not exit (killed, timed out, not started)
  bool timed_out = false;
  std::string out, err;  // each bounded to kMaxOutputBytes (the rest dropped)
  std::string why;       // a one-line reason when it could not run
};

inline constexpr std::size_t kMaxOutputBytes = std::size_t{1} << 20;

// Runs argv[0] (looked up in PATH) with `input` on its stdin; kills it (SIGKILL to its process group)
// after timeout_s. Never throws for the child's failures.
ProcessResult run_process(const std::vector<std::string>& argv, const std::string& input, double timeout_s);

class Remote {
 public:
  virtual ~Remote() = default;
  // Runs `script` with sh on the board, through the board's `sudo` when as_root.
  virtual ProcessResult run(const Board& board, const std::string& script, bool as_root) = 0;
  virtual std::string name() const = 0;
};

// OpenSSH: `ssh -T -o BatchMode=yes ... TARGET -- [sudo] sh -s`.
class SshRemote : public Remote {
 public:
  ProcessResult run(const Board& board, const std::string& script, bool as_root) override;
  std::string name() const override { return "ssh"; }
  // The ssh command line for a board (without the script), for --dry-run and tests.
  static std::vector<std::string> command(const Board& board, bool as_root);
};

// The emulated twin: `[sudo] sh -s` on this machine (board.settings.root is the board).
class LocalRemote : public Remote {
 public:
  ProcessResult run(const Board& board, const std::string& script, bool as_root) override;
  std::string name() const override { return "local"; }
};

}  // namespace vc::deploy
