# The WebAssembly build's dependencies (emcmake: tools/dev.sh web). Eigen, xsimd, nlohmann/json and Catch2 are
# header-only; their Debian headers are used as they are, each through a folder of its own in the build tree
# (a link to the Debian one), never /usr/include itself: that holds the host's libc headers, which must not
# shadow emscripten's. No TBB: MLSDEFORM_SERIAL gives the serial stand-ins (core/src/threading.hpp).
set(_mls_sysdeps ${CMAKE_BINARY_DIR}/sysdeps)
# Catch2 only as version 2's single header (Debian 12): Debian 13's Catch2 3 is a compiled library, built for
# the host only, so there the WebAssembly C++ tests are left out (web/cmake/tests.cmake says so).
set(_mls_deps eigen3/Eigen:Eigen eigen3/unsupported:unsupported xsimd:xsimd nlohmann:nlohmann)
if(EXISTS /usr/include/catch2/catch.hpp)
  list(APPEND _mls_deps catch2:catch2)
endif()
foreach(dep ${_mls_deps})
  string(REPLACE ":" ";" _pair ${dep})
  list(GET _pair 0 _from)
  list(GET _pair 1 _to)
  if(NOT EXISTS /usr/include/${_from})
    message(FATAL_ERROR "web build: /usr/include/${_from} is missing (tools/install_deps.sh web installs it)")
  endif()
  file(MAKE_DIRECTORY ${_mls_sysdeps})
  file(CREATE_LINK /usr/include/${_from} ${_mls_sysdeps}/${_to} SYMBOLIC)
endforeach()
if(NOT TARGET Eigen3::Eigen)
  add_library(Eigen3::Eigen INTERFACE IMPORTED)
  set_target_properties(Eigen3::Eigen PROPERTIES INTERFACE_INCLUDE_DIRECTORIES ${_mls_sysdeps})
  add_library(xsimd INTERFACE IMPORTED)
  set_target_properties(xsimd PROPERTIES INTERFACE_INCLUDE_DIRECTORIES ${_mls_sysdeps})
endif()
