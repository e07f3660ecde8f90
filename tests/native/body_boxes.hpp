// Boxes for the body tests: a mesh, its exact signed distance, and its field as BodyFieldJob builds it.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <utility>
#include <vector>

#include "motionkit/body_field.hpp"
#include "motionkit/types.hpp"

namespace motionkit::testing_boxes {

using TriangleMatrix = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

struct Mesh {
  RowMatrixXd vertices;
  TriangleMatrix triangles;
};

// An axis-aligned box from -h to h, its faces wound outwards.
inline Mesh Box(const Eigen::Vector3d& h) {
  Mesh m{RowMatrixXd(8, 3), TriangleMatrix(12, 3)};
  for (int v = 0; v < 8; ++v) {
    m.vertices.row(v) << ((v & 1) ? h.x() : -h.x()), ((v & 2) ? h.y() : -h.y()), ((v & 4) ? h.z() : -h.z());
  }
  m.triangles << 0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5,
      3, 7, 5;
  return m;
}

inline double BoxDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& h) {
  const Eigen::Vector3d q = p.cwiseAbs() - h;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

struct Field {
  Eigen::VectorXd distance;
  Eigen::VectorXi bone;
  Eigen::Vector3d origin;
  double spacing;
  Eigen::Vector3i dims;
  Eigen::Vector3d Centre(Eigen::Index cell) const {
    const Eigen::Index k = cell % dims.z(), j = (cell / dims.z()) % dims.y(), i = cell / (dims.z() * dims.y());
    return origin + spacing * Eigen::Vector3d(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
  }
};

inline Field Build(const Mesh& m, std::vector<int> bones, double spacing, double reach) {
  const Eigen::Vector3d low = m.vertices.colwise().minCoeff().transpose().array() - reach;
  const Eigen::Vector3d high = m.vertices.colwise().maxCoeff().transpose().array() + reach;
  Field f;
  f.origin = low;
  f.spacing = spacing;
  f.dims = ((high - low) / spacing).array().ceil().cast<int>() + 1;
  f.distance.resize(f.dims.prod());
  f.bone.resize(f.dims.prod());
  BodyFieldJob job(m.vertices, m.triangles, std::move(bones), f.origin, spacing, f.dims, f.distance, f.bone);
  job.Run();
  return f;
}

}  // namespace motionkit::testing_boxes
