// Vertices on and beside handles: their frames (and, beside a dominant segment, their positions) computed
// apart from the kernels, in double, for every weight storage and ISA alike (one scalar stage that every kernel
// table's frame passes through, after its blocks). Three kinds of vertex need it:
//
// On a handle (snapped, snap.hpp). The map interpolates there (its position is the handle's target, as the
// kernels already write it), but the weights relative to the nearest handle are 0 / 0, so the fit has to be taken
// as its limit. As v -> p_ref (a point handle p_n, or a segment's point p(t)), every other handle's weight
// relative to the second-nearest distance d_2 tends to w_j = (d_2 / |p_j - p_ref|)^u (a segment: its moments at
// p_ref, weights.hpp), p* -> p_ref, q* -> q_ref (q_n, or (1 - t) c + t d), and
//   H -> H' + m f e^T,   H' = sum_{j not own} (q_j - q_ref) A_j^T,  A_j = w_j (p_j - p_ref) (segments: their
//                                                                     moment form, as precompute_table.cpp's)
//   G -> G' + m e e^T,   G' = sum_{j not own} A_j (p_j - p_ref)^T     (affine: L = H G^-1; similarity: D = tr G)
// where the last term is the segment's own direction, e = b - a at rest, f = d - c moved, with the weight of its
// second moment about t: m = int w(s) (s - t)^2 ds. Relative to d_2 and with w(s) = (d_2 / (|s - t| |e|))^u,
//   exact_integral, u < 3:  m = (d_2 / |e|)^u (t^(3-u) + (1 - t)^(3-u)) / (3 - u)   (finite: the fit's limit)
//   exact_integral, u >= 3, and paper_constant (constant weight, infinite at distance 0): m = infinity.
// With m infinite the segment's own term dominates, and the limit of the fit is lexicographic:
//   rigid, similarity: R with R e^ = f^ (the minimal rotation R0, then the twist about f^ that maximises
//     tr(R^T H'): theta = atan2(s, c), c = tr N - f^T N f, s = f . vee(N - N^T), N = H' R0^T); mu = |f| / |e|;
//   affine: L e = f, and on e's orthogonal complement Z the others' least squares:
//     L = (f / |e|)(e^T - e^T G' P) + H' P,   P = Z (Z^T G' Z)^+ Z^T   (the limit of (H' + m f e^T)(G' + m e e^T)^-1).
// A rigid, similarity or affine motion of every handle gives that motion's R, mu or L from either form: H' and
// G' are then R (or A) times the same symmetric G', f = R e (or A e).
// Where m is finite the fit is taken of H' + m f e^T; it is also taken as dominated where the others' spread
// across the segment is below 2^-26 = sqrt(eps_double) of the segment's own term (kDominatedRatio: the rounding
// of the sum would then decide the twist). No limit is defined where d_2 is 0 or infinite (another handle at the same
// point: the weights are infinite there too; or a single handle, whose map is one transform everywhere): such a vertex
// keeps the kernels' frame (the identity, or a single segment's own fit).
//
// Beside a dominant segment (table storage: segments need it). A vertex at distance delta from a segment
// handle, not snapped, has H = H' + m f e^T with the segment's term m f e^T (m = J2 / S, its second moment)
// larger than the others' by about delta^-u (paper_constant): formed in T, the others' share, which alone decides
// the rotation about the segment, drowns in the rounding of the segment's term, and the fit turns the vertex
// about the segment at random (eps(T) / rho radians, rho = tr(Z^T G' Z) / (m |e|^2)). Where rho < kBandRatio<T>
// (float 2^-10, double 2^-26) the vertex is a record too: its H' and m f e^T are formed apart, in double, centred
// on the segment's closest point so that nothing of the segment's size is subtracted from H' (precompute_table.cpp,
// band_sums, derives the split: m is then the variance of t along the segment under the weights), and
// fitted in double (rho >= 2^-26: error <= eps_double / rho <= 2^-26), or by the dominated limit above (rho <
// 2^-26: error <= rho); its position q* + mu R vhat is computed in double beside it. So the frames' error near a
// segment is at most about 2^10 eps(float) = 1.2e-4 (float) and 2^-26 = 1.5e-8 (double) radians, instead of
// unbounded; and positions follow. Outside the band the kernels' own fit is within its bound (eps / rho).
// Affine sessions likewise (L = H G^-1 there, whose solve for G, of condition 1 / rho, dropped the others' share
// below 64 eps_double: L off by O(1) at 1e-7 of the spacing in double), and their positions q* + L vhat.
//
// Far from every handle (the on-the-fly storages): a vertex more than kFarRatio handle spreads away, a scan's
// outlier, forms its fit in T from p_j - v, whose rounding eps(T) |v| is far larger than the handles' spread seen
// from there, and its position carries that error times |vhat|: its fit is taken in double too (far_fit).
#pragma once

