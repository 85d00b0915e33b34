// Shared by every benchmark program: the context lines (CPU, ISA, threads) that Google Benchmark prints and
// writes into its JSON, a main() that accepts a few options of our own, and small helpers for counters.
#pragma once

#include <benchmark/benchmark.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace bench {

/// The SIMD extensions this CPU offers, widest first ("avx512f avx2 fma sse4.2"), from cpuid; on aarch64
/// "neon" (Advanced SIMD is part of its baseline).
inline std::string cpu_isa() {
#if defined(__x86_64__) || defined(__i386__)
  std::string s;
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx512f")) s += "avx512f ";
  if (__builtin_cpu_supports("avx2")) s += "avx2 ";
  if (__builtin_cpu_supports("fma")) s += "fma ";
  if (__builtin_cpu_supports("sse4.2")) s += "sse4.2 ";
  if (!s.empty()) s.pop_back();
  return s;
#elif defined(__aarch64__)
  return "neon";
#else
  return "";
#endif
}

/// The CPU's model name from /proc/cpuinfo (empty if unreadable).
inline std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      return colon == std::string::npos ? line : line.substr(colon + 2);
    }
  return {};
}

inline int hardware_threads() {
  const unsigned n = std::thread::hardware_concurrency();
  return n ? static_cast<int>(n) : 1;
}

/// Context lines common to every program (they land in the JSON "context" object the report reads).
/// `library_isa` names the kernel path the library dispatches to (or how the program runs, e.g. "scalar").
inline void add_context(std::string_view library_isa, std::string_view threads) {
  benchmark::AddCustomContext("cpu_model", cpu_model());
  benchmark::AddCustomContext("cpu_isa", cpu_isa());
  benchmark::AddCustomContext("library_isa", std::string(library_isa));
  benchmark::AddCustomContext("hardware_threads", std::to_string(hardware_threads()));
  benchmark::AddCustomContext("threads", std::string(threads));
#ifdef __VERSION__
  benchmark::AddCustomContext("compiler", __VERSION__);
#endif
}

/// A counter that reports `per_iteration` units of work as time per unit in nanoseconds: Google Benchmark's
/// kInvert of a rate gives seconds per unit; scaling the count by 1e-9 turns that into nanoseconds.
inline benchmark::Counter ns_per(double per_iteration) {
  return benchmark::Counter(per_iteration * 1e-9,
                            benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

/// Our own options, taken out of argv before benchmark::Initialize sees it: "--name=value" pairs for the
/// names listed. Returns the values (empty string when absent).
inline std::vector<std::string> take_options(int& argc, char** argv, const std::vector<std::string>& names) {
  std::vector<std::string> values(names.size());
  int out = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    bool taken = false;
    for (std::size_t k = 0; k < names.size(); ++k) {
      const std::string prefix = "--" + names[k] + "=";
      if (arg.rfind(prefix, 0) == 0) {
        values[k] = std::string(arg.substr(prefix.size()));
        taken = true;
      }
    }
    if (!taken) argv[out++] = argv[i];
  }
  argc = out;
  argv[argc] = nullptr;
  return values;
}

/// The standard tail of our main(): initialise, run, shut down.
inline int run_benchmarks(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

}  // namespace bench
