// Reading a body's field through one carrier bone's motion (body_read.hpp).
#include "body_read.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace motionkit {

Status BodyFieldView::Validate(Eigen::Index bones, const std::string& job) const {
  if (distance.size() != static_cast<Eigen::Index>(dims.x()) * dims.y() * dims.z() || owner.size() != distance.size()) {
    return Status::Fail(job + ": the field's cells must number nx*ny*nz");
  }
  if (dims.minCoeff() < 2 || !(spacing > 0.0)) return Status::Fail(job + ": a grid of 2 or more cells a side");
  const Eigen::Index k = static_cast<Eigen::Index>(carriers.size());
  if (carrier_rest.rows() != k || carrier_rest.cols() != 4 || carrier_heads.rows() != k || carrier_heads.cols() != 3) {
    return Status::Fail(job + ": one rest orientation and head per carrier");
  }
  if ((carrier_cells.rows() != 0 && carrier_cells.rows() != k) || (carrier_cells.rows() != 0 && carrier_cells.cols() != 6)) {
    return Status::Fail(job + ": carrier_cells must be K x 6 (or empty)");
  }
  for (int b : carriers) {
    if (b < 0 || b >= bones) return Status::Fail(job + ": carrier " + std::to_string(b) + " out of range");
  }
  return Status::Ok();
}

namespace internal {
namespace {

Eigen::Quaterniond Quat(const ConstMatrixView& m, Eigen::Index row, Eigen::Index col) {
  return Eigen::Quaterniond(m(row, col), m(row, col + 1), m(row, col + 2), m(row, col + 3)).normalized();
}

}  // namespace

CarrierMotion Motion(const BodyFieldView& field, std::size_t c, const ConstMatrixView& orientations,
                     const ConstMatrixView& heads, Eigen::Index frame) {
  const int b = field.carriers[c];
  const Eigen::Index row = static_cast<Eigen::Index>(c);
  CarrierMotion m{b,
                  Quat(field.carrier_rest, row, 0) * Quat(orientations, frame, 4 * b).conjugate(),
                  heads.block<1, 3>(frame, 3 * b).transpose(),
                  field.carrier_heads.row(row).transpose(),
                  Eigen::Vector3i::Zero(),
                  (field.dims.array() - 1).matrix(),
                  Eigen::Vector3d::Zero(),
                  std::numeric_limits<double>::infinity(),
                  Eigen::Matrix3d::Zero(),
                  Eigen::Vector3d::Zero()};
  // p's place in cells at rest, (to_rest (p - head) + rest_head - origin) / spacing, as one matrix and shift.
  m.to_cells = m.to_rest.toRotationMatrix() / field.spacing;
  m.shift = (m.rest_head - field.origin) / field.spacing - m.to_cells * m.head;
  if (field.carrier_cells.rows() != 0) {
    m.low = field.carrier_cells.block<1, 3>(row, 0).transpose();
    m.high = field.carrier_cells.block<1, 3>(row, 3).transpose();
    // The ball around the box's cells (half a cell beyond their centres: where a point's nearest cell is
    // one of them), posed: a point outside it is passed over before it is taken to rest.
    const Eigen::Vector3d low = field.origin + field.spacing * (m.low.cast<double>().array() - 0.5).matrix();
    const Eigen::Vector3d high = field.origin + field.spacing * (m.high.cast<double>().array() + 0.5).matrix();
    m.centre = m.to_rest.conjugate() * (0.5 * (low + high) - m.rest_head) + m.head;
    m.reach_squared = 0.25 * (high - low).squaredNorm();
  }
  return m;
}

double ReadThrough(const BodyFieldView& field, const CarrierMotion& motion, const Eigen::Vector3d& p,
                   Eigen::Vector3d* slope) {
  constexpr double kNone = std::numeric_limits<double>::infinity();
  if ((p - motion.centre).squaredNorm() > motion.reach_squared) return kNone;
  const Eigen::Vector3d x = motion.to_cells * p + motion.shift;
  const Eigen::Vector3i& dims = field.dims;
  if ((x.array() < 0.0).any() || (x.array() > (dims.cast<double>().array() - 1.0)).any()) return kNone;
  // The nearest cell's owner is looked at first: most carriers own few of a point's cells.
  const Eigen::Vector3i near = (x.array() + 0.5).floor().cast<int>().matrix();
  if ((near.array() < motion.low.array()).any() || (near.array() > motion.high.array()).any()) return kNone;
  const Eigen::Index nz = dims.z(), nyz = static_cast<Eigen::Index>(dims.y()) * nz;
  if (field.owner[near.x() * nyz + near.y() * nz + near.z()] != motion.bone) return kNone;
  // The cell below x along each axis, at most the one before the last: its neighbour above is on the grid.
  Eigen::Vector3i i0;
  Eigen::Vector3d f;
  for (int a = 0; a < 3; ++a) {
    const double clipped = std::min(x[a], dims[a] - 1 - 1e-9);
    i0[a] = static_cast<int>(std::floor(clipped));
    f[a] = clipped - i0[a];
  }
  const Eigen::Index base = i0.x() * nyz + i0.y() * nz + i0.z();
  const Eigen::Index step[3] = {nyz, nz, 1};
  double value = 0.0;
  Eigen::Vector3d rest_slope = Eigen::Vector3d::Zero();
  for (int corner = 0; corner < 8; ++corner) {
    const int o[3] = {(corner >> 2) & 1, (corner >> 1) & 1, corner & 1};
    double factor[3];
    for (int a = 0; a < 3; ++a) factor[a] = o[a] ? f[a] : 1.0 - f[a];
    const double v = field.distance[base + o[0] * step[0] + o[1] * step[1] + o[2] * step[2]];
    value += factor[0] * factor[1] * factor[2] * v;
    rest_slope.x() += (o[0] ? 1.0 : -1.0) * factor[1] * factor[2] * v;
    rest_slope.y() += (o[1] ? 1.0 : -1.0) * factor[0] * factor[2] * v;
    rest_slope.z() += (o[2] ? 1.0 : -1.0) * factor[0] * factor[1] * v;
  }
  // The gradient back in the armature's space: to_rest^T (rest_slope / spacing), to_cells^T rest_slope.
  if (slope != nullptr) *slope = motion.to_cells.transpose() * rest_slope;
  return value;
}

}  // namespace internal
}  // namespace motionkit
