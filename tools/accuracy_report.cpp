// accuracy_report: runs the accuracy suite's case families (tests/support/rotation_cases.hpp) for every
// rotation method in float and double, and writes a Markdown report (docs/accuracy.md): per family and
// method, the median, 99.9th percentile and maximum of the angle error and of the relative trace loss,
// the worst angle in units of eps * kappa, the NaN count and the number of cases beyond the suite's bounds
// (tests/support/accuracy_bounds.hpp).
//
//   accuracy_report [--seed N] [--cases N] [--out FILE|-] [--families a,b,...] [--threads N]
//
// --cases is the number of matrices per precision, split evenly over the families (as MLSDEFORM_CASES in
// the test suite); with the same seed and a multiple of the family count, the report covers exactly the
// cases the suite judges. The output depends only on the seed, the case count and the library, not on
// --threads.
#include "tests/support/accuracy_bounds.hpp"
#include "tests/support/rotation_cases.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <exception>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

using namespace mlsdeform;
using namespace mlsdeform::testing;

namespace {

constexpr int kMethods = static_cast<int>(std::size(all_rotation_methods));

struct ReportOptions {
  std::uint64_t seed = kDefaultSeed;
  std::uint64_t cases = 200000;  // per precision
  std::string out;
  std::vector<Family> families;
  unsigned threads = 0;
};

/// Sample statistics of one error measure.
struct Summary {
  std::size_t n = 0;
  double median = 0, p999 = 0, max = 0;
};

Summary summarise(std::vector<double>& v) {
  Summary s;
  s.n = v.size();
  if (v.empty()) return s;
  auto at = [&](double q) {
    const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size()))) - 1;
    const auto idx = std::min(k, v.size() - 1);
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(idx), v.end());
    return v[idx];
  };
  s.median = at(0.5);
  s.p999 = at(0.999);
  s.max = *std::max_element(v.begin(), v.end());
  return s;
}

/// Everything measured for one (precision, family, method).
struct Cell {
  Summary angle, loss;
  double worst_normalised_angle = 0;  // max over unique cases of angle / (eps * kappa)
  std::uint64_t non_finite = 0, thrown = 0, beyond = 0;
  std::uint64_t beyond_uniform = 0;  // beyond the bounds with the common constant c_b_uniform
  std::string worst_case;            // the case with the largest angle / (eps kappa), for reproduction
};

struct FamilyResult {
  std::uint64_t cases = 0, unique = 0;
  double kappa_median = 0, kappa_max = 0;  // over cases with a unique optimum
  Cell cells[kMethods];
};

template <class T>
FamilyResult run_family(Family f, std::uint64_t seed, std::uint64_t n) {
  FamilyResult r;
  r.cases = n;
  std::vector<double> angles[kMethods], losses[kMethods], kappas;
  double worst[kMethods] = {};
  for (std::uint64_t i = 0; i < n; ++i) {
    const Case<T> c = make_case<T>(f, seed, i);
    const Reference ref = reference(c.H);
    if (ref.unique()) {
      ++r.unique;
      kappas.push_back(static_cast<double>(ref.kappa));
    }
    for (int m = 0; m < kMethods; ++m) {
      Cell& cell = r.cells[m];
      Matrix3<T> R;
      try {
        R = fit_rotation(c.H, all_rotation_methods[m]);
      } catch (const std::exception&) {
        ++cell.thrown;
        ++cell.beyond;
        ++cell.beyond_uniform;
        continue;
      }
      const Errors e = measure(R, c.H, ref);
      if (!e.finite) {
        ++cell.non_finite;
        ++cell.beyond;
        ++cell.beyond_uniform;
        continue;
      }
      if (!violations<T>(e, ref, all_rotation_methods[m]).empty()) ++cell.beyond;
      if (!violations<T>(e, ref, c_b_uniform).empty()) ++cell.beyond_uniform;
      losses[m].push_back(static_cast<double>(e.trace_loss));
      if (ref.unique()) {
        angles[m].push_back(static_cast<double>(e.angle));
        const double normalised = static_cast<double>(e.angle / (eps<T> * ref.kappa));
        if (normalised > worst[m] || cell.worst_case.empty()) {
          worst[m] = normalised;
          cell.worst_case = describe(c);
        }
      }
    }
  }
  for (int m = 0; m < kMethods; ++m) {
    r.cells[m].angle = summarise(angles[m]);
    r.cells[m].loss = summarise(losses[m]);
    r.cells[m].worst_normalised_angle = worst[m];
  }
  const Summary k = summarise(kappas);
  r.kappa_median = k.median;
  r.kappa_max = k.max;
  return r;
}

