// Rigs for the native tests and benchmarks, built from heads, tails and
// rolls the way Blender builds bones (the shortest turn of Y onto the bone,
// then the roll about it).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "motionkit/rig.hpp"
#include "motionkit/types.hpp"

namespace motionkit::test_rigs {

struct BoneSpec {
  std::string name;
  int parent;
  Eigen::Vector3d head, tail;
  double roll = 0.0;
};

inline Eigen::Quaterniond RestOf(const BoneSpec& b) {
  const Eigen::Vector3d d = (b.tail - b.head).normalized();
  return (Eigen::AngleAxisd(b.roll, d) * Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitY(), d))
      .normalized();
}

inline RigModel MakeRig(const std::vector<BoneSpec>& bones) {
  const auto n = static_cast<Eigen::Index>(bones.size());
  std::vector<std::string> names;
  std::vector<int> parents;
  RowMatrixXd rest(n, 4), heads(n, 3);
  Eigen::VectorXd lengths(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const BoneSpec& b = bones[static_cast<std::size_t>(i)];
    names.push_back(b.name);
    parents.push_back(b.parent);
    const Eigen::Quaterniond q = RestOf(b);
    rest.row(i) << q.w(), q.x(), q.y(), q.z();
    heads.row(i) = b.head.transpose();
    lengths[i] = (b.tail - b.head).norm();
  }
  return RigModel(names, parents, rest, heads, lengths);
}

}  // namespace motionkit::test_rigs
