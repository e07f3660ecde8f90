#include "motionkit/rig.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <thread>
#include <unordered_set>
#include <utility>

#include "parallel.hpp"
#include "so3.hpp"

namespace motionkit {

namespace {

std::string Bone(const RigModel& rig, int b) { return "bone '" + rig.name(b) + "'"; }

}  // namespace

RigModel::RigModel(std::vector<std::string> names, std::vector<int> parents, const RowMatrixXd& rest_rotations,
                   const RowMatrixXd& rest_heads, const Eigen::VectorXd& lengths)
    : names_(std::move(names)), parents_(std::move(parents)) {
  const auto n = parents_.size();
  const bool shapes = names_.size() == n && static_cast<std::size_t>(rest_rotations.rows()) == n &&
                      rest_rotations.cols() == 4 && static_cast<std::size_t>(rest_heads.rows()) == n &&
                      rest_heads.cols() == 3 && static_cast<std::size_t>(lengths.size()) == n;
  if (!shapes) {
    throw Error("rig: expected names, parents and lengths of one size n, rest rotations n x 4 and heads n x 3");
  }
  for (std::size_t b = 0; b < n; ++b) {
    const auto i = static_cast<Eigen::Index>(b);
    rest_.emplace_back(rest_rotations(i, 0), rest_rotations(i, 1), rest_rotations(i, 2), rest_rotations(i, 3));
    heads_.emplace_back(rest_heads.row(i).transpose());
    lengths_.push_back(lengths[i]);
  }
  const Status status = Validate();
  status.ThrowIfFailed();
  relative_.resize(n);
  offset_.resize(n);
  for (std::size_t b = 0; b < n; ++b) {
    rest_[b].normalize();
    const int p = parents_[b];
    if (p < 0) {
      relative_[b] = rest_[b];
      offset_[b] = heads_[b];
    } else {
      const auto pp = static_cast<std::size_t>(p);
      relative_[b] = (rest_[pp].conjugate() * rest_[b]).normalized();
      offset_[b] = rest_[pp].conjugate() * (heads_[b] - heads_[pp]);
    }
  }
}

Status RigModel::Validate() const {
  std::unordered_set<std::string> seen;
  for (int b = 0; b < size(); ++b) {
    const std::string& n = name(b);
    if (n.empty()) return Status::Fail("rig: bone " + std::to_string(b) + " has no name");
    if (!seen.insert(n).second) return Status::Fail("rig: two bones are named '" + n + "'");
    const int p = parent(b);
    if (p >= b || p < -1) {
      return Status::Fail("rig: " + Bone(*this, b) + " comes before its parent (bones must be parents first)");
    }
    const Eigen::Quaterniond& q = rest(b);
    // Blender's float32 bone matrices give rest quaternions unit only to a
    // few 1e-6; they are normalised here, so only garbage is refused.
    if (!internal::IsUnitQuaternion(q, 1e-3)) {
      return Status::Fail("rig: the rest rotation of " + Bone(*this, b) + " is not a unit quaternion");
    }
    if (!head(b).allFinite()) return Status::Fail("rig: the head of " + Bone(*this, b) + " is not finite");
    if (!(std::isfinite(length(b)) && length(b) > 0.0)) {
      return Status::Fail("rig: " + Bone(*this, b) + " has length " + std::to_string(length(b)));
    }
  }
  return Status::Ok();
}

bool RigModel::IsAncestor(int ancestor, int bone) const {
  for (int b = bone; b >= 0; b = parent(b)) {
    if (b == ancestor) return true;
  }
  return false;
}

int RigModel::Find(const std::string& n) const {
  for (int b = 0; b < size(); ++b) {
    if (name(b) == n) return b;
  }
  return -1;
}

Status ArmaturePoseJob::Validate() const {
  const Eigen::Index bones = rig.size(), frames = basis_rotations.rows();
  if (basis_rotations.cols() != 4 * bones) {
    return Status::Fail("armature pose: basis rotations need 4 columns per bone (" + std::to_string(4 * bones) +
                        "), got " + std::to_string(basis_rotations.cols()));
  }
  if (basis_locations.cols() != 0 && (basis_locations.cols() != 3 * bones || basis_locations.rows() != frames)) {
    return Status::Fail("armature pose: basis locations must be frames x 3 per bone, or have no columns");
  }
  if (rotations.rows() != frames || rotations.cols() != 4 * bones || heads.rows() != frames ||
      heads.cols() != 3 * bones) {
    return Status::Fail("armature pose: outputs must be frames x 4 per bone and frames x 3 per bone");
  }
  for (Eigen::Index f = 0; f < frames; ++f) {
    for (int b = 0; b < bones; ++b) {
      bool ok = internal::IsRotationQuaternion(QuatAt(basis_rotations, f, b));
      if (ok && basis_locations.cols() != 0) ok = basis_locations.row(f).segment<3>(3 * b).allFinite();
      if (!ok) {
        return Status::Fail("armature pose: " + Bone(rig, b) + " at frame index " + std::to_string(f) +
                            " has a zero or non-finite rotation or location");
      }
    }
  }
  return Status::Ok();
}

void ArmaturePoseJob::Run() {
  Validate().ThrowIfFailed();
  const Eigen::Index frames = basis_rotations.rows();
  // No frame depends on another: blocks of frames on threads, each frame computed as on one thread.
  const int blocks = static_cast<int>((frames + kFramesPerBlock - 1) / kFramesPerBlock);
  const int workers = threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  internal::ParallelFor(blocks, workers, [&](int block) {
    const Eigen::Index first = static_cast<Eigen::Index>(block) * kFramesPerBlock;
    for (Eigen::Index f = first; f < std::min(frames, first + kFramesPerBlock); ++f) PoseFrame(f);
  });
}

void ArmaturePoseJob::PoseFrame(Eigen::Index f) {
  const int bones = rig.size();
  const bool located = basis_locations.cols() != 0;
  double* rot = rotations.data() + f * rotations.outerStride();
  double* pos = heads.data() + f * heads.outerStride();
  for (int b = 0; b < bones; ++b) {
    const int p = rig.parent(b);
    const double* pr = rot + 4 * p;
    const Eigen::Quaterniond parent =
        p >= 0 ? Eigen::Quaterniond(pr[0], pr[1], pr[2], pr[3]) : Eigen::Quaterniond::Identity();
    const Eigen::Vector3d parent_head =
        p >= 0 ? Eigen::Vector3d(Eigen::Map<const Eigen::Vector3d>(pos + 3 * p)) : Eigen::Vector3d::Zero();
    const Eigen::Vector3d location = located ? Eigen::Vector3d(basis_locations.row(f).segment<3>(3 * b).transpose())
                                             : Eigen::Vector3d::Zero();
    const PosedBone posed =
        PoseBone(rig, b, parent, parent_head, QuatAt(basis_rotations, f, b).normalized(), location);
    const Eigen::Quaterniond g = posed.global.normalized();
    const Eigen::Vector3d& head = posed.head;
    rot[4 * b] = g.w();
    rot[4 * b + 1] = g.x();
    rot[4 * b + 2] = g.y();
    rot[4 * b + 3] = g.z();
    Eigen::Map<Eigen::Vector3d>(pos + 3 * b) = head;
  }
}

}  // namespace motionkit
