#include "motionkit/bvh_pose.hpp"

#include <cmath>
#include <string>
#include <vector>

#include "motionkit/rotation.hpp"
#include "so3.hpp"

namespace motionkit {
namespace {

constexpr double kDegrees = 180.0 / 3.14159265358979323846;

Eigen::Quaterniond QuatAt(const ConstMatrixView& m, Eigen::Index row, Eigen::Index joint) {
  const double* q = m.row(row).data() + 4 * joint;
  return Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
}

// The intrinsic Euler order a joint's rotation channels spell, completed with
// the missing axes (in X, Y, Z order) when it lists fewer than three.
EulerOrder JointEulerOrder(const Joint& joint, int* rotation_count) {
  char letters[4] = {0, 0, 0, 0};
  int n = 0;
  bool used[3] = {false, false, false};
  for (int c = 0; c < joint.channel_count; ++c) {
    const ChannelType type = joint.channels[static_cast<std::size_t>(c)];
    if (IsRotation(type) && !used[ChannelAxis(type)] && n < 3) {
      used[ChannelAxis(type)] = true;
      letters[n++] = static_cast<char>('X' + ChannelAxis(type));
    }
  }
  *rotation_count = n;
  for (int a = 0; a < 3 && n < 3; ++a) {
    if (!used[a]) letters[n++] = static_cast<char>('X' + a);
  }
  return *ParseEulerOrder(std::string_view(letters, 3));
}

Status CheckCommon(const Skeleton& skeleton, const ConstMatrixView& bone_rest,
                   const Eigen::Quaterniond& conversion, double scale) {
  if (Status s = skeleton.Validate(); !s) return s;
  const auto joints = static_cast<Eigen::Index>(skeleton.joints.size());
  if (bone_rest.rows() != joints || bone_rest.cols() != 4) {
    return Status::Fail("bvh pose: bone_rest must be " + std::to_string(joints) + " x 4, got " +
                        std::to_string(bone_rest.rows()) + " x " + std::to_string(bone_rest.cols()));
  }
  for (Eigen::Index j = 0; j < joints; ++j) {
    if (!skeleton.joints[static_cast<std::size_t>(j)].end_site &&
        !internal::IsUnitQuaternion(QuatAt(bone_rest, j, 0), 1e-6)) {
      return Status::Fail("bvh pose: rest orientation of '" +
                          skeleton.joints[static_cast<std::size_t>(j)].name +
                          "' is not a unit quaternion");
    }
  }
  if (!internal::IsUnitQuaternion(conversion, 1e-6)) {  // float32 sources (mathutils) welcome
    return Status::Fail("bvh pose: the axis conversion is not a unit quaternion");
  }
  if (!(std::isfinite(scale) && scale > 0.0)) {
    return Status::Fail("bvh pose: scale must be positive and finite");
  }
  return Status::Ok();
}

// Per joint, B_i^-1 C (from BVH space to the bone's rest frame) and its inverse C^-1 B_i: the constant
// halves of the maps between a joint's channels and its bone's pose, computed once rather than per frame.
struct RestConversions {
  std::vector<Eigen::Quaterniond> to_bone, to_bvh;
};

RestConversions ConvertRests(const ConstMatrixView& bone_rest, const Eigen::Quaterniond& conversion) {
  const Eigen::Quaterniond c = conversion.normalized();
  const auto joints = static_cast<std::size_t>(bone_rest.rows());
  RestConversions rests{std::vector<Eigen::Quaterniond>(joints), std::vector<Eigen::Quaterniond>(joints)};
  for (std::size_t j = 0; j < joints; ++j) {
    const Eigen::Quaterniond b = QuatAt(bone_rest, static_cast<Eigen::Index>(j), 0).normalized();
    rests.to_bone[j] = b.conjugate() * c;
    rests.to_bvh[j] = c.conjugate() * b;
  }
  return rests;
}

std::string Shape(Eigen::Index rows, Eigen::Index cols) {
  return std::to_string(rows) + " x " + std::to_string(cols);
}

// `what` (an input or output of the jobs) shaped rows x cols, else a failure saying which shape it has.
template <class Matrix>
Status CheckShape(const char* what, const Matrix& m, Eigen::Index rows, Eigen::Index cols) {
  if (m.rows() == rows && m.cols() == cols) return Status::Ok();
  return Status::Fail(std::string("bvh pose: ") + what + " must be " + Shape(rows, cols) + ", got " +
                      Shape(m.rows(), m.cols()));
}

}  // namespace

Status BvhToPoseJob::Validate() const {
  if (Status s = CheckCommon(skeleton, bone_rest, conversion, scale); !s) return s;
  const Eigen::Index frames = values.rows();
  const auto joints = static_cast<Eigen::Index>(skeleton.joints.size());
  if (values.cols() != skeleton.channel_count) {
    return Status::Fail("bvh pose: values have " + std::to_string(values.cols()) +
                        " columns but the skeleton has " + std::to_string(skeleton.channel_count) +
                        " channels");
  }
  if (Status s = CheckShape("rotations", rotations, frames, 4 * joints); !s) return s;
  if (Status s = CheckShape("locations", locations, frames, 3 * joints); !s) return s;
  for (Eigen::Index f = 0; f < frames; ++f) {
    for (const Joint& joint : skeleton.joints) {
      for (int c = 0; c < joint.channel_count; ++c) {
        if (!std::isfinite(values(f, joint.first_channel + c))) {
          return Status::Fail("bvh pose: frame " + std::to_string(f) + ", joint '" + joint.name +
                              "' channel " + ChannelName(joint.channels[static_cast<std::size_t>(c)]) +
                              " is not finite");
        }
      }
    }
  }
  return Status::Ok();
}

void BvhToPoseJob::Run() {
  Validate().ThrowIfFailed();
  // M_i = (B_i^-1 C) R_i (C^-1 B_i), and the location map s B_i^-1 C.
  const RestConversions rests = ConvertRests(bone_rest, conversion);
  const std::size_t joints = skeleton.joints.size();
  std::vector<Eigen::Matrix3d> to_location(joints);
  for (std::size_t j = 0; j < joints; ++j) to_location[j] = scale * rests.to_bone[j].toRotationMatrix();
  for (Eigen::Index f = 0; f < values.rows(); ++f) {
    const double* row = values.row(f).data();
    double* rot_out = rotations.row(f).data();
    double* loc_out = locations.row(f).data();
    for (std::size_t j = 0; j < joints; ++j) {
      const Joint& joint = skeleton.joints[j];
      double* q_out = rot_out + 4 * j;
      double* l_out = loc_out + 3 * j;
      if (joint.end_site) {
        q_out[0] = 1.0;
        q_out[1] = q_out[2] = q_out[3] = 0.0;
        l_out[0] = l_out[1] = l_out[2] = 0.0;
        continue;
      }
      // R_i as a product of axis rotations, each (cos h, sin h e_axis).
      double w = 1.0, x = 0.0, y = 0.0, z = 0.0;
      Eigen::Vector3d t = joint.offset;
      bool moved = false;
      for (int ch = 0; ch < joint.channel_count; ++ch) {
        const ChannelType type = joint.channels[static_cast<std::size_t>(ch)];
        const double v = row[joint.first_channel + ch];
        const int axis = ChannelAxis(type);
        if (!IsRotation(type)) {
          t[axis] = v;
          moved = true;
          continue;
        }
        const double half = 0.5 * v / kDegrees;
        const double ch_cos = std::cos(half), ch_sin = std::sin(half);
        // (w, x, y, z) * (ch_cos, ch_sin e_axis)
        double nw, nx, ny, nz;
        if (axis == 0) {
          nw = w * ch_cos - x * ch_sin; nx = x * ch_cos + w * ch_sin;
          ny = y * ch_cos + z * ch_sin; nz = z * ch_cos - y * ch_sin;
        } else if (axis == 1) {
          nw = w * ch_cos - y * ch_sin; nx = x * ch_cos - z * ch_sin;
          ny = y * ch_cos + w * ch_sin; nz = z * ch_cos + x * ch_sin;
        } else {
          nw = w * ch_cos - z * ch_sin; nx = x * ch_cos + y * ch_sin;
          ny = y * ch_cos - x * ch_sin; nz = z * ch_cos + w * ch_sin;
        }
        w = nw; x = nx; y = ny; z = nz;
      }
      Eigen::Quaterniond m = rests.to_bone[j] * Eigen::Quaterniond(w, x, y, z) * rests.to_bvh[j];
      const double sign = m.w() < 0.0 ? -1.0 : 1.0;  // one hemisphere: continuous curves
      q_out[0] = sign * m.w();
      q_out[1] = sign * m.x();
      q_out[2] = sign * m.y();
      q_out[3] = sign * m.z();
      if (moved) {
        Eigen::Map<Eigen::Vector3d> location(l_out);
        location = to_location[j] * (t - joint.offset);
      } else {
        l_out[0] = l_out[1] = l_out[2] = 0.0;
      }
    }
  }
}

Status PoseToBvhJob::Validate() const {
  if (Status s = CheckCommon(skeleton, bone_rest, conversion, scale); !s) return s;
  const Eigen::Index frames = rotations.rows();
  const auto joints = static_cast<Eigen::Index>(skeleton.joints.size());
  if (rotations.cols() != 4 * joints) {
    return Status::Fail("bvh pose: rotations must have " + std::to_string(4 * joints) +
                        " columns, got " + std::to_string(rotations.cols()));
  }
  if (Status s = CheckShape("locations", locations, frames, 3 * joints); !s) return s;
  if (Status s = CheckShape("values", values, frames, skeleton.channel_count); !s) return s;
  for (Eigen::Index f = 0; f < frames; ++f) {
    for (std::size_t j = 0; j < skeleton.joints.size(); ++j) {
      const auto jj = static_cast<Eigen::Index>(j);
      const Joint& joint = skeleton.joints[j];
      if (joint.end_site) continue;
      const bool finite = rotations.row(f).segment<4>(4 * jj).allFinite() &&
                          locations.row(f).segment<3>(3 * jj).allFinite();
      if (!finite) {
        return Status::Fail("bvh pose: frame " + std::to_string(f) + ", bone '" + joint.name +
                            "' has a non-finite rotation or location");
      }
      if (!internal::IsRotationQuaternion(rotations.row(f).segment<4>(4 * jj))) {
        return Status::Fail("bvh pose: frame " + std::to_string(f) + ", bone '" + joint.name +
                            "' has a zero quaternion");
      }
    }
  }
  return Status::Ok();
}

void PoseToBvhJob::Run() {
  Validate().ThrowIfFailed();
  // R_i = (C^-1 B_i) M_i (B_i^-1 C), and the location map C^-1 B_i / s.
  const RestConversions rests = ConvertRests(bone_rest, conversion);
  const std::size_t joints = skeleton.joints.size();
  std::vector<Eigen::Matrix3d> to_translation(joints);
  std::vector<EulerOrder> orders(joints);
  std::vector<int> rotation_counts(joints);
  for (std::size_t j = 0; j < joints; ++j) {
    to_translation[j] = rests.to_bvh[j].toRotationMatrix() / scale;
    orders[j] = JointEulerOrder(skeleton.joints[j], &rotation_counts[j]);
  }
  // Previous frame's angles per joint, for continuity; the first frame is
  // made compatible with zero, as a rest pose would be.
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> previous =
      Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>::Zero(
          static_cast<Eigen::Index>(skeleton.joints.size()), 3);
  for (Eigen::Index f = 0; f < rotations.rows(); ++f) {
    double* row = values.row(f).data();
    for (std::size_t j = 0; j < skeleton.joints.size(); ++j) {
      const Joint& joint = skeleton.joints[j];
      if (joint.end_site || joint.channel_count == 0) continue;
      const auto jj = static_cast<Eigen::Index>(j);
      const Eigen::Quaterniond m = QuatAt(rotations, f, jj).normalized();
      const Eigen::Quaterniond r = rests.to_bvh[j] * m * rests.to_bone[j];
      const Eigen::Vector3d l = locations.row(f).segment<3>(3 * jj).transpose();
      const Eigen::Vector3d t = joint.offset + to_translation[j] * l;
      Eigen::Vector3d angles = Eigen::Vector3d::Zero();
      if (rotation_counts[j] > 0) {
        angles = MatrixToEulerCompatible(r.toRotationMatrix(), orders[j],
                                         previous.row(jj).transpose());
        previous.row(jj) = angles.transpose();
      }
      int k = 0;
      bool seen[3] = {false, false, false};
      for (int ch = 0; ch < joint.channel_count; ++ch) {
        const ChannelType type = joint.channels[static_cast<std::size_t>(ch)];
        double& out = row[joint.first_channel + ch];
        if (!IsRotation(type)) {
          out = t[ChannelAxis(type)];
        } else if (!seen[ChannelAxis(type)] && k < 3) {
          seen[ChannelAxis(type)] = true;
          out = angles[k++] * kDegrees;
        } else {
          out = 0.0;  // a repeated rotation axis carries nothing more
        }
      }
    }
  }
}

}  // namespace motionkit
