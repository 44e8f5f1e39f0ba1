#include "rig/file_io.hpp"

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

}  // namespace terrain::io
