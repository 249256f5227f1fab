// Stop requests for engines (docs/run-directory.md): SIGTERM or SIGINT asks an engine to
// write a checkpoint where it can and end; it then ends by that signal, so whoever started
// it (the runner) sees an interruption, not a failure.
#pragma once

#include <stdexcept>
#include <string>

namespace granary {

// Thrown by an engine's run when it stopped on request (after checkpointing if it could).
class Stopped : public std::runtime_error {
 public:
  Stopped(int signal, const std::string& what) : std::runtime_error(what), signal_(signal) {}
  int Signal() const { return signal_; }

 private:
  int signal_;
};

}  // namespace granary