#include "core/src/deformer/local_frame.hpp"
#include "core/src/threading.hpp"
#include "kernels/contract.hpp"

#include <mlsdeform/deformer.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <limits>
#include <mutex>
#include <vector>

namespace mlsdeform::detail {

/// The band beside a segment handle where a vertex's fit is taken apart (see above): rho below this.
template <class T>
inline constexpr double kBandRatio = sizeof(T) == 4 ? 0x1p-10 : 0x1p-26;
/// Below this rho the segment's term is taken as dominating (the lexicographic limit).
inline constexpr double kDominatedRatio = 0x1p-26;

/// One vertex taken apart. Its 5 J coefficients (kernel layout: after any folding, fold.hpp) are c_j, the weights
/// of q_ref = sum_j c_j q_j, the centroid weights of q* = sum_j c*_j q_j (position records), and A'_j (x, y, z),
/// with H' = sum_j (q_j - q_ref) A'_j^T.
struct NearRecord {
  std::size_t vertex = 0;   ///< the session's row (a region's compact row)
  std::size_t offset = 0;   ///< of its coefficients in NearHandles::coefficients
  std::ptrdiff_t own = -1;  ///< the own segment's first pseudo-handle (kernel layout), or -1
  bool position = false;    ///< beside a segment: the position too (on a handle the kernels' is kept)
  bool dominated = false;   ///< the own segment's term dominates: the lexicographic limit
  double m = 0;             ///< the own segment's weight, where not dominated
  Eigen::Vector3d e = Eigen::Vector3d::Zero();     ///< the own segment's rest direction b - a, local
  Eigen::Matrix3d G = Eigen::Matrix3d::Zero();     ///< G' (symmetric)
  Eigen::Vector3d vhat = Eigen::Vector3d::Zero();  ///< v - p*, local (position records)
};

/// The session's records, ascending by vertex.
struct NearHandles {
  std::size_t J = 0;  ///< pseudo-handles (kernel layout)
  std::vector<NearRecord> records;
  std::vector<double> coefficients;
  std::vector<std::size_t> positions;  ///< the records with `position`
  std::size_t bytes() const {
    return records.capacity() * sizeof(NearRecord) + coefficients.capacity() * sizeof(double) +
           positions.capacity() * sizeof(std::size_t);
  }
};

/// A record's coefficients over the rest handles' pseudo-handles (RestHandles layout, before any folding).
struct NearColumns {
  std::vector<double> c, star;
  std::vector<Eigen::Vector3d> A;
};

/// The limit of the fit on handle `nearest` (a point index < rh.k, or rh.k + a segment's index, at parameter t),
/// the others weighted relative to d_ref (the vertex's second-nearest distance); false where it has none
/// (d_ref 0 or infinite, or another handle at distance 0 from the point).
bool handle_limit(const RestHandles& rh, const Options& o, std::size_t nearest, double t, double d_ref, NearRecord& r,
                  NearColumns& cols);

/// Far from the handles (the on-the-fly storages, which keep the rest pose in T and form p_j - v there: the
/// handles' configuration then loses eps(T) |p_j - v| / (its size), and the position that error times |vhat|): the
/// vertex's fit in double, from its unrounded local position v. False where it needs none (fewer than two handles).
/// Taken for vertices farther than kFarRatio handle spreads from every handle.
bool far_fit(const RestHandles& rh, const Options& o, const Eigen::Vector3d& v, NearRecord& r, NearColumns& cols);
inline constexpr double kFarRatio = 64;

/// Collects records from the set-up's threads, then sorts and packs them.
class NearHandlesBuilder {
 public:
  void add(NearRecord r, const NearColumns& cols);
  NearHandles finish(std::size_t J);

 private:
  std::mutex mutex_;
  std::vector<std::pair<NearRecord, NearColumns>> pending_;

 public:
  /// Values per pseudo-handle in NearHandles::coefficients: c, c*, A'.
  static constexpr std::size_t kWidth = 5;
};

/// The frame's records after the kernels' blocks: the frames of every record into fr's wanted outputs, and the
/// positions of the position records into fr.out (times fr.world_scale). Returns the smallest vertex whose
/// position or frame is not finite in T, or kernels' kAllFinite convention (SIZE_MAX) if none.
template <class T>
std::size_t apply_near_handles(const NearHandles& nh, const kernels::DeformFrame<T>& fr, RotationMethod method,
                               int threads, tbb::task_arena* arena);

}  // namespace mlsdeform::detail
