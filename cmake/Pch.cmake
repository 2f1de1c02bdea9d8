# Precompiled headers (issue 29). Nearly every translation unit parses the same standard
# library and GLM headers, every test GoogleTest, most of gauss-eval and gauss-bench
# nlohmann/json: measured alone (g++ 12, -O2, one core) the standard headers we use take
# ~1.5 s, GoogleTest ~1.2 s, nlohmann/json ~1.8 s per translation unit, of TUs taking 2-5 s.
# A precompiled header loads in ~0.2 s.
#
# A few kinds, each precompiled once in its own small object library (gauss_pch_<kind>) and
# reused (REUSE_FROM) by every target of that kind. The targets share the compile flags that
# matter to a PCH (the build type's, the sanitizers', the warnings), and GCC refuses a PCH
# built with different ones: CMake passes -Winvalid-pch, which our -Werror makes fatal, so a
# mismatch fails the build instead of silently parsing the headers again.
#
# What stays out, measured: CLI11 2.1 defines its validators as namespace-scope objects, so
# every TU that sees it generates their code (~4.5 s even for an empty file); a PCH holding it
# would charge that to the TUs that never include it. nlohmann/json costs a TU that does not
# use it ~0.5 s from a PCH, so only the two programs where most TUs use it get it. Vulkan
# (volk.h, ~0.1 s) is cheap to parse and not worth a kind of its own.
#
# Sources keep their own includes: the PCH only makes them faster. GAUSS_PCH=OFF builds
# every file from its own includes alone (a missing include shows there), or works around a
# compiler that mishandles precompiled headers.
option(GAUSS_PCH "Precompile the common standard library, GLM, GoogleTest and nlohmann/json headers" ON)

set(GAUSS_PCH_STD
  <algorithm> <array> <atomic> <chrono> <cmath> <cstddef> <cstdint> <cstdio> <cstdlib> <cstring>
  <filesystem> <fstream> <functional> <limits> <map> <memory> <mutex> <optional> <random> <set>
  <span> <sstream> <string> <string_view> <thread> <unordered_map> <utility> <vector>)
set(GAUSS_PCH_GLM
  <glm/vec3.hpp> <glm/vec4.hpp> <glm/mat3x3.hpp> <glm/mat4x4.hpp> <glm/geometric.hpp>
  <glm/common.hpp> <glm/gtc/quaternion.hpp>)

# gauss_pch_<kind>: an object library that holds the kind's precompiled header (its one
# source is empty), linked to LINK for the headers' include paths and definitions.
function(gauss_pch_kind kind)
  if(NOT GAUSS_PCH)
    return()
  endif()
  cmake_parse_arguments(arg "" "" "HEADERS;LINK" ${ARGN})
  add_library(gauss_pch_${kind} OBJECT EXCLUDE_FROM_ALL ${CMAKE_SOURCE_DIR}/cmake/pch_anchor.cpp)
  target_link_libraries(gauss_pch_${kind} PRIVATE ${arg_LINK})
  target_precompile_headers(gauss_pch_${kind} PRIVATE ${arg_HEADERS})
  gauss_warnings(gauss_pch_${kind})
endfunction()

# Compiles `target` with kind `kind`'s precompiled header (nothing with GAUSS_PCH=OFF).
# g++ 12 does not restore `#pragma GCC diagnostic` state from a PCH, so libstdc++'s own
# silencing of its false positives in std::char_traits (bits/char_traits.h: -Wstringop-overflow,
# -Wstringop-overread, -Warray-bounds, inlined into std::string operator+) is lost and
# -Werror fails 4 of our files on code that compiles clean without the PCH (the generated
# code is the same, function for function). With a PCH and g++ < 13 those three warnings are
# off; a GAUSS_PCH=OFF build still reports them.
function(gauss_use_pch target kind)
  if(GAUSS_PCH)
    target_precompile_headers(${target} REUSE_FROM gauss_pch_${kind})
    if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
      target_compile_options(${target} PRIVATE -Wno-array-bounds -Wno-stringop-overflow -Wno-stringop-overread)
    endif()
  endif()
endfunction()

# lib: the standard library and GLM: the libraries, the programs, the fuzz replays.
gauss_pch_kind(lib HEADERS ${GAUSS_PCH_STD} ${GAUSS_PCH_GLM} LINK glm::glm)
# json: lib + nlohmann/json, for gauss-eval and gauss-bench (most of their TUs use it).
gauss_pch_kind(json HEADERS ${GAUSS_PCH_STD} ${GAUSS_PCH_GLM} <nlohmann/json.hpp>
  LINK glm::glm nlohmann_json::nlohmann_json)
# test: lib + GoogleTest, for every executable of tests/ that uses it.
if(NOT GAUSS_LIBRARIES_ONLY)
  gauss_pch_kind(test HEADERS ${GAUSS_PCH_STD} ${GAUSS_PCH_GLM} <gtest/gtest.h>
    LINK glm::glm GTest::gtest)
endif()
