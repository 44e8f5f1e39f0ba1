#include "rig/file_io.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

namespace terrain::io {

namespace fs = std::filesystem;

std::string readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw InputError(path.string() + ": cannot open for reading (" + std::strerror(errno) + ")");
  }
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void writeFileAtomic(const fs::path& path, const std::string& bytes, bool overwrite) {
  if (!overwrite && fs::exists(path)) {
    throw InputError(path.string() + ": already exists (pass --force to overwrite)");
  }
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) {
      throw InputError(path.string() + ": cannot open for writing (" + std::strerror(errno) + ")");
    }
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out.flush()) {
      std::error_code ec;
      fs::remove(tmp, ec);
      throw InputError(path.string() + ": write failed");
    }
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw InputError(path.string() + ": cannot move into place");
  }
}

void prepareOutputDir(const fs::path& dir, bool force) {
  std::error_code ec;
  if (fs::exists(dir, ec)) {
    if (!fs::is_directory(dir, ec)) {
      throw InputError(dir.string() + ": exists and is not a directory");
    }
    if (!fs::is_empty(dir, ec) && !force) {
      throw InputError(dir.string() + ": directory exists and is not empty (pass --force to write into it)");
    }
    return;
  }
  fs::create_directories(dir, ec);
  if (ec) {
    throw InputError(dir.string() + ": cannot create directory (" + ec.message() + ")");
  }
}

StagedDirectory::StagedDirectory(fs::path target, bool force) : force_(force) {
  // an absolute, normal form: "out/", "./out" and "." name their directory, not a child of it
  target_ = fs::absolute(target).lexically_normal();
  if (target_.filename().empty()) target_ = target_.parent_path();
  if (target_ == target_.root_path()) throw InputError(target.string() + ": cannot replace the root directory");
  std::error_code ec;
  if (fs::exists(target_, ec)) {
    if (!fs::is_directory(target_, ec)) throw InputError(target_.string() + ": exists and is not a directory");
    if (!fs::is_empty(target_, ec) && !force_) {
      throw InputError(target_.string() + ": directory exists and is not empty (pass --force to replace it)");
    }
  }
  partial_ = target_.parent_path() / (target_.filename().string() + ".partial-" + std::to_string(::getpid()));
  fs::remove_all(partial_, ec);
  fs::create_directories(partial_, ec);
  if (ec) throw InputError(partial_.string() + ": cannot create directory (" + ec.message() + ")");
}

StagedDirectory::~StagedDirectory() {
  if (committed_) return;
  std::error_code ec;
  fs::remove_all(partial_, ec);
}

void StagedDirectory::commit() {
  std::error_code ec;
  fs::path old;
  if (fs::exists(target_, ec)) {
    // the old directory steps aside first, so that a failed rename leaves it in place
    old = partial_;
    old += ".old";
    fs::remove_all(old, ec);
    fs::rename(target_, old, ec);
    if (ec) throw InputError(target_.string() + ": cannot replace it (" + ec.message() + ")");
  }
  fs::rename(partial_, target_, ec);
  if (ec) {
    if (!old.empty()) fs::rename(old, target_);
    throw InputError(target_.string() + ": cannot move the output into place (" + ec.message() + ")");
  }
  committed_ = true;
  if (!old.empty()) fs::remove_all(old, ec);
}

void requireSpace(const fs::path& out, std::uintmax_t bytes, const std::string& what) {
  fs::path at = fs::absolute(out).parent_path();
  while (!fs::exists(at) && at.has_parent_path() && at != at.parent_path()) at = at.parent_path();
  std::error_code ec;
  const fs::space_info space = fs::space(at, ec);
  if (ec || bytes <= space.available) return;
  std::ostringstream m;
  m.precision(3);
  m << out.string() << ": " << what << " needs at least " << static_cast<double>(bytes) / 1e9 << " GB, and "
    << at.string() << " has " << static_cast<double>(space.available) / 1e9 << " GB free";
  throw InputError(m.str());
}

}  // namespace terrain::io
