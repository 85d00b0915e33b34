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
# The emulator must be qemu 8 or later: Debian 12's qemu-user 7.2 hangs in any program that starts TBB worker
# threads. tools/install_deps.sh arm64 puts Debian 13's static qemu-aarch64 (10.0) in /opt/qemu-trixie/bin on a
# Debian 12 host; on Debian 13 the qemu-user package is that one. MLSDEFORM_QEMU=<path> chooses another.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)

# Programs (python3, clang-format, git) are the host's; libraries and packages come from the multiarch
# directories above, never from the host's x86-64 ones (CMAKE_LIBRARY_ARCHITECTURE keeps those out).
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)

if(NOT MLSDEFORM_QEMU AND DEFINED ENV{MLSDEFORM_QEMU})
  set(MLSDEFORM_QEMU "$ENV{MLSDEFORM_QEMU}" CACHE FILEPATH "qemu-aarch64 (user mode, 8 or later) that runs the tests")
endif()
find_program(MLSDEFORM_QEMU NAMES qemu-aarch64 qemu-aarch64-static HINTS /opt/qemu-trixie/bin NO_CMAKE_FIND_ROOT_PATH
             DOC "qemu-aarch64 (user mode, 8 or later) that runs the tests")
if(NOT MLSDEFORM_QEMU)
  message(FATAL_ERROR "aarch64-linux-gnu.cmake: no qemu-aarch64 found to run the tests; run tools/install_deps.sh arm64 "
                      "or give -DMLSDEFORM_QEMU=<qemu-aarch64 8 or later>")
endif()
execute_process(COMMAND "${MLSDEFORM_QEMU}" --version OUTPUT_VARIABLE _mls_qemu_version ERROR_QUIET)
string(REGEX MATCH "version ([0-9]+)\\.([0-9]+)" _mls_qemu_version "${_mls_qemu_version}")
if(NOT CMAKE_MATCH_1 OR CMAKE_MATCH_1 LESS 8)
  message(FATAL_ERROR "aarch64-linux-gnu.cmake: ${MLSDEFORM_QEMU} is qemu '${CMAKE_MATCH_1}.${CMAKE_MATCH_2}'; "
                      "qemu 7 hangs in multi-threaded TBB programs: run tools/install_deps.sh arm64 (Debian 13's qemu "
                      "10 in /opt/qemu-trixie/bin) or give -DMLSDEFORM_QEMU=<qemu-aarch64 8 or later>")
endif()
# -L: the aarch64 dynamic loader and C library of Debian's cross toolchain (libc6-arm64-cross); what is not there
# (libtbb, zlib) qemu finds at its own path, in /usr/lib/aarch64-linux-gnu.
# taskset -c 0: the emulated program sees one CPU, so oneTBB starts no worker threads. With two, test_deformer's
# cases ran for minutes each (natively milliseconds), qemu spinning in glibc's pthread_create (its walk of the
# cached thread stacks, whose entries all looked in use); on one CPU they take about a second. The library's
# multi-threaded paths are tested natively; here the kernels are.
find_program(MLSDEFORM_TASKSET taskset NO_CMAKE_FIND_ROOT_PATH)
if(MLSDEFORM_TASKSET)
  set(CMAKE_CROSSCOMPILING_EMULATOR "${MLSDEFORM_TASKSET};-c;0;${MLSDEFORM_QEMU};-L;/usr/aarch64-linux-gnu")
else()
  set(CMAKE_CROSSCOMPILING_EMULATOR "${MLSDEFORM_QEMU};-L;/usr/aarch64-linux-gnu")
endif()
