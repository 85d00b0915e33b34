# Cross build for ARM64 (aarch64) Linux on an x86-64 Debian host, with Debian's cross g++ and the arm64
# libraries installed by multiarch; ctest runs the tests under qemu's user-mode emulation.
#
#   tools/install_deps.sh arm64                      # g++-aarch64-linux-gnu, libtbb-dev:arm64, ..., qemu 10
#   cmake -S . -B build-arm64 --toolchain cmake/aarch64-linux-gnu.cmake -DCMAKE_BUILD_TYPE=Release
#   cmake --build build-arm64 -j 2 && ctest --test-dir build-arm64 -L arm64
#
# The kernels get the NEON table (kernels/CMakeLists.txt chooses the ISAs by CMAKE_SYSTEM_PROCESSOR). The arm64
# -dev packages (libtbb-dev:arm64, libxsimd-dev:arm64, zlib1g-dev:arm64) put their libraries and CMake packages
# under /usr/lib/aarch64-linux-gnu, which CMAKE_LIBRARY_ARCHITECTURE makes find_package and find_library search;
# the architecture-independent ones (Eigen, CLI11, nlohmann-json, Catch2's header) are the host's.
#
# tools/install_deps.sh arm64 puts Debian 13's static qemu-aarch64 (10.0) in /opt/qemu-trixie/bin on a Debian 12
# host (tools/insn_per_fit.sh counts instructions with it); on Debian 13 the qemu-user package is that one.
# Debian 12's own qemu-user 7.2 runs the tests too. MLSDEFORM_QEMU=<path> chooses another.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)

# Programs (python3, clang-format, git) are the host's; libraries and packages come from the multiarch
# directories above, never from the host's x86-64 ones (CMAKE_LIBRARY_ARCHITECTURE keeps those out).
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)

if(NOT MLSDEFORM_QEMU AND DEFINED ENV{MLSDEFORM_QEMU})
  set(MLSDEFORM_QEMU "$ENV{MLSDEFORM_QEMU}" CACHE FILEPATH "qemu-aarch64 (user mode) that runs the tests")
endif()
find_program(MLSDEFORM_QEMU NAMES qemu-aarch64 qemu-aarch64-static HINTS /opt/qemu-trixie/bin NO_CMAKE_FIND_ROOT_PATH
             DOC "qemu-aarch64 (user mode) that runs the tests")
if(NOT MLSDEFORM_QEMU)
  message(FATAL_ERROR "aarch64-linux-gnu.cmake: no qemu-aarch64 found to run the tests; run tools/install_deps.sh arm64 "
                      "or give -DMLSDEFORM_QEMU=<qemu-aarch64>")
endif()
# The emulated programs run on the arm64 C library of multiarch (libc6:arm64, which libtbb-dev:arm64 brings):
# its loader /lib/ld-linux-aarch64.so.1 and its libc.so.6 in /lib/aarch64-linux-gnu, one build of glibc, beside
# the other arm64 libraries (libtbb, zlib, libstdc++). `-L /` says so, whatever prefix the emulator was built
# with (Debian's qemu looks in /etc/qemu-binfmt/aarch64 first, often a link to /usr/aarch64-linux-gnu).
# Never `-L /usr/aarch64-linux-gnu`: that prefix gives the loader of the cross toolchain's glibc
# (libc6-arm64-cross), which then finds libc.so.6 through /etc/ld.so.cache in /lib/aarch64-linux-gnu, the
# multiarch package's: a loader and a C library from two builds of glibc (2.36-8 and 2.36-9+deb12u14 on Debian
# 12), which share private structures (the cache of thread stacks among them). In such a process the first
# pthread_create never returns: every program that starts a thread (oneTBB's workers, Options::threads) hangs,
# under any qemu version and on any number of CPUs.
set(_mls_loader /lib/ld-linux-aarch64.so.1)
if(NOT EXISTS ${_mls_loader})
  message(FATAL_ERROR "aarch64-linux-gnu.cmake: no ${_mls_loader} to run the tests with: install libc6:arm64 "
                      "(tools/install_deps.sh arm64)")
endif()
execute_process(COMMAND "${MLSDEFORM_QEMU}" --version OUTPUT_VARIABLE _mls_qemu_version ERROR_QUIET)
string(REGEX MATCH "version [0-9.]+" _mls_qemu_version "${_mls_qemu_version}")
message(STATUS "aarch64 tests run under ${MLSDEFORM_QEMU} (${_mls_qemu_version}) -L /")
set(CMAKE_CROSSCOMPILING_EMULATOR "${MLSDEFORM_QEMU};-L;/")
