# Toolchain for cross-compiling to 64-bit ARM Linux (aarch64) on a Debian amd64 machine with
# Debian's cross compiler (g++-aarch64-linux-gnu) against arm64 multiarch packages
# (dpkg --add-architecture arm64; libfoo-dev:arm64). scripts/cross-aarch64 installs both and
# uses this file; it is the portability check for the headset build (docs/quest.md).
#
# Multiarch keeps arm64 libraries in /usr/lib/aarch64-linux-gnu beside the amd64 ones, and
# headers in /usr/include are shared, so there is no separate sysroot: the find root is /,
# CMAKE_LIBRARY_ARCHITECTURE selects the arm64 library folder, and no --sysroot is passed
# (Debian's cross gcc already searches the multiarch paths). Programs (glslangValidator,
# pkg-config) are the build machine's own.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)

set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)

set(CMAKE_FIND_ROOT_PATH /)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# pkg-config (pkg_check_modules) reads the arm64 .pc files and the architecture-independent
# ones only, never the build machine's /usr/lib/x86_64-linux-gnu/pkgconfig.
set(ENV{PKG_CONFIG_LIBDIR} /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig)
set(ENV{PKG_CONFIG_PATH} "")
