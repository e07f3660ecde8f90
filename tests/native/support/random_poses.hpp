// Random rotations for the whole-clip tests: each bone's rotation vector drawn from a normal distribution
// of the given spread (radians), per frame, as w x y z rows (frames x 4 bones).
#pragma once

#include <Eigen/Geometry>
#include <random>

#include "motionkit/types.hpp"

namespace motionkit::test_rigs {

inline RowMatrixXd RandomPoses(int bones, int frames, unsigned seed, double spread = 0.8) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, spread);
  RowMatrixXd q(frames, 4 * bones);
  for (int f = 0; f < frames; ++f) {
    for (int b = 0; b < bones; ++b) {
      const Eigen::Vector3d v(n(rng), n(rng), n(rng));
      const Eigen::Quaterniond r(Eigen::AngleAxisd(v.norm(), v.normalized()));
      q.row(f).segment<4>(4 * b) << r.w(), r.x(), r.y(), r.z();
    }
  }
  return q;
}

}  // namespace motionkit::test_rigs
