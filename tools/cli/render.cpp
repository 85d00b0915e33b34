#include "tools/cli/render.hpp"

#include <mlsdeform/files_error.hpp>
#include "core/files/file_io.hpp"

#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <stdexcept>
#include <utility>

extern char** environ;

namespace mlsdeform::cli {
namespace {

using nlohmann::json;

// Coordinates rounded to 6 significant digits of the figure's size: plenty for a picture, and short JSON.
double round_to(double v, double quantum) { return quantum > 0 ? std::round(v / quantum) * quantum : v; }

json color(const Color& c) { return json::array({c[0], c[1], c[2]}); }

json flat(const Points<double>& p, double q) {
  json a = json::array();
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (int k = 0; k < 3; ++k) a.push_back(round_to(p(i, k), q));
  return a;
}

json flat(const PointsRowMajor<float>& p, double q) {
  json a = json::array();
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (int k = 0; k < 3; ++k) a.push_back(round_to(double(p(i, k)), q));
  return a;
}

// Runs argv, waits, returns the exit status (-1 if it could not start).
int run(const std::vector<std::string>& args, bool quiet) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (quiet) {
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  }
  pid_t pid;
  const int rc = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return -1;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

}  // namespace

void add_handles(Panel& panel, const Handles<double>& h, bool target, bool with_labels) {
  const Color c = target ? Color{0.85f, 0.1f, 0.1f} : Color{0.1f, 0.3f, 0.9f};
  if (h.point_count() > 0) {
    PointLayer p;
    p.xyz = h.points;
    p.color = c;
    p.size = float(std::clamp(22.0 * std::sqrt(24.0 / double(h.point_count())), 6.0, 22.0));  // smaller when many
    if (with_labels) p.label = target ? "handle target" : "handle rest position";
    panel.points.push_back(std::move(p));
  }
  if (h.segment_count() > 0) {
    SegmentLayer s;
    s.a = h.segment_a;
    s.b = h.segment_b;
    s.color = c;
    s.width = 3.5f;
    if (with_labels) s.label = target ? "segment target" : "segment rest position";
    panel.segments.push_back(std::move(s));
  }
}

void add_moves(Panel& panel, const Handles<double>& rest, const Handles<double>& target) {
  SegmentLayer s;
  s.color = {0.35f, 0.35f, 0.35f};
  s.width = 1.0f;
  s.arrow = true;
  s.label = "handle move";
  const Eigen::Index k = rest.point_count(), m = rest.segment_count();
  s.a.resize(k + 2 * m, 3);
  s.b.resize(k + 2 * m, 3);
  s.a << rest.points, rest.segment_a, rest.segment_b;
  s.b << target.points, target.segment_a, target.segment_b;
  // Only handles that move.
  std::vector<Eigen::Index> keep;
  for (Eigen::Index i = 0; i < s.a.rows(); ++i)
    if ((s.a.row(i) - s.b.row(i)).norm() > 0) keep.push_back(i);
  Points<double> a(Eigen::Index(keep.size()), 3), b(Eigen::Index(keep.size()), 3);
  for (std::size_t j = 0; j < keep.size(); ++j) {
    a.row(Eigen::Index(j)) = s.a.row(keep[j]);
    b.row(Eigen::Index(j)) = s.b.row(keep[j]);
  }
  if (keep.empty() || keep.size() > 12) return;  // many arrows only hide the mesh
  s.a = a;
  s.b = b;
  panel.segments.insert(panel.segments.begin(), std::move(s));
}

SegmentLayer polygon_edges(const Mesh& mesh, Color color, float width) {
  std::set<std::pair<std::uint32_t, std::uint32_t>> edges;
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const std::uint32_t b = mesh.face_start[f], e = mesh.face_start[f + 1];
    for (std::uint32_t i = b; i < e; ++i) {
      const std::uint32_t u = mesh.face_indices[i], w = mesh.face_indices[i + 1 < e ? i + 1 : b];
      edges.emplace(std::min(u, w), std::max(u, w));
    }
  }
  SegmentLayer s;
  s.color = color;
  s.width = width;
  s.a.resize(Eigen::Index(edges.size()), 3);
  s.b.resize(Eigen::Index(edges.size()), 3);
  Eigen::Index k = 0;
  for (const auto& [u, w] : edges) {
    s.a.row(k) = mesh.vertices.row(u).cast<double>();
    s.b.row(k++) = mesh.vertices.row(w).cast<double>();
  }
  return s;
}

std::string figures_script() {
  if (const char* env = std::getenv("MLSDEFORM_FIGURES_SCRIPT"); env && *env) return env;
  return MLSDEFORM_FIGURES_SCRIPT;
}

namespace {
struct Renderer {
  bool ok = false;
  std::string python, why;
};

// The first python that can import matplotlib: $MLSDEFORM_PYTHON, then python3 on PATH, then Debian's own
// /usr/bin/python3 (a python3 from pyenv or a virtual environment on PATH often lacks python3-matplotlib).
const Renderer& renderer() {
  static const Renderer r = [] {
    Renderer out;
    const std::string script = figures_script();
    if (!std::filesystem::exists(script)) {
      out.why = "the figure script " + script + " is missing";
      return out;
    }
    std::vector<std::string> candidates;
    if (const char* env = std::getenv("MLSDEFORM_PYTHON"); env && *env) candidates.push_back(env);
    candidates.push_back("python3");
    candidates.push_back("/usr/bin/python3");
    bool found_python = false;
    for (const auto& py : candidates) {
      const int rc = run({py, script, "--check"}, /*quiet=*/true);
      found_python = found_python || (rc != -1 && rc != 127);
      if (rc == 0) {
        out.ok = true;
        out.python = py;
        return out;
      }
    }
    out.why = found_python ? "python3 cannot import matplotlib (Debian: apt-get install python3-matplotlib)"
                           : "python3 not found (Debian: apt-get install python3-matplotlib)";
    return out;
  }();
  return r;
}
}  // namespace

