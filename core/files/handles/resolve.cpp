// mlsdeform files, the handles file: resolve_handles (handles_file.hpp), the parsed file checked against a mesh
// (vertex indices in range) and a precision (coordinates that fit), its targets, group motions and frames
// turned into the library's Handles<T>.
#include "core/files/handles_file.hpp"

#include <array>
#include <cmath>
#include <string>
#include <vector>

namespace mlsdeform::files {

namespace {

template <class T>
struct Converter {
  const std::string& file;
  Vector3<T> operator()(const Eigen::Vector3d& p, const std::string& path) const {
    const Vector3<T> q = p.cast<T>();
    if (!q.allFinite())
      throw InputError(
          file, "coordinates too large for " + std::string(std::is_same_v<T, float> ? "--precision float" : "double"),
          path);
    return q;
  }
};

template <class T>
void set_row(Points<T>& m, std::size_t i, const Vector3<T>& v) {
  m.row(Eigen::Index(i)) = v.transpose();
}

// sin and cos of an angle in degrees, exact at multiples of 90 degrees (a quarter turn moves handles exactly).
std::array<double, 2> sin_cos_degrees(double degrees) {
  const double r = std::remainder(degrees, 360.0);  // exact, in [-180, 180]
  const double q = std::nearbyint(r / 90);          // quadrant, -2 to 2
  const double f = r - 90 * q;  // exact (Sterbenz: r and 90 q are within a factor 2 unless q = 0), |f| <= 45
  const double s = std::sin(f * (M_PI / 180)), c = std::cos(f * (M_PI / 180));
  switch ((int(q) + 4) % 4) {
    case 1:
      return {c, -s};
    case 2:
      return {-s, -c};
    case 3:
      return {-c, s};
    default:
      return {s, c};
  }
}

// The rotation by `degrees` about the unit `axis` (Rodrigues: R = c I + s [a]_x + (1 - c) a a^T).
Eigen::Matrix3d rotation(const Eigen::Vector3d& a, double degrees) {
  const auto [s, c] = sin_cos_degrees(degrees);
  Eigen::Matrix3d K;
  K << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return c * Eigen::Matrix3d::Identity() + s * K + (1 - c) * a * a.transpose();
}

}  // namespace

template <class T, class V>
ResolvedHandles<T> resolve_handles(const HandlesFile& h, const PointsRowMajor<V>& vertices) {
  const auto n = std::uint64_t(vertices.rows());
  const Converter<T> convert{h.file};
  auto vertex = [&](std::uint64_t i, const std::string& path) -> Eigen::Vector3d {
    if (i >= n)
      throw InputError(h.file,
                       "vertex index " + std::to_string(i) + " out of range (the mesh has " + std::to_string(n) +
                           " vertices" + (n ? ", 0 to " + std::to_string(n - 1) : std::string()) + ")",
                       path);
    return vertices.row(Eigen::Index(i)).transpose().template cast<double>();
  };

  ResolvedHandles<T> r;
  const std::size_t k = h.points.size(), s = h.segments.size();
  r.rest.points.resize(Eigen::Index(k), 3);
  r.rest.segment_a.resize(Eigen::Index(s), 3);
  r.rest.segment_b.resize(Eigen::Index(s), 3);
  std::vector<Eigen::Vector3d> point_rest(k), seg_a(s), seg_b(s);
  for (std::size_t i = 0; i < k; ++i) {
    const auto& p = h.points[i];
    point_rest[i] = p.vertex ? vertex(*p.vertex, p.path + "/vertex") : p.rest;
    set_row(r.rest.points, i, convert(point_rest[i], p.path + (p.vertex ? "/vertex" : "/rest")));
  }
  for (std::size_t i = 0; i < s; ++i) {
    const auto& g = h.segments[i];
    if (g.vertices) {
      seg_a[i] = vertex((*g.vertices)[0], g.path + "/vertices/0");
      seg_b[i] = vertex((*g.vertices)[1], g.path + "/vertices/1");
    } else {
      seg_a[i] = g.rest_a;
      seg_b[i] = g.rest_b;
    }
    const std::string where = g.path + (g.vertices ? "/vertices" : "/rest");
    set_row(r.rest.segment_a, i, convert(seg_a[i], where));
    set_row(r.rest.segment_b, i, convert(seg_b[i], where));
    if (r.rest.segment_a.row(Eigen::Index(i)) == r.rest.segment_b.row(Eigen::Index(i)))
      throw InputError(h.file, "zero-length segment (its two ends coincide)", where);
  }

  for (std::size_t i = 0; i < h.region.size(); ++i) {
    vertex(h.region[i], "/region/" + std::to_string(i));  // in range, or InputError
    r.region.push_back(Eigen::Index(h.region[i]));
  }

  // A frame: each handle's entry, or its own target when the frame has none.
  // Each group's rest centroid (the default pivot): the mean of its points and its segments' end points.
  std::vector<Eigen::Vector3d> centroid;
  for (const GroupSpec& gs : h.groups) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (std::size_t i : gs.points) sum += point_rest[i];
    for (std::size_t i : gs.segments) sum += seg_a[i] + seg_b[i];
    centroid.push_back(sum / double(gs.points.size() + 2 * gs.segments.size()));
  }

