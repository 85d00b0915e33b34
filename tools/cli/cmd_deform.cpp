// `mlsdeform deform`: a mesh file and a handles file in, one deformed mesh (or one per animation frame) out.
#include "core/files/file_io.hpp"
#include "tools/cli/commands.hpp"
#include "tools/cli/progress.hpp"

#include <mlsdeform/files.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <optional>

namespace mlsdeform::cli {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

const char* name(Transform t) {
  return t == Transform::rigid ? "rigid" : t == Transform::similarity ? "similarity" : "affine";
}

template <class T>
int deform(const DeformArgs& a) {
  const Isa isa = checked_active_isa();
  JobOptions jo;
  jo.options = a.options;
  jo.normals = a.normals;
  jo.ply = a.ply_ascii ? PlyEncoding::ascii : PlyEncoding::binary;
  jo.output_type = a.output_type;
  jo.strict_attributes = a.strict_attributes;
  jo.force = a.force;
  jo.max_input_bytes = a.max_input_bytes;
  DeformJob<T> job(a.mesh, a.handles, a.out, jo);  // reads, checks and builds everything; writes nothing
  const JobSummary& s = job.summary();
  const std::vector<std::string>& outputs = job.outputs();
  auto listed = [](const std::vector<std::string>& items) {
    std::string list;
    for (const auto& i : items) list += (list.empty() ? "" : "; ") + i;
    return list;
  };
  if (!s.dropped.empty())
    std::fprintf(stderr, "mlsdeform: dropped from %s: %s\n", a.mesh.c_str(), listed(s.dropped).c_str());

  if (!a.quiet) {
    std::printf("%s: %zu vertices, %zu faces%s\n", a.mesh.c_str(), s.vertices, s.faces,
                // Points and lines are not deformed: kept in OBJ output, named as dropped in another format.
                s.dropped_primitives ? (", " + std::to_string(s.dropped_primitives) + " points/lines").c_str() : "");
    std::printf("%s: %zu point and %zu segment handles%s%s\n", a.handles.c_str(), s.points, s.segments,
                s.animated ? (", " + std::to_string(s.frames) + " frames").c_str() : "",
                s.region == 0 ? ""
                              : (", a region of " + std::to_string(s.region) + " vertices (the " +
                                 std::to_string(s.vertices - s.region) + " others stay)")
                                    .c_str());
    if (!s.kept.empty() || !s.transformed.empty())
      std::printf("attributes: %s%s%s%s\n", s.kept.empty() ? "" : "kept ", listed(s.kept).c_str(),
                  s.kept.empty() || s.transformed.empty() ? "" : "; ",
                  s.transformed.empty() ? "" : ("transformed " + listed(s.transformed)).c_str());
    char threads[32];
    std::snprintf(threads, sizeof threads, a.options.threads > 0 ? "%d threads" : "all cores", a.options.threads);
    const std::string then_arap =
        a.options.arap_iterations > 0 ? ", then " + std::to_string(a.options.arap_iterations) + " ARAP iterations" : "";
    std::printf("deformer: %s, u = %g, %s, %s, %s backend, %s%s; set-up %.2f ms, %.1f MiB\n", name(a.options.transform),
                a.options.weight_exponent, std::string(to_string(a.options.method)).c_str(),
                std::is_same_v<T, float> ? "float" : "double",
                !a.options.isa ? ("simd (" + std::string(to_string(isa)) + ")").c_str() : "scalar", threads,
                then_arap.c_str(), s.setup_ms, double(s.memory_bytes) / (1 << 20));
    if (s.splat_sh_degree >= 0)
      std::printf("splats: %zu Gaussian splats, SH degree %d: rot_*%s and f_rest_* turned by each centre's frame\n",
                  s.vertices, s.splat_sh_degree, a.options.transform == Transform::rigid ? "" : ", scale_*");
    std::fflush(stdout);  // seen before a long first frame, also through a pipe
  }

  double splat_ms = 0;
  std::vector<double> deform_ms;
  std::vector<std::string> written;
  Progress progress(s.frames, a.quiet || !s.animated);
  defer_interrupts(true);
  try {
    for (std::size_t f = 0; f < s.frames; ++f) {
      if (const int sig = pending_interrupt()) throw Interrupted{sig, written.size()};
      // The first SIGINT stops a long ARAP frame between iterations, not after the last one.
      FrameBytes frame;
      try {
        frame = job.encode_frame(f, [] { return pending_interrupt() != 0; });
      } catch (const Cancelled&) {
        throw Interrupted{pending_interrupt(), written.size()};
      }
      deform_ms.push_back(frame.deform_ms);
      splat_ms += frame.attributes_ms;
      const auto t0 = Clock::now();
      write_file_atomic(outputs[f], frame.bytes, a.force);
      written.push_back(outputs[f]);
      progress.frame(f, frame.deform_ms, frame.encode_ms + ms_since(t0), outputs[f]);
    }
    if (const int sig = pending_interrupt()) throw Interrupted{sig, written.size()};
    defer_interrupts(false);
  } catch (...) {
    // All or nothing for an animation too: remove the frames this run already wrote.
    progress.abort();
    for (const auto& w : written) std::filesystem::remove(w);
    throw;
  }

  if (!a.quiet) {
    double total = 0;
    for (double d : deform_ms) total += d;
    const auto [lo, hi] = std::minmax_element(deform_ms.begin(), deform_ms.end());
    if (s.splat_sh_degree >= 0) std::printf("splats turned in %.3f ms (all frames)\n", splat_ms);
    if (s.frames == 1)
      std::printf("deformed in %.3f ms -> %s\n", total, a.out.c_str());
    else
      std::printf("%zu frames deformed in %.1f ms: %.3f ms per frame (min %.3f, max %.3f), %.1f frames/s -> %s .. %s\n",
                  s.frames, total, total / double(s.frames), *lo, *hi, 1000.0 * double(s.frames) / total,
                  outputs.front().c_str(), outputs.back().c_str());
  }
  return 0;
}

}  // namespace

Isa checked_active_isa() {
  try {
    return active_isa();
  } catch (const std::invalid_argument& e) {  // MLSDEFORM_ISA names an unknown or unsupported instruction set
    throw InputError("MLSDEFORM_ISA", e.what());
  }
}

int run_deform(const DeformArgs& args) {
  return args.precision == Precision::single ? deform<float>(args) : deform<double>(args);
}

}  // namespace mlsdeform::cli
