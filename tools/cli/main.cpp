// mlsdeform: the command-line tool. Argument parsing (CLI11) and error reporting only; the subcommands are in
// cmd_*.cpp. Exit codes: 0 success, 2 bad input or usage (one line on stderr naming the file and the
// problem), 1 anything else (a bug or no memory).
#include <mlsdeform/files_error.hpp>
#include "core/files/file_io.hpp"
#include "core/files/mesh.hpp"
#include "tools/cli/commands.hpp"

#include <mlsdeform/version.hpp>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

namespace {

using namespace mlsdeform;
using namespace mlsdeform::cli;

std::string one_line(std::string s) {
  for (auto& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

const CLI::Validator exponent_check(
    [](std::string& s) -> std::string {
      try {
        std::size_t used = 0;
        const double u = std::stod(s, &used);
        if (used == s.size() && std::isfinite(u) && u >= 1) return {};
      } catch (const std::exception&) {
      }
      return "the weight exponent u must be a number >= 1, got '" + s + "'";
    },
    "U >= 1");

// A whole decimal count >= 0 that fits in an int: "2", not "2.5", "-1", "+2" or "0x10" (CLI11's own int
// conversion reads "0x10" as 16 and "010" as 8).
const CLI::Validator iterations_check(
    [](std::string& s) -> std::string {
      int n = 0;
      const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), n);
      const bool digits = !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
      if (digits && ec == std::errc() && end == s.data() + s.size()) return {};
      return "the ARAP iteration count must be a whole number >= 0, got '" + s + "'";
    },
    "N >= 0");

// An option taking one of a few names ("rigid", "similarity", ...) into an enum. (Strings and IsMember rather
// than CLI11's enum transformer: its --help shows the enums' numbers.)
template <class E>
CLI::Option* add_choice(CLI::App* app, const std::string& flags, E& target,
                        const std::vector<std::pair<std::string, E>>& choices, const std::string& help) {
  std::vector<std::string> names;
  std::string current;
  for (const auto& [n, e] : choices) {
    names.push_back(n);
    if (e == target) current = n;
  }
  return app
      ->add_option_function<std::string>(
          flags,
          [&target, choices](const std::string& s) {
            for (const auto& [n, e] : choices)
              if (n == s) target = e;
          },
          help)
      ->check(CLI::IsMember(names, CLI::ignore_case))
      ->default_str(current);
}

const std::vector<std::pair<std::string, Precision>> precisions{{"float", Precision::single},
                                                                {"double", Precision::double_}};

/// Bytes as the MiB --weight-budget takes ("64" for 64 << 20), for the help's default: the library's own.
std::string mib_text(std::size_t bytes) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, double(bytes) / 1048576.0);
  return std::string(buf, r.ptr);
}

void add_common_deformer_options(CLI::App* c, Options& o, Precision& precision) {
  std::vector<std::pair<std::string, RotationMethod>> methods;
  for (auto r : all_rotation_methods) methods.emplace_back(std::string(to_string(r)), r);
  add_choice<Transform>(
      c, "--transform,-t", o.transform,
      {{"rigid", Transform::rigid}, {"similarity", Transform::similarity}, {"affine", Transform::affine}},
      "the local transform fitted at each vertex (paper Sec. 4 and 6.1)");
  c->add_option("--exponent,-u", o.weight_exponent, "the weight exponent u in w_i = |p_i - v|^-u (Fig. 5: 2, 3, 4)")
      ->check(exponent_check)
      ->default_str("2");
  add_choice(c, "--method", o.method, methods, "the rotation solver (axis_angle: the paper's Sec. 4.3-4.6)");
  add_choice(c, "--precision", precision, precisions, "floating-point type of the computation");
  c->add_option("--threads,-j", o.threads, "worker threads; 0: all cores")
      ->check(CLI::NonNegativeNumber)
      ->default_str("0");
  add_choice<std::optional<Isa>>(c, "--backend", o.isa, {{"simd", std::nullopt}, {"scalar", Isa::scalar}},
                                 "simd: the SIMD kernels (best ISA at run time); scalar: the reference");
  c->add_option_function<double>(
       "--weight-budget", [&o](double mib) { o.precompute_budget_bytes = static_cast<std::size_t>(mib * 1048576.0); },
       "MiB that the precomputed weight table may take (automatic storage); beyond it, on-the-fly weights or an error")
      ->check(CLI::Range(0.0, 1048576.0))
      ->default_str(mib_text(Options{}.precompute_budget_bytes));
  add_choice<SegmentWeight>(
      c, "--segment-weight", o.segment_weight,
      {{"constant", SegmentWeight::paper_constant}, {"exact", SegmentWeight::exact_integral}},
      "segment handles: constant d^-u along a segment (the paper's Sec. 6.2) or the exact integral");
  add_choice<Centroids>(c, "--centroids", o.centroids, {{"mls", Centroids::mls}, {"rbf", Centroids::rbf}},
                        "q*: the weighted centroid of the targets (mls, eq. 2) or the RBF interpolant of the handles "
                        "at p* (rbf, the paper's Sec. 7-8; precomputed weights only)");
}

