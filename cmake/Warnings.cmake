# Project code builds with warnings as errors; third-party code (the ImGui
# backend, stb) is compiled through its own targets without these flags.
function(gauss_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Woverloaded-virtual
    -Wformat=2 -Wimplicit-fallthrough -Werror)
endfunction()
