// mlsdeform files: the handles file (JSON). Its format is documented in README.md, "Handles file".
//
// Parsing is split from resolving: parse_handles() checks the file on its own (syntax, types, required
// and unknown keys, counts); resolve_handles() checks it against a mesh (vertex indices in range) and a
// precision (coordinates that fit), and produces the library's Handles<T>. Both report problems as
// InputError with the JSON path (RFC 6901 pointer, e.g. "/points/2/vertex") of the offending value.
#pragma once

#include <mlsdeform/files_error.hpp>

#include <mlsdeform/deformer.hpp>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace mlsdeform::files {

/// Where one handle goes in one frame.
struct Target {
  enum class Kind { rest, absolute, offset };
  Kind kind = Kind::rest;  ///< rest: stays where it is
  /// absolute: the point (a) or the segment's ends (a, b); offset: the displacement (a) of the point or of
  /// both ends of the segment.
  Eigen::Vector3d a = Eigen::Vector3d::Zero(), b = Eigen::Vector3d::Zero();
};

struct PointHandleSpec {
  std::optional<std::uint64_t> vertex;             ///< rest position = this mesh vertex ...
  Eigen::Vector3d rest = Eigen::Vector3d::Zero();  ///< ... or this position
  Target target;
  std::string path;  ///< JSON path, for messages
};

struct SegmentHandleSpec {
  std::optional<std::array<std::uint64_t, 2>> vertices;
  Eigen::Vector3d rest_a = Eigen::Vector3d::Zero(), rest_b = Eigen::Vector3d::Zero();
  Target target;
  std::string path;
};

/// A rigid motion of a handle group: x -> R (x - pivot) + pivot + translate, R the rotation by `degrees`
/// about `axis` (right-handed; identity when the group has no "rotate").
struct Motion {
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< unit length
  double degrees = 0;
  std::optional<Eigen::Vector3d> pivot;  ///< none: the group's rest centroid
  Eigen::Vector3d translate = Eigen::Vector3d::Zero();
  std::string path;  ///< JSON path, for messages
};

/// Handles moved as one rigid body; each handle is in at most one group.
struct GroupSpec {
  std::vector<std::size_t> points, segments;  ///< indices into HandlesFile::points, ::segments
  Motion motion;
  std::string path;
};

/// One frame of an animation: a target per handle, or none (std::nullopt: the handle's own target), and a
/// motion per group, or none (the group's own).
struct FrameSpec {
  std::vector<std::optional<Target>> points, segments;
  std::vector<std::optional<Motion>> groups;
};

struct HandlesFile {
  std::string file;  ///< name used in messages
  std::vector<PointHandleSpec> points;
  std::vector<SegmentHandleSpec> segments;
  std::vector<GroupSpec> groups;  ///< applied after the handles' own targets, overriding them
  std::vector<FrameSpec> frames;  ///< empty unless the file has "frames"
  /// "region": the vertices that may move (Options::region), each once; empty: the whole mesh.
  std::vector<std::uint64_t> region;
  bool animated() const { return !frames.empty(); }
};

/// Parses and checks a handles file's text. `file` names it in errors. Throws InputError.
HandlesFile parse_handles(std::string_view json_text, const std::string& file);
/// read_file + parse_handles.
HandlesFile read_handles(const std::string& path);

template <class T>
struct ResolvedHandles {
  Handles<T> rest;
  /// One per output: the file's frames, or the handles' own targets when it has none.
  std::vector<Handles<T>> frames;
  /// The file's "region", checked against the mesh (Options::region).
  std::vector<Eigen::Index> region;
};

/// Looks up vertex indices in `vertices` (n x 3, float or double: the mesh as read) and converts to T. Throws
/// InputError (with the JSON path) on an index out of range (of a handle or of the region), a coordinate that
/// is not finite in T, or a zero-length rest segment.
template <class T, class V>
ResolvedHandles<T> resolve_handles(const HandlesFile& handles, const PointsRowMajor<V>& vertices);

extern template ResolvedHandles<float> resolve_handles<float, float>(const HandlesFile&, const PointsRowMajor<float>&);
extern template ResolvedHandles<float> resolve_handles<float, double>(const HandlesFile&,
                                                                      const PointsRowMajor<double>&);
extern template ResolvedHandles<double> resolve_handles<double, float>(const HandlesFile&,
                                                                       const PointsRowMajor<float>&);
extern template ResolvedHandles<double> resolve_handles<double, double>(const HandlesFile&,
                                                                        const PointsRowMajor<double>&);

}  // namespace mlsdeform::files
