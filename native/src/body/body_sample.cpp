// Reading the body's field where its bones have moved it (native/include/motionkit/body_sample.hpp).
#include "motionkit/body_sample.hpp"

#include <limits>
#include <string>

#include "body_read.hpp"

namespace motionkit {

Status BodySampleJob::Validate() const {
  const Eigen::Index frames = points.rows(), count = points.cols() / 3;
  if (points.cols() % 3 != 0) return Status::Fail("body sample: points must be frames x 3N");
  const Eigen::Index bones = orientations.cols() / 4;
  if (orientations.rows() != frames || heads.rows() != frames || heads.cols() != 3 * bones ||
      orientations.cols() != 4 * bones) {
    return Status::Fail("body sample: the pose must be frames x 4B orientations and frames x 3B heads");
  }
  if (Status s = field.Validate(bones, "body sample"); !s.ok()) return s;
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
    for (std::size_t c = 0; c < field.carriers.size(); ++c) {
      const internal::CarrierMotion motion = internal::Motion(field, c, orientations, heads, f);
      for (Eigen::Index n = 0; n < count; ++n) {
        Eigen::Vector3d slope;
        const double d = internal::ReadThrough(field, motion, points.block<1, 3>(f, 3 * n).transpose(),
                                               slopes ? &slope : nullptr);
        if (!(d < read(f, n))) continue;
        read(f, n) = d;
        if (slopes) gradient.block<1, 3>(f, 3 * n) = slope.transpose();
      }
    }
  }
}

}  // namespace motionkit
