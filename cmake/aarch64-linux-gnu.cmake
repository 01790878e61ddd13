# Cross-compiles splitvk for 64-bit ARM Linux (aarch64) on a Debian x86-64 build machine, against the
# arm64 libraries Debian's multiarch installs next to the native ones (/usr/lib/aarch64-linux-gnu):
#
#   dpkg --add-architecture arm64 && apt-get update
#   apt-get install crossbuild-essential-arm64 qemu-user-static libvulkan-dev:arm64 ...
#   cmake -S . -B build-aarch64 --toolchain cmake/aarch64-linux-gnu.cmake -DSPIRV-Tools_DIR=...
#
# scripts/cross-aarch64 does all of it, SPIRV-Tools included (Debian's spirv-tools package cannot be
# installed for two architectures at once, so the agent's static SPIRV-Tools comes from the arm64
# package unpacked into a folder of its own).
#
# The code generators, glslang and spirv-val are build-machine programs: what they write (the codec,
# the dispatch tables, SPIR-V, manifests) does not depend on the target and must come out byte for
# byte as in a native build. Programs are therefore looked up on the build machine; libraries,
# headers and CMake packages under the target's multiarch folders. Target executables run under
# qemu's user-mode emulation, called directly rather than through binfmt_misc, which CI containers
# often cannot register: gtest_discover_tests and ctest both go through CMAKE_CROSSCOMPILING_EMULATOR.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)

set(SPLITVK_CROSS_TRIPLET aarch64-linux-gnu)
set(CMAKE_C_COMPILER ${SPLITVK_CROSS_TRIPLET}-gcc)
set(CMAKE_CXX_COMPILER ${SPLITVK_CROSS_TRIPLET}-g++)
set(CMAKE_LIBRARY_ARCHITECTURE ${SPLITVK_CROSS_TRIPLET})

# No sysroot: Debian's multiarch layout keeps both architectures under /usr, told apart by the
# library architecture above, which every find_* and find_package already searches by.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)

# pkg-config reads the target's .pc files only (Debian 12 ships no <triplet>-pkg-config wrapper
# without pkgconf's cross personality); the architecture-independent ones stay visible.
set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/${SPLITVK_CROSS_TRIPLET}/pkgconfig:/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_PATH} "")

# The arm64 C library of Debian's multiarch (libc6:arm64, which every :arm64 library above depends
# on) puts its dynamic loader at /lib/ld-linux-aarch64.so.1, where the executables name it, so qemu
# needs no -L prefix. The cross toolchain's own copy (-L /usr/aarch64-linux-gnu) is not used: under
# Debian 12's qemu 7.2 a process forked from it hangs before its first system call.
find_program(SPLITVK_QEMU_AARCH64 qemu-aarch64-static REQUIRED)
set(CMAKE_CROSSCOMPILING_EMULATOR ${SPLITVK_QEMU_AARCH64})
