# GAUSS_SANITIZE=ON instruments everything built in this tree with ASan + UBSan.
# UBSan findings abort (no recovery) so a test fails instead of printing and passing.
if(GAUSS_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer)
  add_link_options(-fsanitize=address,undefined)
endif()

# GAUSS_FUZZ=ON (clang): every library gets libFuzzer coverage instrumentation, so the
# fuzzer sees inside the parsers it drives; the *_libfuzzer binaries link the runtime.
if(GAUSS_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "GAUSS_FUZZ needs clang (configure with CC=clang CXX=clang++)")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer)
  add_link_options(-fsanitize=address,undefined)
endif()
