// Test helper: restores the instruction set in force when it was made, also when a check throws (a failing
// REQUIRE must not leave an ISA forced for the tests that follow).
#pragma once

#include <mlsdeform/dispatch.hpp>

namespace mlsdeform::testing {

class IsaGuard {
 public:
  IsaGuard() : saved_(active_isa()) {}
  ~IsaGuard() { set_isa(saved_); }
  IsaGuard(const IsaGuard&) = delete;
  IsaGuard& operator=(const IsaGuard&) = delete;

 private:
  Isa saved_;
};

}  // namespace mlsdeform::testing
