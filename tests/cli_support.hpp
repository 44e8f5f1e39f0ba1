#pragma once
// For tests that drive the command line: the terrain executable, the committed urban scene, and a
// shell command's exit status as std::system returns it. A test binary using it defines
// TERRAIN_CLI and TERRAIN_SOURCE_DIR.

#include <cstdlib>
#include <string>

namespace terrain::test {

inline const std::string kCli = TERRAIN_CLI;
inline const std::string kUrbanScene = std::string(TERRAIN_SOURCE_DIR) + "/scenes/library/urban_1.xml";
inline int sh(const std::string& command) { return std::system(command.c_str()); }

}  // namespace terrain::test
