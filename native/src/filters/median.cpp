// Running median with the clip extended by its end values, as
// scipy.ndimage.median_filter(mode='nearest'): one spike shorter than half the
// window goes, a step stays where it was.
//
// On rotations, each frame's window is taken in the tangent space at a centre
// c_t: out_t = c_t exp(median_k log(c_t^-1 q_t+k)), per component. For a
// scalar, c + median_k(x_t+k - c) is the median itself whatever c, so this is
// the same filter. The centre starts at q_t, which returns smooth motion and a
// constant-speed rotation unchanged (ends included); a large spike is not flat
// in the tangent space at its own frame, so the pass is repeated with each
// output as the next centre, where the linearisation holds.
#include "../so3.hpp"
#include "filter_internal.hpp"

namespace motionkit::internal {

void MedianFilter(int size, const double* x, Eigen::Index n, double* out, double* window) {
  const Eigen::Index half = size / 2;
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index k = 0; k < size; ++k) {
      window[k] = x[std::clamp<Eigen::Index>(i - half + k, 0, n - 1)];
    }
    std::nth_element(window, window + half, window + size);
    out[i] = window[half];
  }
}

double MedianRotations(int size, const Eigen::Quaterniond* q, Eigen::Index n, Eigen::Quaterniond* centre,
                       double* window) {
  const Eigen::Index half = size / 2;
  double* component[3] = {window, window + size, window + 2 * size};
  double largest = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Quaterniond inverse = centre[i].conjugate();
    for (Eigen::Index k = 0; k < size; ++k) {
      const Eigen::Vector3d v = RotationVector(inverse * q[std::clamp<Eigen::Index>(i - half + k, 0, n - 1)]);
      for (int c = 0; c < 3; ++c) component[c][k] = v[c];
    }
    Eigen::Vector3d median;
    for (int c = 0; c < 3; ++c) {
      std::nth_element(component[c], component[c] + half, component[c] + size);
      median[c] = component[c][half];
    }
    largest = std::max(largest, median.norm());
    centre[i] = (centre[i] * FromRotationVector(median)).normalized();
  }
  return largest;
}

}  // namespace motionkit::internal
