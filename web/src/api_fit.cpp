// The batched rotation fit of the C API (api.hpp): fit_rotations_interleaved in float, on n row-major 3 x 3
// matrices one after the other (the layout of a Float32Array of 9 n values), on the calling thread.
#include "web/src/api.hpp"

#include <mlsdeform/fit_rotations.hpp>

#include <emscripten/emscripten.h>

#include <cstddef>

extern "C" {

/// R[9 i ..] = the rotation fit to H[9 i ..] (Sec. 4's axis-angle fit, eqs. (13)-(15)) for i < n; R may be H.
/// 0, or 1 with mls_last_error() set (a non-finite entry, named as H[i, r, c]; R is then untouched).
EMSCRIPTEN_KEEPALIVE int mls_fit_rotations(const float* H, float* R, int n) {
  return mlsdeform::web::guarded(1, [&] {
    if (n < 0) throw std::invalid_argument("fitRotations: negative count");
    mlsdeform::fit_rotations_interleaved(H, R, std::size_t(n));
    return 0;
  });
}

}  // extern "C"