std::string sci(double x, int digits = 2) {
  if (x == 0) return "0";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*e", digits - 1, x);
  return buf;
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\n");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t\n") - b + 1);
}

std::string cpu_name() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) return trim(line.substr(line.find(':') + 1));
  return "unknown CPU";
}

std::string command_output(const std::string& cmd) {
  std::string out;
  if (FILE* p = popen(cmd.c_str(), "r")) {
    char buf[256];
    while (std::fgets(buf, sizeof buf, p)) out += buf;
    if (pclose(p) != 0) return "";
  }
  return trim(out);
}

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  char buf[64];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M UTC", std::gmtime(&t));
  return buf;
}

ReportOptions parse(int argc, char** argv) {
  ReportOptions o;
#ifdef MLSDEFORM_SOURCE_DIR
  o.out = MLSDEFORM_SOURCE_DIR "/docs/accuracy.md";
#else
  o.out = "docs/accuracy.md";
#endif
  auto value = [&](int& i) -> std::string {
    if (i + 1 >= argc) throw std::invalid_argument(std::string(argv[i]) + " needs a value");
    return argv[++i];
  };
  auto number = [](const std::string& s) {
    std::size_t pos = 0;
    const unsigned long long v = std::stoull(s, &pos, 0);
    if (pos != s.size() || s[0] == '-') throw std::invalid_argument("'" + s + "' is not an unsigned integer");
    return static_cast<std::uint64_t>(v);
  };
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seed") {
      o.seed = number(value(i));
    } else if (a == "--cases") {
      o.cases = number(value(i));
    } else if (a == "--out") {
      o.out = value(i);
    } else if (a == "--threads") {
      o.threads = static_cast<unsigned>(number(value(i)));
    } else if (a == "--families") {
      std::stringstream ss(value(i));
      std::string name;
      while (std::getline(ss, name, ',')) o.families.push_back(family_from_string(name));
    } else if (a == "--help" || a == "-h") {
      std::cout << "usage: accuracy_report [--seed N] [--cases N per precision] [--out FILE|-] [--families a,b]"
                   " [--threads N]\n";
      std::exit(0);
    } else {
      throw std::invalid_argument("unknown option '" + a + "' (try --help)");
    }
  }
  if (o.families.empty())
    for (const FamilyInfo& f : all_families()) o.families.push_back(f.family);
  if (o.threads == 0) o.threads = std::max(1u, std::thread::hardware_concurrency());
  return o;
}

const FamilyInfo& info(Family f) { return all_families()[static_cast<std::size_t>(f)]; }

