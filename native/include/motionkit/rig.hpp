// A Blender-style armature at rest, and its forward kinematics.
//
// Unlike a BVH skeleton, a bone has a rest orientation of its own (its Y axis
// runs head to tail, rolled about itself) and its pose is stored relative to
// that rest frame. With Rest_b the rest orientation and H_b the rest head in
// armature space (bone.matrix_local), a bone's posed orientation and head are
//   G_b    = G_p Rest_p^-1 Rest_b basis_b
//   head_b = head_p + G_p Rest_p^-1 (H_b - H_p + Rest_b loc_b)
// (a root: G_b = Rest_b basis_b, head_b = H_b + Rest_b loc_b), which is what
// Blender's pose_bone.matrix holds for bones that inherit rotation and have
// unit scale. Quaternions are (w, x, y, z) in arrays.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "motionkit/error.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

// Const after construction; bones depth-first (every parent index smaller
// than its children's), as ozz and Pinocchio keep their models.
class RigModel {
 public:
  RigModel(std::vector<std::string> names, std::vector<int> parents, const RowMatrixXd& rest_rotations,
           const RowMatrixXd& rest_heads, const Eigen::VectorXd& lengths);

  // Names unique and non-empty, parents before children, rest rotations
  // finite and unit (to 1e-3; they are normalised), heads finite, lengths finite and positive.
  Status Validate() const;

  int size() const { return static_cast<int>(parents_.size()); }
  const std::string& name(int bone) const { return names_[static_cast<std::size_t>(bone)]; }
  int parent(int bone) const { return parents_[static_cast<std::size_t>(bone)]; }
  const Eigen::Quaterniond& rest(int bone) const { return rest_[static_cast<std::size_t>(bone)]; }
  const Eigen::Vector3d& head(int bone) const { return heads_[static_cast<std::size_t>(bone)]; }
  double length(int bone) const { return lengths_[static_cast<std::size_t>(bone)]; }
  // Rest_p^-1 Rest_b (Rest_b for a root): the bone's rest relative to its parent.
  const Eigen::Quaterniond& relative(int bone) const { return relative_[static_cast<std::size_t>(bone)]; }
  // Rest_p^-1 (H_b - H_p) (H_b for a root): the head in the parent's rest frame.
  const Eigen::Vector3d& offset(int bone) const { return offset_[static_cast<std::size_t>(bone)]; }
  // True when `ancestor` is `bone` or above it.
  bool IsAncestor(int ancestor, int bone) const;
  int Find(const std::string& name) const;

 private:
  std::vector<std::string> names_;
  std::vector<int> parents_;
  std::vector<Eigen::Quaterniond> rest_;
  std::vector<Eigen::Vector3d> heads_;
  std::vector<double> lengths_;
  std::vector<Eigen::Quaterniond> relative_;
  std::vector<Eigen::Vector3d> offset_;
};

// The rig's forward kinematics, one bone at a time: the one recurrence that the
// armature pose job, the IK solver and the retarget job all use. Under its
// parent's posed orientation `parent` (identity for a root) the bone's rest
// frame is parent * relative(b); its head is parent_head + parent * offset(b)
// (offset's Y scaled by the parent's length scale, 1 but for IK's stretching
// bones) + frame * location (the bone's location channel); its orientation
// is frame * basis (its pose rotation). For a root, parent_head is zero.
inline Eigen::Quaterniond RestFrame(const RigModel& rig, int b, const Eigen::Quaterniond& parent) {
  return parent * rig.relative(b);
}

struct PosedBone {
  Eigen::Quaterniond frame;   // RestFrame: the bone at rest under its posed parent
  Eigen::Quaterniond global;  // frame * basis: its posed orientation (not normalised)
  Eigen::Vector3d head;
};

inline PosedBone PoseBone(const RigModel& rig, int b, const Eigen::Quaterniond& parent,
                          const Eigen::Vector3d& parent_head, const Eigen::Quaterniond& basis,
                          const Eigen::Vector3d& location, double parent_scale = 1.0) {
  PosedBone out;
  out.frame = RestFrame(rig, b, parent);
  Eigen::Vector3d offset = rig.offset(b);
  offset.y() *= parent_scale;
  out.head = parent_head + parent * offset + out.frame * location;
  out.global = out.frame * basis;
  return out;
}

// PoseBone backwards (unit parent scale): the pose channels that put bone b at orientation `global` with
// its head at `head`, under its parent posed at (parent, parent_head).
struct BoneChannels {
  Eigen::Quaterniond basis;
  Eigen::Vector3d location;
};

