// The Jacobian transpose's direction: alpha A^T e, alpha = <e, A A^T e> / |A A^T e|^2 (Buss), the step
// that minimises the linear model's residual along A^T e. The loop halves it while it fails.
#include "solver.hpp"

namespace motionkit::ik_internal {

bool TransposeDirection(const Model& m, Data& d) {
  StepBuffers& b = d.buffers;
  MultiplyAt(m, d, b.residual.data(), b.direction.data());
  MultiplyA(m, d, b.direction.data(), b.linear_change.data());
  double num = 0.0, den = 0.0;
  for (int i = 0; i < m.rows; ++i) {
    num += At(b.residual, i) * At(b.linear_change, i);
    den += At(b.linear_change, i) * At(b.linear_change, i);
  }
  if (!(den > 0.0)) return false;
  for (double& v : b.direction) v *= num / den;
  return AllFinite(b.direction);
}

}  // namespace motionkit::ik_internal
