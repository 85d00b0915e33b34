// bench_rotation_fit's error sweep (--error_sweep=FILE, the report's plot): the error of every fit against
// the distance of the rotation from a half-turn.
#pragma once

#include "bench/cases.hpp"
#include "bench/paper_literal.hpp"
#include "bench/qcp.hpp"
#include "bench/reference.hpp"
#include "bench/rotation_fit_sets.hpp"

#include <mlsdeform/rotation.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

namespace bench::rotation_fit {

/// One precision's rows: for delta = pi - angle from 1e-8 to 1 rad, cases of near_half_turn_correlation; per
/// method, the median and largest angle to the long-double SVD reference of the rounded H.
template <class T>
void sweep_type(std::ofstream& csv) {
  struct Method {
    std::string name;
    std::function<Matrix3<T>(const Matrix3<T>&)> fit;
  };
  std::vector<Method> methods;
  for (RotationMethod m : mlsdeform::all_rotation_methods)
    methods.push_back(
        {std::string(mlsdeform::to_string(m)), [m](const Matrix3<T>& H) { return mlsdeform::fit_rotation<T>(H, m); }});
  methods.push_back({"qcp", [](const Matrix3<T>& H) { return bench::fit_rotation_qcp<T>(H); }});
  methods.push_back(
      {"paper_eq14_literal", [](const Matrix3<T>& H) { return bench::fit_rotation_paper_literal<T>(H); }});
  constexpr int kPerDecade = 4, kCasesPerDelta = 400;
  for (int e = -8 * kPerDecade; e <= 0; ++e) {
    const double delta = std::pow(10.0, double(e) / kPerDecade);
    std::vector<Matrix3<T>> H(kCasesPerDelta);
    std::vector<Matrix3L> R_ref(kCasesPerDelta);
    bench::Rng rng = bench::case_rng(bench::kCaseSeed + 1, static_cast<std::uint64_t>(e + 1000));
    for (int i = 0; i < kCasesPerDelta; ++i) {
      H[i] = bench::near_half_turn_correlation(rng, delta).template cast<T>();
      R_ref[i] = bench::reference(H[i]).rotation.template cast<long double>();
    }
    for (const Method& m : methods) {
      std::vector<double> err(kCasesPerDelta);
      for (int i = 0; i < kCasesPerDelta; ++i) {
        const Matrix3<T> R = m.fit(H[i]);
        err[i] = R.allFinite() ? static_cast<double>(bench::rotation_angle(R.template cast<long double>(), R_ref[i]))
                               : std::numbers::pi;
      }
      std::sort(err.begin(), err.end());
      csv << type_name<T>() << ',' << m.name << ',' << delta << ',' << kCasesPerDelta << ',' << err[kCasesPerDelta / 2]
          << ',' << err.back() << '\n';
    }
  }
}

/// The sweep in float and double, as CSV.
inline void write_error_sweep(const std::string& path) {
  std::ofstream csv(path);
  csv.precision(6);
  csv << "type,method,delta,cases,median_angle_error,max_angle_error\n";
  sweep_type<float>(csv);
  sweep_type<double>(csv);
}

}  // namespace bench::rotation_fit