inline BoneChannels UnposeBone(const RigModel& rig, int b, const Eigen::Quaterniond& parent,
                               const Eigen::Vector3d& parent_head, const Eigen::Quaterniond& global,
                               const Eigen::Vector3d& head) {
  const Eigen::Quaterniond frame = RestFrame(rig, b, parent);
  const Eigen::Vector3d anchor = parent_head + parent * rig.offset(b);
  return {(frame.conjugate() * global).normalized(), frame.conjugate() * (head - anchor)};
}

// Pose channels of every bone and frame to armature-space orientations and
// heads. Caller-owned buffers; Run() allocates nothing.
//   basis_rotations: frames x 4B, any non-zero length (normalised)
//   basis_locations: frames x 3B, or 0 columns for none
//   rotations:       frames x 4B out, unit, G_b
//   heads:           frames x 3B out
struct ArmaturePoseJob {
  ArmaturePoseJob(const RigModel& rig_in, ConstMatrixView basis_rotations_in,
                  ConstMatrixView basis_locations_in, Eigen::Ref<RowMatrixXd> rotations_out,
                  Eigen::Ref<RowMatrixXd> heads_out)
      : rig(rig_in),
        basis_rotations(basis_rotations_in),
        basis_locations(basis_locations_in),
        rotations(rotations_out),
        heads(heads_out) {}

  const RigModel& rig;
  ConstMatrixView basis_rotations;
  ConstMatrixView basis_locations;
  Eigen::Ref<RowMatrixXd> rotations;
  Eigen::Ref<RowMatrixXd> heads;
  int threads = 0;  // 0: one per hardware thread; the result is the same on any number

  // Shapes agree and every input is finite with non-zero quaternions, else
  // names the bone and frame.
  Status Validate() const;
  void Run();

  // Frames a thread takes at a time: enough that starting a block costs nothing beside it.
  static constexpr Eigen::Index kFramesPerBlock = 512;

 private:
  void PoseFrame(Eigen::Index f);
};

// Quaternion row helpers shared by the rig jobs.
inline Eigen::Quaterniond QuatAt(const ConstMatrixView& m, Eigen::Index row, Eigen::Index bone) {
  const double* p = m.data() + row * m.outerStride() + 4 * bone;
  return Eigen::Quaterniond(p[0], p[1], p[2], p[3]);
}
inline void StoreQuat(Eigen::Ref<RowMatrixXd>& m, Eigen::Index row, Eigen::Index bone,
                      const Eigen::Quaterniond& q) {
  double* p = m.data() + row * m.outerStride() + 4 * bone;
  p[0] = q.w();
  p[1] = q.x();
  p[2] = q.y();
  p[3] = q.z();
}

// Stores q in the hemisphere of row f - 1's quaternion of the same bone (row 0: w >= 0), so that each
// bone's curves stay continuous from frame to frame.
// q stored on row f, on the side of row f - 1's quaternion (continuous, as Blender's curves are best keyed),
// row `first` (default 0) with w >= 0. Rows from `first` on may be written apart from the rows before
// (MakeContinuousAcross then joins them).
inline void StoreContinuous(Eigen::Ref<RowMatrixXd>& m, Eigen::Index f, Eigen::Index bone, Eigen::Quaterniond q,
                            Eigen::Index first = 0) {
  if (f > first) {
    const double* previous = m.data() + (f - 1) * m.outerStride() + 4 * bone;
    const double dot = previous[0] * q.w() + previous[1] * q.x() + previous[2] * q.y() + previous[3] * q.z();
    if (dot < 0) q.coeffs() = -q.coeffs();
  } else if (q.w() < 0) {
    q.coeffs() = -q.coeffs();
  }
  StoreQuat(m, f, bone, q);
}

// Rows [first, end) written continuous among themselves (StoreContinuous from `first`) made continuous with
// row first - 1 too: each bone's run negated where it starts on the other side, exactly as one pass over
// every row would have stored it.
inline void MakeContinuousAcross(Eigen::Ref<RowMatrixXd>& m, Eigen::Index first, Eigen::Index end) {
  if (first <= 0 || first >= end) return;
  for (Eigen::Index bone = 0; 4 * bone < m.cols(); ++bone) {
    const double* previous = m.data() + (first - 1) * m.outerStride() + 4 * bone;
    const double* q = m.data() + first * m.outerStride() + 4 * bone;
    if (previous[0] * q[0] + previous[1] * q[1] + previous[2] * q[2] + previous[3] * q[3] >= 0) continue;
    for (Eigen::Index f = first; f < end; ++f) m.row(f).segment<4>(4 * bone) *= -1.0;
  }
}

}  // namespace motionkit
