// Catch2's main, compiled from its headers for a cross build, where the catch2 package's prebuilt
// libCatch2WithMain.a is the host's (tests/CMakeLists.txt): Catch2 2 writes it where CATCH_CONFIG_MAIN is
// defined; Catch2 3 has no such switch (tests/support/catch.hpp then declares Catch::Session).
#define CATCH_CONFIG_MAIN
#include "tests/support/catch.hpp"

#if __has_include(<catch2/catch_session.hpp>)
int main(int argc, char* argv[]) { return Catch::Session().run(argc, argv); }
#endif