template <class T>
void write_precision(std::ostream& md, const char* name, const ReportOptions& o,
                     const std::vector<FamilyResult>& results, std::uint64_t per_family) {
  md << "\n## " << name << " (eps = " << sci(static_cast<double>(eps<T>), 3) << ")\n";
  // Overview: the worst angle in units of eps * kappa and the cases beyond the bounds, per family and method.
  md << "\nWorst angle error in units of eps * kappa (over cases with a unique optimum), and in brackets the "
        "numbers of cases beyond the accuracy suite's bounds (the method's c_b) / beyond the uniform a-priori "
        "bounds (c_b = "
     << static_cast<int>(c_b_uniform) << " for every method), out of " << per_family << " per family.\n\n| family |";
  for (RotationMethod m : all_rotation_methods) md << " " << to_string(m) << " |";
  md << "\n|---|";
  for (int m = 0; m < kMethods; ++m) md << "---|";
  md << "\n";
  for (std::size_t fi = 0; fi < o.families.size(); ++fi) {
    const FamilyResult& r = results[fi];
    md << "| " << info(o.families[fi]).name << " |";
    for (int m = 0; m < kMethods; ++m) {
      const Cell& c = r.cells[m];
      md << " " << (r.unique ? sci(c.worst_normalised_angle) : std::string("-")) << " (" << c.beyond << " / "
         << c.beyond_uniform << ")" << (c.beyond ? " **!**" : "") << " |";
    }
    md << "\n";
  }
  for (std::size_t fi = 0; fi < o.families.size(); ++fi) {
    const FamilyResult& r = results[fi];
    const FamilyInfo& f = info(o.families[fi]);
    md << "\n### " << name << ": " << f.name << "\n\n"
       << f.description << ". " << r.cases << " cases, " << r.unique << " with a unique optimum";
    if (r.unique) md << " (kappa median " << sci(r.kappa_median, 3) << ", max " << sci(r.kappa_max, 3) << ")";
    md << ".\n\n| method | angle median | angle p99.9 | angle max | max angle / (eps kappa) | loss median | "
          "loss p99.9 | loss max | NaN | beyond bounds | beyond uniform bounds |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (int m = 0; m < kMethods; ++m) {
      const Cell& c = r.cells[m];
      md << "| " << to_string(all_rotation_methods[m]) << " | ";
      if (c.angle.n)
        md << sci(c.angle.median) << " | " << sci(c.angle.p999) << " | " << sci(c.angle.max) << " | "
           << sci(c.worst_normalised_angle) << " | ";
      else
        md << "- | - | - | - | ";
      md << sci(c.loss.median) << " | " << sci(c.loss.p999) << " | " << sci(c.loss.max) << " | " << c.non_finite
         << (c.thrown ? " (+" + std::to_string(c.thrown) + " threw)" : std::string()) << " | " << c.beyond << " | "
         << c.beyond_uniform << " |\n";
    }
    bool any = false;
    for (int m = 0; m < kMethods; ++m)
      if (r.cells[m].beyond_uniform && !r.cells[m].worst_case.empty()) {
        if (!any)
          md << "\nWorst case (largest angle / (eps kappa)) of each method with cases beyond the uniform bounds:\n\n";
        any = true;
        md << "- " << to_string(all_rotation_methods[m]) << ": `" << r.cells[m].worst_case << "`\n";
      }
  }
}

}  // namespace

int main(int argc, char** argv) try {
  const ReportOptions o = parse(argc, argv);
  const std::uint64_t per_family = (o.cases + o.families.size() - 1) / o.families.size();
  const auto t0 = std::chrono::steady_clock::now();

  // Tasks: (precision, family), taken by the workers from a shared counter; results land in fixed slots.
  const std::size_t nf = o.families.size();
  std::vector<FamilyResult> results_f(nf), results_d(nf);
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    for (std::size_t t; (t = next.fetch_add(1)) < 2 * nf;) {
      if (t < nf)
        results_d[t] = run_family<double>(o.families[t], o.seed, per_family);
      else
        results_f[t - nf] = run_family<float>(o.families[t - nf], o.seed, per_family);
    }
  };
  std::vector<std::thread> pool;
  for (unsigned i = 0; i < std::min<std::size_t>(o.threads, 2 * nf); ++i) pool.emplace_back(worker);
  for (std::thread& th : pool) th.join();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  std::ostringstream md;
  std::string revision;
