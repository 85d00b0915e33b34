// mlsdeform files, the handles file: a JSON value with its RFC 6901 path (Node), and the checks of its type and
// keys that every part of the parser makes, each failing with an InputError that names the file and the path
// ("/points/2/vertex") of the offending value. Only the parser (parse.cpp) includes it.
#pragma once

#include <mlsdeform/files_error.hpp>

#include <nlohmann/json.hpp>

#include <Eigen/Core>

#include <array>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <string>

namespace mlsdeform::files::handles {

using nlohmann::json;

// A JSON value with its RFC 6901 path, so that every check can say where it failed.
struct Node {
  const json& v;
  std::string path;
  const std::string& file;

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(file, problem, path.empty() ? "/" : path);
  }

  Node operator[](const char* key) const { return {v.at(key), path + "/" + key, file}; }
  Node at(std::size_t i) const { return {v.at(i), path + "/" + std::to_string(i), file}; }
  bool has(const char* key) const { return v.contains(key); }
  /// One of the two keys, not both and not neither.
  void exactly_one_of(const char* a, const char* b) const {
    if (has(a) == has(b))
      fail(has(a) ? std::string("give \"") + a + "\" or \"" + b + "\", not both"
                  : std::string("missing \"") + a + "\" or \"" + b + "\"");
  }

  void require_object(const char* what) const {
    if (!v.is_object()) fail(std::string("expected ") + what + ", found " + v.type_name());
  }
  void require_array(const char* what) const {
    if (!v.is_array()) fail(std::string("expected ") + what + ", found " + v.type_name());
  }
  void only_keys(std::initializer_list<const char*> allowed) const {
    for (const auto& item : v.items()) {
      bool ok = false;
      for (const char* a : allowed) ok = ok || item.key() == a;
      if (!ok) {
        std::string list;
        for (const char* a : allowed) list += std::string(list.empty() ? "" : ", ") + "\"" + a + "\"";
        Node{item.value(), path + "/" + escape(item.key()), file}.fail("unknown key (expected " + list + ")");
      }
    }
  }
  static std::string escape(const std::string& key) {  // RFC 6901: ~ -> ~0, / -> ~1
    std::string s;
    for (char c : key) s += c == '~' ? "~0" : c == '/' ? "~1" : std::string(1, c);
    return s;
  }

  double number() const {
    if (!v.is_number()) fail(std::string("expected a number, found ") + v.type_name());
    const double d = v.get<double>();
    if (!std::isfinite(d)) fail("not a finite number");
    return d;
  }
  Eigen::Vector3d vec3() const {
    if (!v.is_array() || v.size() != 3)
      fail(std::string("expected a position [x, y, z], found ") +
           (v.is_array() ? "an array of " + std::to_string(v.size()) : std::string(v.type_name())));
    return {at(0).number(), at(1).number(), at(2).number()};
  }
  std::array<Eigen::Vector3d, 2> vec3_pair() const {
    if (!v.is_array() || v.size() != 2)
      fail(std::string("expected two end points [[x, y, z], [x, y, z]], found ") +
           (v.is_array() ? "an array of " + std::to_string(v.size()) : std::string(v.type_name())));
    return {at(0).vec3(), at(1).vec3()};
  }
  std::uint64_t index(const char* what = "vertex") const {
    if (v.is_number_unsigned()) return v.get<std::uint64_t>();
    if (v.is_number_integer())
      fail(std::string(what) + " index " + std::to_string(v.get<std::int64_t>()) + " is negative");
    fail(std::string("expected a ") + what + " index (an integer from 0), found " +
         (v.is_number() ? v.dump() : v.type_name()));
  }
};

}  // namespace mlsdeform::files::handles
