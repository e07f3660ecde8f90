// Reading the body's field where its bones have moved it (native/include/motionkit/body_sample.hpp).
#include "motionkit/body_sample.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <string>

namespace motionkit {
namespace {

struct Reading {
  double distance;
  int owner;
  Eigen::Vector3d slope;  // in the rest space
};

// The trilinear distance (and its gradient) at rest point p where bone owns the nearest cell; +inf and -1
// off the grid or where another bone owns it (looked at first: most carriers own few of a point's cells).
Reading Read(const BodySampleJob& job, const Eigen::Vector3d& p, int bone) {
  const Eigen::Vector3d x = (p - job.origin) / job.spacing;
  const Eigen::Vector3d last = (job.dims.cast<double>().array() - 1.0).matrix();
  const Reading none{std::numeric_limits<double>::infinity(), -1, Eigen::Vector3d::Zero()};
  if ((x.array() < 0.0).any() || (x.array() > last.array()).any()) return none;
  const Eigen::Vector3i near = (x.array() + 0.5).floor().cast<int>().matrix();
  const Eigen::Index at = (static_cast<Eigen::Index>(near.x()) * job.dims.y() + near.y()) * job.dims.z() + near.z();
  const int owner = job.owner[at];
  if (owner != bone) return none;
  Eigen::Vector3i i0;
  Eigen::Vector3d f;
  for (int a = 0; a < 3; ++a) {
    const double clipped = std::min(x[a], last[a] - 1e-9);
    i0[a] = static_cast<int>(std::floor(clipped));
    f[a] = clipped - i0[a];
  }
  const auto cell = [&](int i, int j, int k) {
    return (static_cast<Eigen::Index>(i) * job.dims.y() + j) * job.dims.z() + k;
  };
  double value = 0.0;
  Eigen::Vector3d slope = Eigen::Vector3d::Zero();
  for (int corner = 0; corner < 8; ++corner) {
    const int o[3] = {(corner >> 2) & 1, (corner >> 1) & 1, corner & 1};
    double factor[3];
    for (int a = 0; a < 3; ++a) factor[a] = o[a] ? f[a] : 1.0 - f[a];
    const double v = job.distance[cell(std::min(i0.x() + o[0], job.dims.x() - 1),
                                       std::min(i0.y() + o[1], job.dims.y() - 1),
                                       std::min(i0.z() + o[2], job.dims.z() - 1))];
    value += factor[0] * factor[1] * factor[2] * v;
    slope.x() += (o[0] ? 1.0 : -1.0) * factor[1] * factor[2] * v;
    slope.y() += (o[1] ? 1.0 : -1.0) * factor[0] * factor[2] * v;
    slope.z() += (o[2] ? 1.0 : -1.0) * factor[0] * factor[1] * v;
  }
  return {value, owner, slope / job.spacing};
}

Eigen::Quaterniond Quat(const ConstMatrixView& m, Eigen::Index row, Eigen::Index col) {
  return Eigen::Quaterniond(m(row, col), m(row, col + 1), m(row, col + 2), m(row, col + 3)).normalized();
}

}  // namespace

Status BodySampleJob::Validate() const {
  const Eigen::Index frames = points.rows(), count = points.cols() / 3;
  if (points.cols() % 3 != 0) return Status::Fail("body sample: points must be frames x 3N");
  if (distance.size() != static_cast<Eigen::Index>(dims.x()) * dims.y() * dims.z() || owner.size() != distance.size()) {
    return Status::Fail("body sample: the field's cells must number nx*ny*nz");
  }
  if (dims.minCoeff() < 2 || !(spacing > 0.0)) return Status::Fail("body sample: a grid of 2 or more cells a side");
  const Eigen::Index bones = orientations.cols() / 4;
  if (orientations.rows() != frames || heads.rows() != frames || heads.cols() != 3 * bones ||
      orientations.cols() != 4 * bones) {
    return Status::Fail("body sample: the pose must be frames x 4B orientations and frames x 3B heads");
  }
  const Eigen::Index k = static_cast<Eigen::Index>(carriers.size());
  if (carrier_rest.rows() != k || carrier_rest.cols() != 4 || carrier_heads.rows() != k || carrier_heads.cols() != 3) {
    return Status::Fail("body sample: one rest orientation and head per carrier");
  }
  for (int b : carriers) {
    if (b < 0 || b >= bones) return Status::Fail("body sample: carrier " + std::to_string(b) + " out of range");
  }
  if (read.rows() != frames || read.cols() != count ||
      (gradient.cols() != 0 && (gradient.rows() != frames || gradient.cols() != 3 * count))) {
    return Status::Fail("body sample: outputs of frames x N (and frames x 3N) expected");
  }
  for (Eigen::Index f = 0; f < frames; ++f) {
    for (Eigen::Index n = 0; n < count; ++n) {
      if (!points.block<1, 3>(f, 3 * n).allFinite()) {
        return Status::Fail("body sample: point " + std::to_string(n) + " at frame index " + std::to_string(f) +
                            " is not finite");
      }
    }
  }
  return Status::Ok();
}

void BodySampleJob::Run() {
  Validate().ThrowIfFailed();
  const Eigen::Index frames = points.rows(), count = points.cols() / 3;
  const bool slopes = gradient.cols() != 0;
  read.setConstant(std::numeric_limits<double>::infinity());
  if (slopes) gradient.setZero();
  for (Eigen::Index f = 0; f < frames; ++f) {
    for (std::size_t c = 0; c < carriers.size(); ++c) {
      const int b = carriers[c];
      const Eigen::Index row = static_cast<Eigen::Index>(c);
      const Eigen::Quaterniond to_rest = Quat(carrier_rest, row, 0) * Quat(orientations, f, 4 * b).conjugate();
      const Eigen::Vector3d head = heads.block<1, 3>(f, 3 * b).transpose();
      const Eigen::Vector3d rest_head = carrier_heads.row(row).transpose();
      for (Eigen::Index n = 0; n < count; ++n) {
        const Eigen::Vector3d p = points.block<1, 3>(f, 3 * n).transpose();
        const Reading r = Read(*this, to_rest * (p - head) + rest_head, b);
        if (r.owner != b || !(r.distance < read(f, n))) continue;
        read(f, n) = r.distance;
        if (slopes) gradient.block<1, 3>(f, 3 * n) = (to_rest.conjugate() * r.slope).transpose();
      }
    }
  }
}

}  // namespace motionkit
