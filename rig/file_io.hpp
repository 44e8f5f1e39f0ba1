#pragma once
// Safe output: files are written to a temporary name and renamed into place, so a failed write
// never leaves a half-written file, and an existing file or directory is never replaced unless
// the caller allows it.

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace terrain::io {

// Error in user input (a file, a parameter): the message names what is wrong and where.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Reads a whole file. Throws InputError naming the file if it cannot be read.
std::string readFile(const std::filesystem::path& path);

// Writes bytes to path atomically (temporary file, then rename). Throws InputError if the file
// exists and overwrite is false, or if the write fails.
void writeFileAtomic(const std::filesystem::path& path, const std::string& bytes, bool overwrite);

// Prepares an output directory: creates it if absent. If it exists and is not empty, throws
// InputError unless force is true.
void prepareOutputDir(const std::filesystem::path& dir, bool force);

// Throws InputError when the filesystem that will hold `out` (its nearest existing ancestor) has
// fewer than `bytes` bytes free, naming out, what needs them (`what`, e.g. "recording 60 frames")
// and the free space; does nothing when the free space cannot be known.
void requireSpace(const std::filesystem::path& out, std::uintmax_t bytes, const std::string& what);

// An output directory built beside its target (TARGET.partial-PID) and moved into place by
// commit(): until then the target is untouched, and a failure (the destructor without commit)
// removes the partial directory. The constructor refuses a target that exists as a file, or as
// a non-empty directory unless force; commit() then replaces it whole (no old file survives).
class StagedDirectory {
 public:
  StagedDirectory(std::filesystem::path target, bool force);
  ~StagedDirectory();
  StagedDirectory(const StagedDirectory&) = delete;
  StagedDirectory& operator=(const StagedDirectory&) = delete;

  // where to write meanwhile
  const std::filesystem::path& path() const { return partial_; }
  const std::filesystem::path& target() const { return target_; }
  // Moves the directory into place. Throws InputError if it cannot.
  void commit();

 private:
  std::filesystem::path target_, partial_;
  bool force_;
  bool committed_ = false;
};

}  // namespace terrain::io