  auto moved = [&](const std::vector<std::optional<Target>>* fp, const std::vector<std::optional<Target>>* fs,
                   const std::vector<std::optional<Motion>>* fg, const std::string& frame_path) {
    Handles<T> m;
    m.points.resize(Eigen::Index(k), 3);
    m.segment_a.resize(Eigen::Index(s), 3);
    m.segment_b.resize(Eigen::Index(s), 3);
    for (std::size_t i = 0; i < k; ++i) {
      const bool own = !fp || !(*fp)[i];
      const Target& t = own ? h.points[i].target : *(*fp)[i];
      const std::string path = own ? h.points[i].path : frame_path + "/points/" + std::to_string(i);
      const Eigen::Vector3d q = t.kind == Target::Kind::rest       ? point_rest[i]
                                : t.kind == Target::Kind::absolute ? t.a
                                                                   : point_rest[i] + t.a;
      set_row(m.points, i, convert(q, path));
    }
    for (std::size_t i = 0; i < s; ++i) {
      const bool own = !fs || !(*fs)[i];
      const Target& t = own ? h.segments[i].target : *(*fs)[i];
      const std::string path = own ? h.segments[i].path : frame_path + "/segments/" + std::to_string(i);
      Eigen::Vector3d a = seg_a[i], b = seg_b[i];
      if (t.kind == Target::Kind::absolute) {
        a = t.a;
        b = t.b;
      } else if (t.kind == Target::Kind::offset) {
        a += t.a;
        b += t.a;
      }
      set_row(m.segment_a, i, convert(a, path));
      set_row(m.segment_b, i, convert(b, path));
    }
    // Groups, after the handles' own targets: their members go to their rest positions under the motion.
    for (std::size_t g = 0; g < h.groups.size(); ++g) {
      const GroupSpec& gs = h.groups[g];
      const Motion& mo = fg && (*fg)[g] ? *(*fg)[g] : gs.motion;
      const Eigen::Matrix3d R = rotation(mo.axis, mo.degrees);
      const Eigen::Vector3d c = mo.pivot ? *mo.pivot : centroid[g];
      const auto image = [&](const Eigen::Vector3d& x) -> Eigen::Vector3d { return R * (x - c) + c + mo.translate; };
      for (std::size_t i : gs.points) set_row(m.points, i, convert(image(point_rest[i]), mo.path));
      for (std::size_t i : gs.segments) {
        set_row(m.segment_a, i, convert(image(seg_a[i]), mo.path));
        set_row(m.segment_b, i, convert(image(seg_b[i]), mo.path));
      }
    }
    return m;
  };
  if (h.frames.empty()) {
    r.frames.push_back(moved(nullptr, nullptr, nullptr, {}));
  } else {
    r.frames.reserve(h.frames.size());
    for (std::size_t f = 0; f < h.frames.size(); ++f)
      r.frames.push_back(
          moved(&h.frames[f].points, &h.frames[f].segments, &h.frames[f].groups, "/frames/" + std::to_string(f)));
  }
  return r;
}

template ResolvedHandles<float> resolve_handles<float, float>(const HandlesFile&, const PointsRowMajor<float>&);
template ResolvedHandles<float> resolve_handles<float, double>(const HandlesFile&, const PointsRowMajor<double>&);
template ResolvedHandles<double> resolve_handles<double, float>(const HandlesFile&, const PointsRowMajor<float>&);
template ResolvedHandles<double> resolve_handles<double, double>(const HandlesFile&, const PointsRowMajor<double>&);

}  // namespace mlsdeform::files
