#include "motionkit/keyframes.hpp"

#include <cmath>
#include <string>

#include "time_checks.hpp"

namespace motionkit {

Status KeyframeCoJob::Validate() const {
  const Eigen::Index n = frames.size();
  if (values.cols() != n) {
    return Status::Fail("keyframes: values has " + std::to_string(values.cols()) +
                        " columns but there are " + std::to_string(n) + " frames");
  }
  if (co.rows() != values.rows() || co.cols() != 2 * n) {
    return Status::Fail("keyframes: output co must be " + std::to_string(values.rows()) + " x " +
                        std::to_string(2 * n) + ", got " + std::to_string(co.rows()) + " x " +
                        std::to_string(co.cols()));
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!internal::TimeInOrder(frames.data(), i)) {
      return internal::TimeOrderFailure(frames.data(), i, "keyframes: ", {"frame time at key", "frame times", "key"});
    }
  }
  // Row-major input: scan row by row, which is contiguous.
  for (Eigen::Index c = 0; c < values.rows(); ++c) {
    for (Eigen::Index i = 0; i < n; ++i) {
      if (!std::isfinite(values(c, i))) {
        return Status::Fail("keyframes: curve " + std::to_string(c) + ", key " +
                            std::to_string(i) + " (frame " + std::to_string(frames[i]) +
                            ") is not finite");
      }
    }
  }
  return Status::Ok();
}

void KeyframeCoJob::Run() {
  Validate().ThrowIfFailed();
  const Eigen::Index n = frames.size();
  for (Eigen::Index c = 0; c < values.rows(); ++c) {
    float* out = co.row(c).data();
    for (Eigen::Index i = 0; i < n; ++i) {
      out[2 * i] = static_cast<float>(frames[i]);
      out[2 * i + 1] = static_cast<float>(values(c, i));
    }
  }
}

}  // namespace motionkit
