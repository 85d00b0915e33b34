// The Python binding of mlsdeform (pybind11): numpy in, numpy out. The per-frame path writes straight into
// the caller's C-contiguous (n, 3) array through the library's interleaved output (no copy of the vertices);
// the GIL is released while the library works. Errors keep the library's message: std::invalid_argument ->
// ValueError, std::out_of_range -> IndexError (pybind11's own translations); shape and dtype problems of an
// argument raise ValueError / TypeError naming the argument and what was received. Long calls (a session's
// set-up, ARAP frames, large batches of fits) check for signals while they work (SignalWatch): Ctrl-C raises
// KeyboardInterrupt promptly, leaving outputs untouched.
// The parts by API area: bind_deformer.cpp (Deformer; the session itself in deformer.hpp), bind_fits.cpp (the
// rotation fits), bind_frames.cpp (normals and tangents through the frames), bind_splats.cpp (the splats),
// bind_files.cpp and mesh_file.cpp (the files library's meshes and handles files), bind_jobs.cpp (its DeformJob);
// arrays.hpp converts arguments, signals.hpp watches for Ctrl-C; this file the module, its error translation and
// the instruction-set functions.
#include "python/src/bindings.hpp"
#include "python/src/signals.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

namespace py = pybind11;
using namespace mlsdeform;

PYBIND11_MODULE(_mlsdeform, m) {
  m.doc() = "mlsdeform: as-rigid-as-possible MLS deformation and batched rotation fits (C++ core).";
  python::g_main_thread = py::module_::import("threading").attr("main_thread")().attr("ident").cast<unsigned long>();
  m.attr("__version__") = std::to_string(MLSDEFORM_VERSION_MAJOR) + "." + std::to_string(MLSDEFORM_VERSION_MINOR) +
                          "." + std::to_string(MLSDEFORM_VERSION_PATCH);
  // pybind11 reads numpy's array descriptors with its own layout of them: numpy 2 changed it, and pybind11 knows
  // the new one from 2.12 on. mlsdeform/__init__.py refuses to import where the two do not match (_check_numpy).
  m.attr("_pybind11_version") = py::make_tuple(PYBIND11_VERSION_MAJOR, PYBIND11_VERSION_MINOR);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const std::invalid_argument& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const std::out_of_range& e) {
      PyErr_SetString(PyExc_IndexError, e.what());
    } catch (const std::logic_error& e) {  // a use error, such as a moved-from session
      PyErr_SetString(PyExc_RuntimeError, e.what());
    }
  });

  python::bind_deformer(m);
  python::bind_fits(m);
  python::bind_frames(m);
  python::bind_splats(m);
  python::bind_files(m);
  python::bind_jobs(m);

  m.def(
      "active_isa", [] { return std::string(to_string(active_isa())); },
      "The instruction set the kernels use: 'scalar', 'sse4_2', 'avx2' or 'avx512' (x86-64), 'neon' (aarch64).");
  m.def(
      "supported_isas",
      [] {
        std::vector<std::string> r;
        for (Isa i : supported_isas()) r.emplace_back(to_string(i));
        return r;
      },
      "The instruction sets this CPU runs, best last.");
  m.def(
      "set_isa",
      [](const std::string& name) {
        for (Isa i : {Isa::scalar, Isa::sse4_2, Isa::avx2, Isa::avx512, Isa::neon})
          if (to_string(i) == name) return set_isa(i);
        throw py::value_error("set_isa: unknown instruction set '" + name + "'");
      },
      py::arg("isa"), "Force an instruction set (ValueError if this CPU cannot run it). Not thread-safe.");
}