#ifdef MLSDEFORM_SOURCE_DIR
  // The commit, and whether the library's sources (core/, kernels/) differ from it in the working tree (other
  // files' changes do not affect the numbers). A description of the checkout when the report runs: the
  // binary should have been rebuilt from it.
  revision = command_output("git -C '" MLSDEFORM_SOURCE_DIR "' rev-parse --short HEAD 2>/dev/null");
  if (!revision.empty()) {
    revision = "`" + revision + "`";
    if (!command_output("git -C '" MLSDEFORM_SOURCE_DIR "' status --porcelain -- core kernels 2>/dev/null").empty())
      revision += ", with uncommitted changes in core/ or kernels/";
  }
#endif
  md << "# Rotation fit accuracy\n\n"
     << "Generated by `tools/accuracy_report` (do not edit by hand; regenerate with "
     << "`build/tools/accuracy_report --seed " << o.seed << " --cases " << o.cases << "`).\n\n"
     << "| | |\n|---|---|\n"
     << "| seed | " << o.seed << " |\n"
     << "| cases | " << o.cases << " matrices per precision, " << per_family << " per family, each fitted by all "
     << kMethods << " methods |\n"
     << "| date | " << utc_now() << " |\n"
     << "| CPU | " << cpu_name() << ", " << std::thread::hardware_concurrency() << " logical CPUs |\n"
     << "| compiler | g++ " << __VERSION__ <<
#ifdef NDEBUG
      ", optimised (NDEBUG)"
#else
      ", assertions on"
#endif
     << (built_with_sanitizer() ? ", AddressSanitizer" : "") << " |\n";
  if (!revision.empty()) md << "| source | " << revision << " |\n";
  md << "| run time | " << static_cast<int>(seconds + 0.5) << " s on " << pool.size() << " threads |\n\n"
     << "**What is measured.** Each case is a 3x3 matrix H (the families are described below and in "
        "`tests/support/rotation_cases.hpp`), built in long double and rounded once to the working precision. "
        "The reference is an SVD of that rounded H in long double (`Eigen::JacobiSVD`): R* = U diag(1, 1, d) V^T "
        "with d = sign det(U V^T), optimum s1 + s2 + d s3, condition number kappa = s1 / (s2 + d s3) (the optimum "
        "is unique iff s2 + d s3 > 0).\n\n"
        "- *angle*: the angle in radians between the method's R and R*, 2 asin(||R - R*||_F / sqrt(8)); only over "
        "cases with a unique optimum (elsewhere any optimal rotation is right).\n"
        "- *max angle / (eps kappa)*: the same, divided by the machine epsilon times kappa. The accuracy suite "
        "allows 2 sqrt(3) c_b of these (plus 96 eps), with the backward-error constant c_b of "
        "`tests/support/accuracy_bounds.hpp`: 16 (55.4 eps kappa) for every method.\n"
        "- *loss*: the relative trace loss (s1 + s2 + d s3 - trace(R^T H)) / ||H||_F, signed (a rounding-level "
        "negative value means R is slightly off orthonormal); over all cases. The suite allows "
        "(2 sqrt(3) c_b + 96) eps = 151 eps.\n"
        "- *NaN*: results with a non-finite entry (never acceptable).\n"
        "- *beyond bounds*: cases that the accuracy suite (`tests/test_rotation_accuracy.cpp`, same bounds) "
        "flags for any reason (orthonormality, det, trace, angle, NaN, exception); every one fails the suite. "
        "*beyond uniform bounds*: the same count with c_b = 16 for every method (now the suite's own "
        "constant for all of them, so the two counts agree).\n";

  write_precision<float>(md, "float", o, results_f, per_family);
  write_precision<double>(md, "double", o, results_d, per_family);

  if (o.out == "-") {
    std::cout << md.str();
  } else {
    std::ofstream out(o.out);
    if (!out) throw std::runtime_error("cannot write " + o.out);
    out << md.str();
    std::cerr << "accuracy_report: wrote " << o.out << " (" << o.cases << " cases per precision, seed " << o.seed
              << ", " << static_cast<int>(seconds + 0.5) << " s)\n";
  }
  return 0;
} catch (const std::exception& e) {
  std::cerr << "accuracy_report: " << e.what() << "\n";
  return 2;
}
