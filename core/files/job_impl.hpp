// mlsdeform files: DeformJob's state (job.cpp builds it, job_frames.cpp runs the frames).
#pragma once

#include "core/files/carry.hpp"
#include "core/files/handles_file.hpp"
#include "core/files/mesh.hpp"

#include <mlsdeform/files.hpp>

#include <optional>
#include <string>
#include <vector>

namespace mlsdeform::files {

template <class T>
struct DeformJob<T>::Impl {
  std::string mesh_path, handles_path;
  JobOptions options;
  BasicMesh<T> mesh;    ///< the rest pose as read
  BasicMesh<T> result;  ///< the frame being encoded: a copy of `mesh`, its positions and attributes carried
  ResolvedHandles<T> handles;
  std::optional<Deformer<T>> deformer;
  std::vector<std::string> outputs;
  JobSummary summary;
  WriteOptions write;
  CarryPlan plan;
  Points<T> out;
  std::vector<T> linear, quaternions, scales;  ///< the frames the plan needs (FramesOut)
};

}  // namespace mlsdeform::files
