// The WebAssembly module's C API (web/src/mlsdeform.js wraps it as an ES module; docs/web.md): plain
// functions over opaque objects, so that JavaScript reaches the library without a binding layer. Every
// function that can fail returns null or a non-zero status and leaves the exception's message for
// mls_last_error(), which the wrapper throws as a JavaScript Error.
#pragma once

#include <exception>
#include <new>
#include <stdexcept>
#include <string>

namespace mlsdeform::web {

/// The message of the last failure (mls_last_error()).
std::string& last_error();

/// Runs f(); on an exception stores its message and returns `failed` instead of f()'s value.
template <class R, class F>
R guarded(R failed, const F& f) {
  try {
    return f();
  } catch (const std::bad_alloc&) {
    last_error() = "out of memory";
  } catch (const std::exception& e) {
    last_error() = e.what();
  } catch (...) {
    last_error() = "unknown error";
  }
  return failed;
}

}  // namespace mlsdeform::web
