# Unity builds (issue 29): each target's sources compiled in batches of GAUSS_UNITY_BATCH, each
# batch one translation unit that includes them. The headers a batch shares are parsed once and
# the templates and inline functions they share are compiled once per batch instead of once per
# file: in a first, partly failing try the compile steps of the engine, its tests, the render
# library and the headless XR runtime took 32-45 % less CPU time (g++ 12, -O2, precompiled
# headers on as well).
#
# What it asks of the sources: names at namespace scope in a .cpp file (anonymous namespaces
# included) must not clash with another file's of the same target, and every file of the
# target must include a header the same way (one with an include guard that depends on what
# came before, like GLFW's, goes through one header: apps/gauss-view/glfw.h). CMake leaves
# out of batches the files with their own compile definitions or options. GAUSS_UNITY=OFF
# compiles every file alone: that build shows a file that only compiles because of another
# in its batch (a missing include).
option(GAUSS_UNITY "Compile each target's sources in batches (unity build)" ON)
set(GAUSS_UNITY_BATCH 8 CACHE STRING "Sources per unity batch")
if(GAUSS_UNITY)
  set(CMAKE_UNITY_BUILD ON)
  set(CMAKE_UNITY_BUILD_BATCH_SIZE ${GAUSS_UNITY_BATCH})
  # -Wsubobject-linkage is about headers: a class defined in a header with a member of an
  # anonymous-namespace type is a different class in every file that includes it. In a batch
  # every source is an included file, so it fires on our pimpl structs (Impl holding a type
  # of its own .cpp's anonymous namespace), which are defined in exactly one source.
  add_compile_options($<$<COMPILE_LANG_AND_ID:CXX,GNU>:-Wno-subobject-linkage>)
endif()
