# The library's own dependencies, found the same way by the build and by the installed package config
# (mlsdeformConfig.cmake includes this file too: consumers of the static library link its private
# dependencies, so they must find them as well).
include(CMakeFindDependencyMacro)
if(NOT COMMAND _mlsdeform_find)
  macro(_mlsdeform_find)
    if(DEFINED CMAKE_FIND_PACKAGE_NAME)   # inside a package config: find_dependency forwards QUIET/REQUIRED
      find_dependency(${ARGV})
    else()
      find_package(${ARGV} REQUIRED)
    endif()
  endmacro()
endif()
_mlsdeform_find(Eigen3 3.4 CONFIG)
_mlsdeform_find(TBB 2021 CONFIG)
# xsimd 8 (Debian 12) to 13 (Debian 13): its package accepts only a request of its own major version, so none
# is asked and the range is checked here (kernels/simd.hpp switches on XSIMD_VERSION_MAJOR where the API moved).
_mlsdeform_find(xsimd CONFIG)
if(xsimd_VERSION VERSION_LESS 8 OR xsimd_VERSION VERSION_GREATER_EQUAL 14)
  message(FATAL_ERROR "xsimd ${xsimd_VERSION} found; mlsdeform builds with xsimd 8 to 13 (Debian: libxsimd-dev)")
endif()
# Debian's xsimd names a link interface 'xtl' that no package defines: without this empty target every link
# fails with 'cannot find -lxtl'.
if(NOT TARGET xtl)
  add_library(xtl INTERFACE IMPORTED)
endif()
# CHOLMOD (MLSDEFORM_CHOLMOD): Debian 12's SuiteSparse 5.12 has no CMake package; an imported target from
# its header and library (libcholmod.so pulls in its BLAS, LAPACK and METIS).
if(MLSDEFORM_CHOLMOD AND NOT TARGET mlsdeform::cholmod)
  find_path(MLSDEFORM_CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
  find_library(MLSDEFORM_CHOLMOD_LIBRARY cholmod)
  if(NOT MLSDEFORM_CHOLMOD_INCLUDE_DIR OR NOT MLSDEFORM_CHOLMOD_LIBRARY)
    message(FATAL_ERROR "MLSDEFORM_CHOLMOD is ON but CHOLMOD was not found (Debian: apt-get install libsuitesparse-dev)")
  endif()
  add_library(mlsdeform::cholmod UNKNOWN IMPORTED)
  set_target_properties(mlsdeform::cholmod PROPERTIES IMPORTED_LOCATION ${MLSDEFORM_CHOLMOD_LIBRARY}
    INTERFACE_INCLUDE_DIRECTORIES ${MLSDEFORM_CHOLMOD_INCLUDE_DIR})
endif()
