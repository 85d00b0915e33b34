# The library's own dependencies, found the same way by the build and by the installed package config
# (mlsdeformConfig.cmake includes this file too). See ../shared/TOOLCHAIN.md for the pitfalls.
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
_mlsdeform_find(xsimd 8 CONFIG)
# Debian's xsimd names a link interface 'xtl' that no package defines (TOOLCHAIN.md pitfall 1).
if(NOT TARGET xtl)
  add_library(xtl INTERFACE IMPORTED)
endif()
