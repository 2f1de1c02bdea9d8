# Project code builds with warnings as errors; third-party code (volk, stb) is
# compiled through its own targets without these flags.
function(gauss_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Woverloaded-virtual
    -Wformat=2 -Wimplicit-fallthrough -Werror)
  if(GAUSS_SANITIZE AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    # GCC's flow analysis reports false "may be used uninitialized" under ASan's
    # instrumentation; they stay visible as warnings there, and are errors elsewhere.
    target_compile_options(${target} PRIVATE -Wno-error=maybe-uninitialized)
  endif()
endfunction()