int run(int argc, char** argv) {
  CLI::App app{"mlsdeform " + std::to_string(MLSDEFORM_VERSION_MAJOR) + "." + std::to_string(MLSDEFORM_VERSION_MINOR) +
                   "." + std::to_string(MLSDEFORM_VERSION_PATCH) +
                   ": as-rigid-as-possible deformation of 3D meshes by Moving Least Squares\n"
                   "(Cuno, Esperanca, Oliveira, Cavalcanti, \"3D As-Rigid-As-Possible Deformations Using MLS\").",
               "mlsdeform"};
  app.set_version_flag("--version", std::to_string(MLSDEFORM_VERSION_MAJOR) + "." +
                                        std::to_string(MLSDEFORM_VERSION_MINOR) + "." +
                                        std::to_string(MLSDEFORM_VERSION_PATCH));
  app.require_subcommand(1);
  app.footer(
      "Examples:\n"
      "  mlsdeform demo                                   deform the bundled meshes, print frame rates\n"
      "  mlsdeform deform -m in.obj -H handles.json -o out.ply\n"
      "  mlsdeform deform -m in.obj -H handles.json -o out.ply --arap 10   MLS, then 10 ARAP iterations\n"
      "  mlsdeform figures                                redraw the paper's figures in mlsdeform-figures-out/\n"
      "Run 'mlsdeform SUBCOMMAND --help' for a subcommand's options. Exit status: 0 done, 2 bad input or usage,\n"
      "1 internal error, 128 + N interrupted by signal N (the outputs of the run removed).");

  DeformArgs d;
  auto* deform = app.add_subcommand("deform", "Deform a mesh by the handles in a JSON file and write the result.");
  deform->add_option("--mesh,-m", d.mesh, "input mesh: " + readable_formats())->required();
  deform
      ->add_option("--handles,-H", d.handles,
                   "handles file (JSON): point and segment handles, targets, optional frames")
      ->required();
  deform
      ->add_option("--out,-o", d.out,
                   "output mesh, format by extension: " + writable_formats() +
                       "; with frames, one file per frame: OUT_0000.EXT, OUT_0001.EXT, ...")
      ->required();
  add_common_deformer_options(deform, d.options, d.precision);
  deform
      ->add_option("--arap", d.options.arap_iterations,
                   "surface-ARAP iterations after MLS (Sorkine & Alexa 2007) on the mesh's faces, polygons fanned "
                   "into triangles; handle vertices stay where MLS puts them. 0: MLS alone (the paper)")
      ->check(iterations_check)
      ->default_str("0");
  add_choice<mlsdeform::ArapAcceleration>(
      deform, "--arap-acceleration", d.options.arap_acceleration,
      {{"none", mlsdeform::ArapAcceleration::none}, {"anderson", mlsdeform::ArapAcceleration::anderson}},
      "how the --arap iterations are driven: none (plain local/global steps) or anderson (Anderson acceleration "
      "with an energy safeguard: a lower energy after the same iterations)");
  deform->add_flag("--arap-warm-start", d.options.arap_warm_start,
                   "with frames: start each frame's --arap iterations from the last frame's result (from MLS after "
                   "a handle moves by more than 5% of the mesh's bounding-box diagonal)");
  deform
      ->add_option_function<std::size_t>(
          "--max-input-mib", [&d](std::size_t mib) { d.max_input_bytes = mib << 20; },
          "the largest mesh file, or decompressed .gz data, that is read (MiB); larger inputs are refused unread")
      ->check(CLI::Range(std::size_t(1), std::size_t(1) << 24))
      ->default_str(std::to_string(kDefaultMaxInputBytes >> 20));
  deform->add_flag("--force,-f", d.force, "overwrite existing output files");
  deform->add_flag("--ply-ascii", d.ply_ascii, "write PLY as text (default: binary little-endian)");
  add_choice<std::optional<CoordinateType>>(
      deform, "--output-type", d.output_type,
      {{"auto", std::nullopt}, {"float", CoordinateType::float32}, {"double", CoordinateType::float64}},
      "the output's coordinate type: PLY's property type; OBJ and OFF: the shortest text of a float or of a "
      "double. auto: float with --precision float; with --precision double, the input PLY's type (float stays "
      "float), else double");
  add_choice<NormalsOut>(deform, "--normals", d.normals,
                         {{"input", NormalsOut::input}, {"computed", NormalsOut::computed}},
                         "the vertex normals written: input (the input's, transformed by each vertex's linear "
                         "part; none where it has none) or computed (area-weighted, from the deformed faces)");
  deform->add_flag("--strict-attributes", d.strict_attributes,
                   "refuse (exit 2) rather than drop an attribute of the input the output cannot keep (another "
                   "format, or normals an affine fit cannot transform)");
  deform->add_flag("--quiet,-q", d.quiet, "print nothing but errors (attributes dropped are still named)");
  deform->footer(
      "The handles file (see README.md, \"Handles file\"):\n"
      "  {\"points\":   [{\"vertex\": 12, \"target\": [0, 1, 0]}, {\"rest\": [0, 0, 0]}],\n"
      "   \"segments\": [{\"vertices\": [3, 40], \"offset\": [0, 0.2, 0]}],\n"
      "   \"frames\":   [{\"points\": [[0, 1.1, 0], null], \"segments\": [null]}]}\n"
      "A handle is placed by a 0-based vertex index (in the file's vertex order) or a rest position; it moves to an\n"
      "absolute \"target\" or by an \"offset\", else it stays. Each frame gives one entry per handle (null: its own\n"
      "target). An optional \"region\": [i, j, ...] lists the only vertices that may move (the others are written\n"
      "as read). Outputs are written all or nothing (temporary file, then rename); existing files need --force.");

  DemoArgs demo_args;
  auto* demo = app.add_subcommand("demo",
                                  "Deform a bundled mesh and the paper's primitives, print frames/s for the scalar and "
                                  "SIMD backends, write the results and images to a folder.");
  demo->add_option("--out-dir,-o", demo_args.out_dir,
                   "folder for the results (created; its earlier results are replaced)")
      ->default_str(demo_args.out_dir);
  demo->add_option("--frames", demo_args.frames, "frames per animated scene")
      ->check(CLI::Range(1, 100000))
      ->default_str("30");
  demo->add_option("--threads,-j", demo_args.threads, "worker threads; 0: all cores")
      ->check(CLI::NonNegativeNumber)
      ->default_str("0");
  add_choice(demo, "--precision", demo_args.precision, precisions, "floating-point type of the computation");
  demo->add_option("--data-dir", demo_args.data_dir,
                   "folder with the bundled meshes (default: the source tree's data/)");
  demo->add_flag("!--no-images", demo_args.images, "skip the PNG images (they need python3-matplotlib)");

  FiguresArgs fig_args;
  auto* figures =
      app.add_subcommand("figures",
                         "Redraw the paper's Fig. 1 to 8, and MLS against MLS + ARAP (arap.png), as PNG images "
                         "(with python3-matplotlib).");
  figures
      ->add_option("--out-dir,-o", fig_args.out_dir,
                   "folder for the images (created); the docs' copies: --out-dir docs/figures in the source tree")
      ->default_str(fig_args.out_dir);
  figures->add_option("--only", fig_args.only,
                      "comma-separated figures: 1 to 8, arap (default: all; 2 needs the shared fish.obj, "
                      "$MLSDEFORM_MESHES)");
  figures->add_option("--data-dir", fig_args.data_dir,
                      "folder with the bundled meshes (default: the source tree's data/)");
  figures->add_flag("--keep-spec", fig_args.keep_spec, "also keep each figure's JSON description next to its PNG");

  if (argc <= 1) {
    std::fputs(app.help().c_str(), stderr);
    return 2;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    const std::string sub = deform->parsed()    ? " deform"
                            : demo->parsed()    ? " demo"
                            : figures->parsed() ? " figures"
                                                : "";
    std::fprintf(stderr, "mlsdeform: error: %s (see 'mlsdeform%s --help')\n", one_line(e.what()).c_str(), sub.c_str());
    return 2;
  }
  if (deform->parsed()) return run_deform(d);
  if (demo->parsed()) return run_demo(demo_args);
  return run_figures(fig_args);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const InputError& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "mlsdeform: error: %s\n", one_line(e.what()).c_str());
    return 2;
  } catch (const Interrupted& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "mlsdeform: interrupted by signal %d: removed the %zu output file(s) this run wrote\n",
                 e.signal, e.removed);
    return 128 + e.signal;
  } catch (const std::bad_alloc&) {
    // The input asked for more memory than this machine gives (bad input for it, not a bug): exit 2.
    std::fflush(stdout);
    std::fprintf(stderr, "mlsdeform: error: out of memory: the input needs more memory than is available\n");
    return 2;
  } catch (const std::exception& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "mlsdeform: internal error: %s\n", one_line(e.what()).c_str());
    return 1;
  }
}
