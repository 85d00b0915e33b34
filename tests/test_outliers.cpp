// A stray vertex far from the model (a scanned cloud's outlier) changes no other vertex: the session's local frame
// is centred on the handles (core/src/deformer/local_frame.hpp) and scaled by a power of two, and every weight is
// relative, so the model's vertices run on the same bits with the stray as without it (their coordinates in the
// local frame differ by a power of two, exactly, in T's normal range), in every storage, transform and precision,
// positions and frames alike. Before, the frame was centred on the whole scene's box: the stray moved the origin
// thousands of diagonals away, and the on-the-fly storages, which keep the rest coordinates in T, rounded the
// model to T's spacing there (1e-4 of the diagonal at 3,000 diagonals in float).
#include "tests/support/catch.hpp"
#include "tests/support/deform_cases.hpp"
#include "tests/support/isa_guard.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <cstring>
#include <random>
#include <vector>

using namespace mlsdeform;
using mlsdeform::testing::IsaGuard;

TEMPLATE_TEST_CASE("outliers: a stray vertex far away leaves every other vertex's bits", "[deformer][outliers]", float,
                   double) {
  using T = TestType;
  const IsaGuard guard;
  std::mt19937_64 g(71);
  const testing::DeformCase<T> points = testing::random_case<T>(g, 261, 7);
  const testing::DeformCase<T> segments = testing::random_case<T>(g, 261, 4, 2);
  const double diagonal = 2 * std::sqrt(3.0);  // random_case draws from [-1, 1]^3
  const Eigen::Matrix3d M = Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.2, 0.5, -0.84).normalized()).toRotationMatrix();
  for (Isa isa : supported_isas())
    for (const testing::DeformCase<T>* c : {&points, &segments})
      for (WeightStorage ws :
           {WeightStorage::precomputed, WeightStorage::on_the_fly, WeightStorage::precomputed_weights})
        for (Transform tr : {Transform::rigid, Transform::similarity, Transform::affine})
          for (double far : {1e3, 3e3, 1e5, 2e5, 1e6}) {
            const bool table_only = c->rest.segment_count() > 0 || tr == Transform::affine;
            if (table_only && ws != WeightStorage::precomputed) continue;
            INFO("isa " << to_string(isa) << " segments " << c->rest.segment_count() << " storage " << int(ws)
                        << " transform " << int(tr) << " stray at " << far << " diagonals");
            Options o;
            o.isa = isa;
            o.weight_storage = ws;
            o.transform = tr;
            o.affine_frames = tr == Transform::affine;
            const Eigen::Index n = c->vertices.rows();
            Points<T> with(n + 1, 3);
            with.topRows(n) = c->vertices;
            with.row(n) = (Eigen::Vector3d(0.6, -0.48, 0.64) * far * diagonal).transpose().template cast<T>();
            // A similarity motion (rigid for a rigid session): every vertex, the stray too, must get it.
            const double scale = tr == Transform::rigid ? 1.0 : 1.4;
            const Eigen::Vector3d t(0.5, -0.1, 0.3);
            const Handles<T> moved = testing::transformed(c->rest, scale * M, t);
            const Deformer<T> plain_d(c->vertices, c->rest, o), stray_d(with, c->rest, o);
            Points<T> plain, stray;
            std::vector<T> plain_l(9 * std::size_t(n)), stray_l(9 * std::size_t(n + 1));
            plain_d.deform(moved, plain, FramesOut<T>{{}, {}, {}, plain_l});
            stray_d.deform(moved, stray, FramesOut<T>{{}, {}, {}, stray_l});
            Eigen::Index differ = 0;
            for (Eigen::Index i = 0; i < n; ++i)
              if (!(stray.row(i) == plain.row(i))) ++differ;
            CHECK(differ == 0);
            CHECK(std::memcmp(plain_l.data(), stray_l.data(), plain_l.size() * sizeof(T)) == 0);
            // The stray itself: its fit sees the handles almost uniformly weighted, with the conditioning kappa =
            // |C|_F / (lambda_1 + lambda_2) of C = sum_j (p_j - p*)(p_j - p*)^T (the handles' own spread; segments:
            // their end points, the same order), so its frame is within 2 (J + 16) kappa eps(T) + the rounding of
            // the result (3 eps(T)), and its position, |x| ~ far diagonals from every handle, within that times |x|
            // plus the handles' and targets' rounding, (J + 16) eps(T) times the targets' size.
            const Eigen::Vector3d x = with.row(n).template cast<double>().transpose();
            Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
            Eigen::Vector3d mean = Eigen::Vector3d::Zero();
            std::vector<Eigen::Vector3d> ps;
            for (const Points<T>* p : {&c->rest.points, &c->rest.segment_a, &c->rest.segment_b})
              for (Eigen::Index j = 0; j < p->rows(); ++j) ps.push_back(p->row(j).template cast<double>().transpose());
            for (const auto& p : ps) mean += p / double(ps.size());
            for (const auto& p : ps) C += (p - mean) * (p - mean).transpose();
            const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C);
            const double kappa = C.norm() / (es.eigenvalues()(0) + es.eigenvalues()(1));
            const double eps = std::numeric_limits<T>::epsilon(), J = double(ps.size());
            const double tol = (2 * (J + 16) * kappa + 3) * eps * scale * x.norm() + (J + 16) * eps * 4 * scale;
            const Eigen::Vector3d want = scale * M * x + t;
            INFO("stray: |dp| " << (stray.row(n).template cast<double>().transpose() - want).norm() << " bound "
                                << tol);
            CHECK((stray.row(n).template cast<double>().transpose() - want).norm() <= tol);
          }
}
