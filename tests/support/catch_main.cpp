// Catch2 2's main, compiled from its single header for a cross build, where the catch2 package's prebuilt
// libCatch2WithMain.a is the host's (tests/CMakeLists.txt).
#define CATCH_CONFIG_MAIN
#include <catch2/catch.hpp>
