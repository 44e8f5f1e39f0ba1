#pragma once
// Progress of long jobs on the terminal: frames done, rate and time left. On a terminal the line
// is redrawn in place; otherwise a line is printed every tenth of the job.

#include <chrono>
#include <cstdio>
#include <string>
#include <unistd.h>

namespace terrain::app {

class Progress {
 public:
  Progress(std::string what, int total)
      : what_(std::move(what)), total_(total), tty_(isatty(fileno(stderr)) != 0), start_(Clock::now()) {}

  void update(int done) {
    if (what_.empty()) return;
    const double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
    const double rate = elapsed > 0 ? done / elapsed : 0.0;
    const double left = rate > 0 ? (total_ - done) / rate : 0.0;
    const int step = total_ >= 10 ? total_ / 10 : 1;
    if (!tty_ && done != total_ && done % step != 0) return;
    std::fprintf(stderr, "%s%s: %d/%d frames, %.2f frames/s, %.0f s left%s", tty_ ? "\r" : "", what_.c_str(), done,
                 total_, rate, left, tty_ ? "   " : "\n");
    if (tty_ && done == total_) std::fputc('\n', stderr);
    std::fflush(stderr);
  }

 private:
  using Clock = std::chrono::steady_clock;
  std::string what_;
  int total_;
  bool tty_;
  Clock::time_point start_;
};

}  // namespace terrain::app
