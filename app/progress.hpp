#pragma once
// Progress of long jobs on the terminal: frames done, rate and time left. On a terminal the line
// is redrawn in place; otherwise a line is printed every tenth of the job. A job of unknown length
// (total < 0: a live sensor, a capture) reports the frames done and the rate, every 50 frames off a terminal.

#include <unistd.h>
#include <chrono>
#include <cstdio>
#include <string>

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
    if (total_ < 0) {
      if (!tty_ && done % 50 != 0) return;
      std::fprintf(stderr, "%s%s: %d frames, %.2f frames/s%s", tty_ ? "\r" : "", what_.c_str(), done, rate,
                   tty_ ? "   " : "\n");
      std::fflush(stderr);
      open_line_ = tty_;
      return;
    }
    const int step = total_ >= 10 ? total_ / 10 : 1;
    if (!tty_ && done != total_ && done % step != 0) return;
    std::fprintf(stderr, "%s%s: %d/%d frames, %.2f frames/s, %.0f s left%s", tty_ ? "\r" : "", what_.c_str(), done,
                 total_, rate, left, tty_ ? "   " : "\n");
    if (tty_ && done == total_) std::fputc('\n', stderr);
    std::fflush(stderr);
  }

  // ends a line left open on the terminal by a job of unknown length
  void finish() {
    if (open_line_) std::fputc('\n', stderr);
    open_line_ = false;
  }

 private:
  using Clock = std::chrono::steady_clock;
  std::string what_;
  int total_;
  bool tty_;
  bool open_line_ = false;
  Clock::time_point start_;
};

}  // namespace terrain::app
