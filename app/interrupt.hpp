#pragma once
// Ctrl-C and SIGTERM: the handler only notes the signal; long loops call throwIfInterrupted()
// between frames, so a command stops at a frame boundary, its staged output directory is removed
// (io::StagedDirectory) and main() exits 128 + the signal number (130 for SIGINT, 143 for SIGTERM).

#include <csignal>
#include <stdexcept>
#include <string>

namespace terrain::app {

class Interrupted : public std::runtime_error {
 public:
  explicit Interrupted(int signal)
      : std::runtime_error(signal == SIGTERM ? "terminated (SIGTERM)" : "interrupted (SIGINT)"), signal_(signal) {}
  int signal() const { return signal_; }
  int exitCode() const { return 128 + signal_; }

 private:
  int signal_;
};

inline volatile std::sig_atomic_t g_signal = 0;

inline void noteSignal(int s) { g_signal = s; }

// Installs the handlers for SIGINT and SIGTERM.
inline void installInterruptHandlers() {
  struct sigaction a {};
  a.sa_handler = noteSignal;
  sigemptyset(&a.sa_mask);
  sigaction(SIGINT, &a, nullptr);
  sigaction(SIGTERM, &a, nullptr);
}

// Throws Interrupted once a handled signal has arrived.
inline void throwIfInterrupted() {
  if (g_signal != 0) throw Interrupted(g_signal);
}

}  // namespace terrain::app
