#include "motionkit/mirror.hpp"

#include <string>
#include <vector>

#include "so3.hpp"

namespace motionkit {

namespace {

std::string Bone(const RigModel& rig, int b) { return "'" + rig.name(b) + "'"; }

// The plane's reflection L, on orientations' turns (L D L) and on points.
class Reflection {
 public:
  Reflection(const Eigen::Vector3d& normal, const Eigen::Vector3d& point) : n_(normal.normalized()), c_(point) {}

  // L D L for D = (w, v): a half turn about n on either side keeps w and turns v by half a turn about n.
  Eigen::Quaterniond Turn(const Eigen::Quaterniond& q) const {
    const Eigen::Vector3d v = 2.0 * n_.dot(q.vec()) * n_ - q.vec();
    return Eigen::Quaterniond(q.w(), v.x(), v.y(), v.z());
  }

  Eigen::Vector3d Point(const Eigen::Vector3d& h) const { return h - 2.0 * (h - c_).dot(n_) * n_; }

 private:
  Eigen::Vector3d n_;
  Eigen::Vector3d c_;
};

// Poses the target frame by frame, parents first, keeping this frame's orientations and heads (what the
// children's channels are read against) in scratch sized once.
class MirrorPoser {
 public:
  explicit MirrorPoser(MirrorJob& job)
      : job_(job),
        reflection_(job.normal, job.point),
        globals_(static_cast<std::size_t>(job.target.size())),
        heads_(static_cast<std::size_t>(job.target.size())) {}

  void PoseFrame(Eigen::Index f) {
    const RigModel& target = job_.target;
    for (int b = 0; b < target.size(); ++b) {
      const int p = target.parent(b);
      const Eigen::Quaterniond parent = p < 0 ? Eigen::Quaterniond::Identity() : globals_[Index(p)];
      const Eigen::Vector3d parent_head = p < 0 ? Eigen::Vector3d::Zero() : heads_[Index(p)];
      const int partner = job_.partners[Index(b)];
      BoneChannels channels;
      if (partner >= 0) {
        const Eigen::Quaterniond turn =
            QuatAt(job_.source_rotations, f, partner).normalized() * job_.source.rest(partner).conjugate();
        globals_[Index(b)] = (reflection_.Turn(turn) * target.rest(b)).normalized();
        heads_[Index(b)] = reflection_.Point(SourceHead(f, partner));
        channels = UnposeBone(target, b, parent, parent_head, globals_[Index(b)], heads_[Index(b)]);
      } else {
        channels = KeptChannels(f, job_.kept[Index(b)]);
        const PosedBone posed = PoseBone(target, b, parent, parent_head, channels.basis, channels.location);
        globals_[Index(b)] = posed.global.normalized();
        heads_[Index(b)] = posed.head;
      }
      StoreContinuous(job_.rotations, f, b, channels.basis);
      job_.locations.row(f).segment<3>(3 * b) = channels.location.transpose();
    }
  }

 private:
  static std::size_t Index(int b) { return static_cast<std::size_t>(b); }

  Eigen::Vector3d SourceHead(Eigen::Index f, int a) const {
    return job_.source_heads.row(f).segment<3>(3 * a).transpose();
  }

  // Source bone a's own pose channels on frame f (the rest's for a < 0), read against its parent's pose.
  BoneChannels KeptChannels(Eigen::Index f, int a) const {
    if (a < 0) return {Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()};
    const int p = job_.source.parent(a);
    const Eigen::Quaterniond parent =
        p < 0 ? Eigen::Quaterniond::Identity() : QuatAt(job_.source_rotations, f, p).normalized();
    const Eigen::Vector3d parent_head = p < 0 ? Eigen::Vector3d::Zero() : SourceHead(f, p);
    return UnposeBone(job_.source, a, parent, parent_head, QuatAt(job_.source_rotations, f, a).normalized(),
                      SourceHead(f, a));
  }

  MirrorJob& job_;
  const Reflection reflection_;
  std::vector<Eigen::Quaterniond> globals_;
  std::vector<Eigen::Vector3d> heads_;
};

Status ValidateBoneList(const std::vector<int>& list, const RigModel& source, const RigModel& target,
                        const char* what) {
  if (list.size() != static_cast<std::size_t>(target.size())) {
    return Status::Fail(std::string("mirror: ") + what + " needs one entry per target bone (" +
                        std::to_string(target.size()) + "), got " + std::to_string(list.size()));
  }
  for (int b = 0; b < target.size(); ++b) {
    const int a = list[static_cast<std::size_t>(b)];
    if (a < -1 || a >= source.size()) {
      return Status::Fail(std::string("mirror: ") + what + " of target bone " + Bone(target, b) +
                          " is source index " + std::to_string(a) + ", out of range");
    }
  }
  return Status::Ok();
}

}  // namespace

Status MirrorJob::Validate() const {
  const Eigen::Index frames = source_rotations.rows(), ns = source.size(), nt = target.size();
  if (source_rotations.cols() != 4 * ns || source_heads.rows() != frames || source_heads.cols() != 3 * ns) {
    return Status::Fail("mirror: source rotations and heads must be frames x 4 and frames x 3 per source bone");
  }
  if (rotations.rows() != frames || rotations.cols() != 4 * nt || locations.rows() != frames ||
      locations.cols() != 3 * nt) {
    return Status::Fail("mirror: outputs must be frames x 4 and frames x 3 per target bone");
  }
  for (const Status& status : {ValidateBoneList(partners, source, target, "partners"),
                               ValidateBoneList(kept, source, target, "kept")}) {
    if (!status) return status;
  }
  if (!normal.allFinite() || normal.norm() < 1e-12 || !point.allFinite()) {
    return Status::Fail("mirror: the plane needs a finite, non-zero normal and a finite point");
  }
  for (Eigen::Index f = 0; f < frames; ++f) {
    for (int a = 0; a < ns; ++a) {
      if (!internal::IsRotationQuaternion(QuatAt(source_rotations, f, a)) ||
          !source_heads.row(f).segment<3>(3 * a).allFinite()) {
        return Status::Fail("mirror: source bone " + Bone(source, a) +
                            " has a zero or non-finite rotation or head at frame index " + std::to_string(f));
      }
    }
  }
  return Status::Ok();
}

void MirrorJob::Run() {
  Validate().ThrowIfFailed();
  MirrorPoser poser(*this);
  for (Eigen::Index f = 0; f < source_rotations.rows(); ++f) poser.PoseFrame(f);
}

}  // namespace motionkit
