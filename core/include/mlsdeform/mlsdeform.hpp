// mlsdeform: 3D as-rigid-as-possible deformation by Moving Least Squares (Cuno, Esperanca, Oliveira,
// Cavalcanti), and the batched weighted rotation fit at its heart. The one header consumers include.
#pragma once

#include <mlsdeform/arap.hpp>
#include <mlsdeform/cancel.hpp>
#include <mlsdeform/deformer.hpp>
#include <mlsdeform/dispatch.hpp>
#include <mlsdeform/fit_rotations.hpp>
#include <mlsdeform/frames.hpp>
#include <mlsdeform/point_fit.hpp>
#include <mlsdeform/rotation.hpp>
#include <mlsdeform/splats.hpp>
#include <mlsdeform/types.hpp>
#include <mlsdeform/version.hpp>
