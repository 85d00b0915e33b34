// The deformer tests' own header (tests/test_deformer*.cpp): the Catch2-specific bits (the seed of the random
// tests) and the names they use from the test-support library (tests/support: random scenes, the OBJ vertex
// reader, and the direct per-vertex MLS evaluation with its derived error bound, mls_reference.hpp).
#pragma once

#include "tests/support/deform_cases.hpp"
#include "tests/support/meshes.hpp"
#include "tests/support/mls_reference.hpp"
#include "tests/support/random.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace deformer_test {

using namespace mlsdeform;
using Vec3d = Eigen::Vector3d;
using Mat3d = Eigen::Matrix3d;

inline constexpr Transform all_transforms[] = {Transform::rigid, Transform::similarity, Transform::affine};

inline const char* name(Transform t) {
  return t == Transform::rigid ? "rigid" : t == Transform::similarity ? "similarity" : "affine";
}

template <class T>
const char* type_name() {
  return sizeof(T) == 4 ? "float" : "double";
}

/// The seed of the random tests: Catch's --rng-seed (0 means the fixed default below).
inline unsigned seed() {
  const unsigned s = Catch::getSeed();
  return s != 0 ? s : 20240611u;
}

// The shared helpers, from the test-support library (tests/support).
using testing::bundled_mesh;
using testing::cast_handles;
using testing::compare_with_direct;
using testing::Comparison;
using testing::DeformCase;
using testing::direct_vertex;
using testing::DirectVertex;
using testing::random_case;
using testing::random_points;
using testing::random_rotation;
using testing::random_vector;
using testing::read_obj_vertices;
using testing::rotation_about;
using testing::rounded_points;
using testing::rounded_to;
using testing::scene_size;
using testing::shared_mesh;
using testing::transformed;
using testing::twisted_cube_case;

}  // namespace deformer_test
