// bench_rotation_fit's two matrix sets, built once with their long-double references, and the untimed check
// that every benchmark runs over a whole set before timing it (bench/reference.hpp judges each result).
#pragma once

#include "bench/cases.hpp"
#include "bench/reference.hpp"

#include <mlsdeform/rotation.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <mutex>
#include <string>
#include <type_traits>
#include <vector>

namespace bench::rotation_fit {

using mlsdeform::Matrix3;
using mlsdeform::RotationMethod;

/// Size of each set (--cases).
inline std::size_t case_count = 1'000'000;

/// The two matrix sets: correlation matrices of random weighted point sets (bench/cases.hpp make_case), and
/// Gaussian H (make_gaussian_case). Benchmark names start with the set: fit/, fit_hot/ (point sets) and
/// gauss/, gauss_hot/ (Gaussian).
enum class Set { points, gaussian };
inline constexpr Set kSets[] = {Set::points, Set::gaussian};

inline std::string prefix(Set set, bool hot) {
  return std::string(set == Set::points ? "fit" : "gauss") + (hot ? "_hot/" : "/");
}

/// The shared set and its references, built once (in parallel: the long-double SVDs take a few seconds).
struct Data {
  std::vector<Eigen::Matrix3d> H_double;
  std::vector<Eigen::Matrix3f> H_float;
  std::vector<bench::Reference> ref_double, ref_float;
  std::size_t det_negative = 0;

  template <class T>
  const std::vector<Matrix3<T>>& H() const {
    if constexpr (std::is_same_v<T, float>)
      return H_float;
    else
      return H_double;
  }
  template <class T>
  const std::vector<bench::Reference>& ref() const {
    if constexpr (std::is_same_v<T, float>)
      return ref_float;
    else
      return ref_double;
  }
};

inline Data build(Set set) {
  Data d;
  const std::size_t n = case_count;
  d.H_double.resize(n);
  d.H_float.resize(n);
  d.ref_double.resize(n);
  d.ref_float.resize(n);
  std::atomic<std::size_t> negative{0};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const tbb::blocked_range<std::size_t>& r) {
    std::size_t neg = 0;
    for (std::size_t i = r.begin(); i < r.end(); ++i) {
      d.H_double[i] =
          set == Set::points ? bench::make_case(bench::kCaseSeed, i) : bench::make_gaussian_case(bench::kCaseSeed, i);
      d.H_float[i] = d.H_double[i].cast<float>();
      d.ref_double[i] = bench::reference(d.H_double[i]);
      d.ref_float[i] = bench::reference(d.H_float[i]);
      if (d.H_double[i].determinant() < 0) ++neg;
    }
    negative += neg;
  });
  d.det_negative = negative;
  return d;
}

inline const Data& data(Set set) {
  if (set == Set::points) {
    static const Data points = build(Set::points);
    return points;
  }
  static const Data gaussian = build(Set::gaussian);
  return gaussian;
}

/// Judges results 0 .. n-1 in parallel (untimed): `verdict(i)` computes what result i needs and judges it.
/// Returns an empty string when all pass, else a message naming how many `fits` failed and the first failing
/// case; `worst` gets the largest error/tolerance ratio.
template <class VerdictOf>
std::string check_all(std::size_t n, const VerdictOf& verdict, const char* fits, double& worst) {
  std::mutex m;
  std::size_t first_bad = n, bad = 0;
  Verdict first_verdict;
  worst = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 4096), 0.0,
      [&](const tbb::blocked_range<std::size_t>& r, double w) {
        for (std::size_t i = r.begin(); i < r.end(); ++i) {
          const Verdict v = verdict(i);
          w = std::max(w, static_cast<double>(v.worst_ratio()));
          if (!v.ok) {
            std::lock_guard lock(m);
            ++bad;
            if (i < first_bad) first_bad = i, first_verdict = v;
          }
        }
        return w;
      },
      [](double a, double b) { return std::max(a, b); });
  if (bad == 0) return {};
  return std::to_string(bad) + " of " + std::to_string(n) + " " + fits +
         " off the long-double SVD reference; first: case " + std::to_string(first_bad) + " (seed " +
         std::to_string(kCaseSeed) + "): " + first_verdict.describe();
}

template <class T>
const char* type_name() {
  return std::is_same_v<T, float> ? "float" : "double";
}

}  // namespace bench::rotation_fit
