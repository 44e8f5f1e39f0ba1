#include "rig/file_io.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <limits>

namespace terrain::io {
namespace {

namespace fs = std::filesystem;

// More bytes than any filesystem has free is refused with the output, the need and the free space
// named; a byte is not; an output below directories still to be made is judged by its nearest
// existing ancestor
TEST(FileIoTest, RequireSpaceRefusesWhatCannotFit) {
  const fs::path out = fs::temp_directory_path() / "terrain-space-test" / "a" / "b";
  EXPECT_NO_THROW(requireSpace(out, 1, "one byte"));
  try {
    requireSpace(out, std::numeric_limits<std::uintmax_t>::max(), "recording 9 frames");
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(out.string() + ": recording 9 frames needs at least"), std::string::npos) << m;
    EXPECT_NE(m.find(" GB free"), std::string::npos) << m;
    EXPECT_NE(m.find(fs::temp_directory_path().string()), std::string::npos) << m;
  }
  EXPECT_FALSE(fs::exists(out.parent_path().parent_path()));
}

}  // namespace
}  // namespace terrain::io
