# Compiler settings for the project's own targets, in one place.
function(terrain_compile_options target)
  target_compile_features(${target} PUBLIC cxx_std_17)
  if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                             -Wno-deprecated-declarations -Werror)
  endif()
endfunction()
