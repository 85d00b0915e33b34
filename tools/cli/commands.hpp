// mlsdeform CLI: the subcommands, separated from argument parsing (main.cpp) so that tests can call them.
// Each returns the process exit code and throws InputError for bad input (exit code 2).
#pragma once

#include "core/files/mesh.hpp"

#include <mlsdeform/deformer.hpp>
#include <mlsdeform/dispatch.hpp>

#include <optional>
#include <string>

namespace mlsdeform::cli {

// The program is a command layer over the files library (core/files/): its names are the program's own.
using namespace mlsdeform::files;

enum class Precision { single, double_ };

struct DeformArgs {
  std::string mesh, handles, out;
  Options options;  ///< transform, weight_exponent, method, backend, threads, segment_weight
  Precision precision = Precision::single;
  bool force = false;
  bool ply_ascii = false;
  /// The output's coordinate type (WriteOptions::coordinates); none: the input's, at most the precision's.
  std::optional<CoordinateType> output_type = std::nullopt;
  bool quiet = false;
  /// The normals written: the input's, transformed by each vertex's linear part, or computed from the faces.
  NormalsOut normals = NormalsOut::input;
  /// Refuse (exit 2) rather than drop an attribute of the input that the output cannot keep.
  bool strict_attributes = false;
  std::size_t max_input_bytes = std::size_t(1) << 30;  ///< mesh file, or its decompressed data (kDefaultMaxInputBytes)
};
int run_deform(const DeformArgs& args);

struct DemoArgs {
  std::string out_dir = "mlsdeform-demo-out";
  std::string data_dir;  ///< empty: $MLSDEFORM_DATA_DIR, else the source tree's data/
  int frames = 30;
  int threads = 0;
  Precision precision = Precision::single;
  bool images = true;
};
int run_demo(const DemoArgs& args);

struct FiguresArgs {
  /// Relative to the current folder, as demo's (never the source tree: docs/figures is regenerated on purpose,
  /// with --out-dir docs/figures).
  std::string out_dir = "mlsdeform-figures-out";
  std::string data_dir;
  std::string only;  ///< e.g. "1,5"; empty: all
  bool keep_spec = false;
};
int run_figures(const FiguresArgs& args);

/// mlsdeform::active_isa(), with a bad MLSDEFORM_ISA reported as InputError rather than as a bug.
Isa checked_active_isa();

/// The bundled data folder (data/): args value, else $MLSDEFORM_DATA_DIR, else the source tree's.
std::string data_dir(const std::string& from_args);

}  // namespace mlsdeform::cli
