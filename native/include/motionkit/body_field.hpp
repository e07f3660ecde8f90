// A skinned body as a signed-distance field on a regular grid in its rest space (docs/body.md): per cell
// the distance to the mesh's surface, negative inside the closed mesh, and the bone that carries the
// nearest surface, so that each bone's part of the body can be sampled where its bone has moved it.
//
// The sign is voted by rays along the grid's three axes (two of three), each counting the surface's
// crossings by their winding (the nonzero rule: inside any shell is inside), so that a hole in a mesh that
// is not watertight flips at most the one axis whose rays pass through it. The distance is exact
// (point to triangle) within two cells of the surface and carried beyond by each neighbour's nearest
// surface point (a vector distance transform: exact on a convex surface, within a fraction of a cell
// elsewhere).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "motionkit/error.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

using ConstTriangleView = Eigen::Ref<const Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>>;

// Caller-owned buffers; Run() allocates its per-column ray hits, the per-cell nearest points and votes once.
//   vertices:    V x 3 rest positions (finite)
//   triangles:   T x 3 vertex indices
//   vertex_bone: V, the bone carrying each vertex most (any int; -1 for none)
//   origin:      the first cell's centre; spacing: the cells' size (> 0); dims: cells along x, y, z
//   distance:    nx*ny*nz out, cell (i, j, k) at (i*ny + j)*nz + k
//   bone:        nx*ny*nz out, the bone of the nearest surface point's nearest vertex
struct BodyFieldJob {
  BodyFieldJob(ConstMatrixView vertices_in, ConstTriangleView triangles_in, std::vector<int> vertex_bone_in,
               Eigen::Vector3d origin_in, double spacing_in, Eigen::Vector3i dims_in,
               Eigen::Ref<Eigen::VectorXd> distance_out, Eigen::Ref<Eigen::VectorXi> bone_out)
      : vertices(vertices_in),
        triangles(triangles_in),
        vertex_bone(std::move(vertex_bone_in)),
        origin(origin_in),
        spacing(spacing_in),
        dims(dims_in),
        distance(distance_out),
        bone(bone_out) {}

  ConstMatrixView vertices;
  ConstTriangleView triangles;
  std::vector<int> vertex_bone;
  Eigen::Vector3d origin;
  double spacing;
  Eigen::Vector3i dims;
  Eigen::Ref<Eigen::VectorXd> distance;
  Eigen::Ref<Eigen::VectorXi> bone;
  int threads = 0;  // the distances and the three axes' votes on this many threads (0: one per hardware
                    // thread); the same result on any number

  // At least one triangle, indices in range (naming the triangle), finite vertices (naming the vertex),
  // one bone per vertex, spacing > 0, every dimension >= 2, outputs of nx*ny*nz.
  Status Validate() const;
  void Run();
};

}  // namespace motionkit
