// The check of key times that the jobs share (internal to native/src): each time finite, and each later
// than the one before, in the words of the job's own messages.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <string>

#include "motionkit/error.hpp"

namespace motionkit::internal {

// How a job's messages name its times, after its prefix ("keyframes: ", "interpolate curves: curve 3, "):
// "<one_time> 4 is not finite" and "<times> must increase strictly, but <entry> 4 (t) does not come after
// <entry> 3 (t)".
struct TimeNames {
  const char* one_time;  // "time of key", "frame time at key"
  const char* times;     // "key times"
  const char* entry;     // "key", "sample"
};

// times[i] is finite and, past the first, later than times[i - 1]. Checked on every key: kept to two
// comparisons, the message built only on failure (TimeOrderFailure).
inline bool TimeInOrder(const double* times, Eigen::Index i) {
  return std::isfinite(times[i]) && (i == 0 || times[i] > times[i - 1]);
}

// Why times[i] is not in order, for a time TimeInOrder refused.
inline Status TimeOrderFailure(const double* times, Eigen::Index i, const std::string& prefix, const TimeNames& names) {
  if (!std::isfinite(times[i])) {
    return Status::Fail(prefix + names.one_time + " " + std::to_string(i) + " is not finite");
  }
  return Status::Fail(prefix + names.times + " must increase strictly, but " + names.entry + " " + std::to_string(i) +
                      " (" + std::to_string(times[i]) + ") does not come after " + names.entry + " " +
                      std::to_string(i - 1) + " (" + std::to_string(times[i - 1]) + ")");
}

inline constexpr TimeNames kKeyTimes{"time of key", "key times", "key"};

}  // namespace motionkit::internal
