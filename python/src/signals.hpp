// Signals during the long calls the binding makes with the GIL released (SignalWatch, interruptible):
// Ctrl-C raises KeyboardInterrupt promptly and leaves the caller's outputs untouched.
#pragma once

#include <mlsdeform/mlsdeform.hpp>

#include <pybind11/pybind11.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <utility>

namespace mlsdeform::python {

namespace py = pybind11;

/// Python's main thread (threading.main_thread().ident, read at import): the only one on which Python runs
/// signal handlers.
inline unsigned long g_main_thread = 0;

/// Signals during a long call that runs with the GIL released. Python runs signal handlers only on its main
/// thread and with the GIL, so the library's cancellation check (mlsdeform::CancelCheck, asked between blocks
/// from any of its threads) does this: on the calling thread, if it is Python's main thread, at most once per
/// kInterval it takes the GIL and calls PyErr_CheckSignals, which runs the handlers; if one raised
/// (KeyboardInterrupt for SIGINT), the exception is kept and every later check, on any thread, says stop.
/// Other threads and the times in between cost one relaxed atomic load (and a clock read). The library then
/// throws mlsdeform::Cancelled having changed nothing, and raise_kept() raises the handler's exception.
/// A signal that arrives after the last check is handled by Python when the call returns, as usual.
class SignalWatch {
 public:
  static constexpr std::chrono::milliseconds kInterval{50};

  SignalWatch()
      : caller_(std::this_thread::get_id()),
        main_(PyThread_get_thread_ident() == g_main_thread),
        next_(std::chrono::steady_clock::now() + kInterval) {}
  SignalWatch(const SignalWatch&) = delete;
  SignalWatch& operator=(const SignalWatch&) = delete;
  ~SignalWatch() {  // destroyed with the GIL held (created with it, outside the released scope)
    Py_XDECREF(type_);
    Py_XDECREF(value_);
    Py_XDECREF(trace_);
  }

  /// The check to hand to the library; valid while *this lives.
  CancelCheck check() {
    if (!main_) return {};  // no signal handler can run on this thread: nothing to check
    return [this] { return poll(); };
  }

  /// With the GIL held, after the call: raises the handler's exception if one was kept.
  void raise_kept() {
    if (!stop_.load(std::memory_order_relaxed)) return;
    PyErr_Restore(type_, value_, trace_);
    type_ = value_ = trace_ = nullptr;
    throw py::error_already_set();
  }

 private:
  bool poll() {
    if (stop_.load(std::memory_order_relaxed)) return true;
    if (std::this_thread::get_id() != caller_) return false;
    const auto now = std::chrono::steady_clock::now();
    if (now < next_) return false;
    next_ = now + kInterval;
    const py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() == 0) return false;
    PyErr_Fetch(&type_, &value_, &trace_);
    stop_.store(true, std::memory_order_relaxed);
    return true;
  }

  std::thread::id caller_;
  bool main_;
  std::chrono::steady_clock::time_point next_;  ///< touched by the calling thread only
  std::atomic<bool> stop_{false};
  PyObject *type_ = nullptr, *value_ = nullptr, *trace_ = nullptr;
};

/// Runs f(check) with the GIL released and a SignalWatch's check (or an empty one when `watch` is false);
/// a call the watch stopped raises the signal handler's exception (KeyboardInterrupt).
template <class F>
void interruptible(bool watch, F&& f) {
  SignalWatch w;
  try {
    const py::gil_scoped_release release;
    f(watch ? w.check() : CancelCheck());
  } catch (...) {  // Cancelled, or another error while a handler had raised: the handler's exception wins
    w.raise_kept();
    throw;
  }
  w.raise_kept();  // stopped in the last block without a check after it: the signal still counts
}

}  // namespace mlsdeform::python
