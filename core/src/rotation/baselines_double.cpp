#include "core/src/rotation/baselines.hpp"

namespace mlsdeform::detail {

MLSDEFORM_BASELINES(, double)

}  // namespace mlsdeform::detail