bool renderer_available(std::string* why_not) {
  if (why_not) *why_not = renderer().why;
  return renderer().ok;
}

void render(const Figure& fig, const std::string& png_path, bool keep_spec) {
  // The figure's extent, for the shared scale and for rounding.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(HUGE_VAL), hi = -lo;
  for (const auto& p : fig.panels)
    for (const auto& m : p.meshes)
      for (Eigen::Index i = 0; i < m.mesh.vertex_count(); ++i) {
        lo = lo.cwiseMin(m.mesh.vertices.row(i).transpose().cast<double>());
        hi = hi.cwiseMax(m.mesh.vertices.row(i).transpose().cast<double>());
      }
  const double quantum = lo.allFinite() && hi.allFinite() ? (hi - lo).maxCoeff() * 1e-5 : 0.0;

  json spec;
  spec["title"] = fig.title;
  spec["caption"] = fig.caption;
  spec["rows"] = fig.rows;
  spec["cols"] = fig.cols;
  spec["panel_size"] = {fig.panel_width, fig.panel_height};
  spec["dpi"] = fig.dpi;
  spec["shared_bounds"] = fig.shared_bounds;
  spec["output"] = png_path;
  json panels = json::array();
  for (const auto& p : fig.panels) {
    json jp;
    jp["title"] = p.title;
    jp["view"] = {{"elev", p.elev}, {"azim", p.azim}};
    jp["row_span"] = p.row_span;
    if (p.plot) {
      json series = json::array();
      for (const auto& c : p.plot->series)
        series.push_back({{"label", c.label}, {"color", color(c.color)}, {"x", c.x}, {"y", c.y}});
      jp["plot"] = {
          {"xlabel", p.plot->xlabel}, {"ylabel", p.plot->ylabel}, {"log_x", p.plot->log_x}, {"series", series}};
    }
    jp["meshes"] = json::array();
    for (const auto& m : p.meshes) {
      const auto tris = triangulate(m.mesh);
      json jm = {{"vertices", flat(m.mesh.vertices, quantum)},
                 {"triangles", tris},
                 {"color", color(m.color)},
                 {"alpha", m.alpha}};
      if (!m.face_colors.empty()) {
        if (m.face_colors.size() != m.mesh.face_count())
          throw std::logic_error("render: face_colors must have one colour per face");
        json tc = json::array();  // per triangle, in triangulate()'s order: a fan of k - 2 per k-gon
        for (std::size_t f = 0; f < m.mesh.face_count(); ++f)
          for (std::uint32_t t = 2; t < m.mesh.face_start[f + 1] - m.mesh.face_start[f]; ++t)
            tc.push_back(color(m.face_colors[f]));
        jm["triangle_colors"] = std::move(tc);
      }
      jp["meshes"].push_back(std::move(jm));
    }
    jp["points"] = json::array();
    for (const auto& l : p.points)
      jp["points"].push_back({{"xyz", flat(l.xyz, quantum)},
                              {"color", color(l.color)},
                              {"size", l.size},
                              {"marker", l.marker},
                              {"label", l.label}});
    jp["segments"] = json::array();
    for (const auto& l : p.segments)
      jp["segments"].push_back({{"a", flat(l.a, quantum)},
                                {"b", flat(l.b, quantum)},
                                {"color", color(l.color)},
                                {"width", l.width},
                                {"arrow", l.arrow},
                                {"label", l.label}});
    panels.push_back(std::move(jp));
  }
  spec["panels"] = std::move(panels);

  std::string spec_path;
  if (keep_spec) {
    spec_path = std::filesystem::path(png_path).replace_extension(".json").string();
  } else {
    char tmpl[] = "/tmp/mlsdeform-figure-XXXXXX";
    const int fd = mkstemp(tmpl);
    if (fd < 0) throw InputError(png_path, "cannot create a temporary file for the figure spec");
    ::close(fd);
    spec_path = tmpl;
  }
  write_file_atomic(spec_path, spec.dump(), /*force=*/true);
  if (!renderer().ok) throw InputError(png_path, "cannot render: " + renderer().why);
  const int rc = run({renderer().python, figures_script(), spec_path}, /*quiet=*/false);
  if (!keep_spec) std::filesystem::remove(spec_path);
  if (rc != 0)
    throw InputError(png_path, "rendering failed (" + renderer().python + " " + figures_script() + " exited with " +
                                   std::to_string(rc) + ")");
}

}  // namespace mlsdeform::cli

namespace mlsdeform::cli {

Panel mesh_panel(const std::string& title, const Mesh& mesh, const Handles<double>& rest,
                 const Handles<double>* target) {
  Panel p;
  p.title = title;
  p.meshes.push_back({mesh});
  if (target) {
    add_moves(p, rest, *target);
    add_handles(p, *target, true);
  } else {
    add_handles(p, rest, false);
  }
  return p;
}

}  // namespace mlsdeform::cli
