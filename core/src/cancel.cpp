#include <mlsdeform/cancel.hpp>

namespace mlsdeform {

// Out of line: the vtable and type information live here, in one object, not in every caller's.
Cancelled::Cancelled() : std::runtime_error("mlsdeform: the call was cancelled by its CancelCheck") {}
Cancelled::~Cancelled() = default;

}  // namespace mlsdeform
