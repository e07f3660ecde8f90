// The pseudo-inverse's step: u = A^T (A A^T + eps I)^-1 e.
#include "solver.hpp"

namespace motionkit::ik_internal {

bool PseudoInverseStep(const Model& m, Data& d, double eps) {
  StepBuffers& b = d.buffers;
  Gram(m, d, false, eps);
  if (!Cholesky(b.gram.data(), m.rows)) return false;
  std::copy(b.residual.begin(), b.residual.end(), b.effector_system.begin());
  CholeskySolve(b.gram.data(), m.rows, b.effector_system.data());
  MultiplyAt(m, d, b.effector_system.data(), b.step.data());
  return AllFinite(b.step);
}

}  // namespace motionkit::ik_internal
