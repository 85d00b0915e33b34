// Catch2 v2's main for the WebAssembly tests (web/cmake/tests.cmake): Debian's prebuilt Catch2WithMain is x86.
#define CATCH_CONFIG_MAIN
#include <catch2/catch.hpp>
