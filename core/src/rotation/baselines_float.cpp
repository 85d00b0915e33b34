#include "core/src/rotation/baselines.hpp"

namespace mlsdeform::detail {

MLSDEFORM_BASELINES(, float)

}  // namespace mlsdeform::detail
