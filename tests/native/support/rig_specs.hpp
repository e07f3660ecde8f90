// Rigs for the native tests and benchmarks, built from heads, tails and
// rolls the way Blender builds bones (the shortest turn of Y onto the bone,
// then the roll about it).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "motionkit/ik.hpp"
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

// A humanoid's natural defaults as the add-on sets them (addon/core/ik_defaults.py), by bone name: the
// limbs first, the spine (stage 1, stiffness 0.3) and the root (stage 2, stiffness 0.6) only while a
// target is out of their reach, soft ranges everywhere, the spine's, knees' and elbows' ranges.
inline std::vector<IkJoint> NaturalJoints(const RigModel& rig) {
  std::vector<IkJoint> joints(static_cast<std::size_t>(rig.size()));
  for (int b = 0; b < rig.size(); ++b) {
    IkJoint& j = joints[static_cast<std::size_t>(b)];
    const std::string& n = rig.name(b);
    j.soft = {{true, true, true}};
    if (b == 0) {
      j.stage = 2;
      j.stiffness = Eigen::Vector3d::Constant(0.6);
    } else if (n.rfind("spine", 0) == 0) {
      j.stage = 1;
      j.stiffness = Eigen::Vector3d::Constant(0.3);
      j.min = Eigen::Vector3d(-0.15, -0.2, -0.15);
      j.max = Eigen::Vector3d(0.35, 0.2, 0.15);
    } else if (n.rfind("shin", 0) == 0 || n.rfind("forearm", 0) == 0) {
      j.min = Eigen::Vector3d(0.0, -0.2, -0.1);
      j.max = Eigen::Vector3d(2.6, 0.2, 0.1);
    }
  }
  return joints;
}

// The options that go with them: DLS, the root free, balance, the prior 0.01 towards the input.
inline IkOptions NaturalOptions(double height) {
  IkOptions options;
  options.method = IkMethod::kDls;
  options.root_translation = true;
  options.root_rotation = true;
  options.tolerance = 4e-7 * height;  // 0.7 um on a person, as the default gives one
  options.balance = true;
  options.regularization = 1e-2;
  options.reference = IkReference::kInput;
  return options;
}

}  // namespace motionkit::test_rigs
