#include "core/src/deformer/local_frame.hpp"

#include "core/src/deformer/validation.hpp"
#include "core/src/pow2.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>

namespace mlsdeform::detail {

using Vec3d = Eigen::Vector3d;

template <class T>
LocalFrame make_local_frame(const Points<T>& vertices, const Handles<T>& handles) {
  // The box of the handles (the origin: local_frame.hpp) and of the whole scene (the size).
  Vec3d lo = Vec3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo, lo_h = lo, hi_h = hi;
  auto add = [](const Points<T>& p, Vec3d& l, Vec3d& h) {
    for (Eigen::Index i = 0; i < p.rows(); ++i) {
      const Vec3d x = p.row(i).transpose().template cast<double>();
      l = l.cwiseMin(x);
      h = h.cwiseMax(x);
    }
  };
  add(handles.points, lo_h, hi_h);
  add(handles.segment_a, lo_h, hi_h);
  add(handles.segment_b, lo_h, hi_h);
  lo = lo_h, hi = hi_h;
  add(vertices, lo, hi);
  LocalFrame s;
  s.e0 = exponent_of(std::max(hi.cwiseAbs().maxCoeff(), lo.cwiseAbs().maxCoeff()));
  for (int c = 0; c < 3; ++c) {
    hi[c] = std::ldexp(hi[c], -s.e0), lo[c] = std::ldexp(lo[c], -s.e0);
    hi_h[c] = std::ldexp(hi_h[c], -s.e0), lo_h[c] = std::ldexp(lo_h[c], -s.e0);
  }
  const Vec3d half = 0.5 * hi - 0.5 * lo;  // halves first: no overflow
  s.centre0 = 0.5 * hi_h + 0.5 * lo_h;
  for (int c = 0; c < 3; ++c) s.centre[c] = std::ldexp(s.centre0[c], s.e0);
  const double m = half.maxCoeff();
  const double diag0 = m > 0 ? 2 * m * (half / m).norm() : 0.0, diag = std::ldexp(diag0, s.e0);
  if (!(diag <= double(coordinate_limit<T>())))
    throw std::invalid_argument(
        "Deformer: the scene (bounding box of rest vertices and handles) is too large for the "
        "precision: diagonal " +
        num(diag));
  if (diag > 0 && !(diag >= double(std::numeric_limits<T>::min())))
    throw std::invalid_argument(
        "Deformer: the scene (bounding box of rest vertices and handles) is too small for the precision: "
        "diagonal " +
        num(diag) + ", below the smallest normal " + (sizeof(T) == 4 ? "float" : "double") + " " +
        num(double(std::numeric_limits<T>::min())));
  s.e = diag > 0 ? s.e0 + std::ilogb(diag0) : 0;
  s.size_local = std::ldexp(diag0, s.e0 - s.e);
  return s;
}

template <class T>
RestHandles make_rest_handles(const Handles<T>& h, const LocalFrame& scene) {
  RestHandles r;
  r.k = static_cast<std::size_t>(h.points.rows());
  r.s = static_cast<std::size_t>(h.segment_a.rows());
  r.P.reserve(r.k + 2 * r.s);
  for (Eigen::Index i = 0; i < h.points.rows(); ++i)
    r.P.push_back(scene.local(h.points.row(i).transpose().template cast<double>()));
  for (Eigen::Index i = 0; i < h.segment_a.rows(); ++i) {
    r.P.push_back(scene.local(h.segment_a.row(i).transpose().template cast<double>()));
    r.P.push_back(scene.local(h.segment_b.row(i).transpose().template cast<double>()));
  }
  return r;
}

template LocalFrame make_local_frame<float>(const Points<float>&, const Handles<float>&);
template LocalFrame make_local_frame<double>(const Points<double>&, const Handles<double>&);
template RestHandles make_rest_handles<float>(const Handles<float>&, const LocalFrame&);
template RestHandles make_rest_handles<double>(const Handles<double>&, const LocalFrame&);

}  // namespace mlsdeform::detail
