// Damped least squares' step:
//   min |A u - e|^2 + lambda^2 |u|_G^2 + mu |rho + D u|_G^2 + u^T C u
// (G the columns' metric: 1, or 1 / ls^2 for the root's move; D the columns' scales; rho where each
// unknown stands from the reference; C the residuals' curvature at each joint that Gauss-Newton leaves
// out, which stops a chain reaching for an unreachable target from overshooting, so that lambda need
// not grow to do it). With M = (lambda^2 + mu D^2) G + C (block diagonal: 3 x 3 per joint) and
// W = M^-1, u = W b + W A^T (I + A W A^T)^-1 (e - A W b), b = -mu D G rho (Woodbury): an
// effector-space system, as small as the effectors' rows.
#include "solver.hpp"

namespace motionkit::ik_internal {

namespace {

// W's diagonal (a held column's 0) and b.
void ColumnWeights(const Model& m, Data& d, double lambda2, double mu) {
  // With natural defaults the prior is a level of its own (u0, which the
  // levels above undo where it would move them), not extra damping of the
  // targets' steps: W keeps lambda alone.
  const double prior = m.separate_prior ? 0.0 : mu;
  for (int j = 0; j < m.cols; ++j) {
    const Column& c = At(m.columns, j);
    const double scale = c.scale;
    const bool held = At(d.bounds.held, j);
    // Settling, W is the prior's own metric (d^2 G)^-1: the levels then
    // take back the W-orthogonal part of the prior's Newton step, and what
    // is left is the prior's step on the levels' null space (in any other
    // metric it need not even lower the prior).
    const double settle = d.settle_gain > 0.0 ? scale * scale : 1.0;
    At(d.weight.diagonal, j) =
        held || !(settle > 0.0) ? 0.0 : 1.0 / ((lambda2 + prior * scale * scale) * settle * c.metric);
    At(d.buffers.prior_pull, j) = mu > 0.0 && !held ? -mu * scale * c.metric * At(d.buffers.prior_offset, j) : 0.0;
  }
}

// With the curvature, W's 3 x 3 block per joint (a held column's row and column 0).
void JointWeightBlocks(const Model& m, Data& d, double lambda2, double mu) {
  const double bend_weight = d.curvature.weight;
  for (std::size_t jo = 0; jo < m.joints.size(); ++jo) {
    const Joint& j = m.joints[jo];
    if (j.axis_count == 0) continue;
    Eigen::Matrix3d metric = Eigen::Matrix3d::Identity();
    for (int k = 0; k < j.axis_count; ++k) {
      if (At(d.bounds.held, j.first_column + k)) continue;
      for (int l = 0; l < j.axis_count; ++l) {
        const bool bend = bend_weight > 0.0 && !At(d.bounds.held, j.first_column + l);
        metric(k, l) = bend ? bend_weight * d.curvature.joint[jo](k, l) : 0.0;
      }
      const double scale = j.axis_scale[static_cast<std::size_t>(k)];
      metric(k, k) += (lambda2 + (m.separate_prior ? 0.0 : mu) * scale * scale) * StageCost(j.stage);
    }
    Eigen::Matrix3d& w = d.weight.joint[jo];
    w = metric.inverse();
    for (int k = 0; k < j.axis_count; ++k) {
      if (!At(d.bounds.held, j.first_column + k)) continue;
      w.row(k).setZero();
      w.col(k).setZero();
    }
  }
}

// u0: with the prior as a level of its own, its own step, the share mu d^2 / (lambda^2 + mu d^2) of
// the way back, at most kPriorGain of it an iteration (a whole return at once is a large move that the
// levels above undo only to first order); else W b.
void PriorStep(const Model& m, Data& d, double lambda2, double mu) {
  if (!m.separate_prior) {
    MultiplyW(m, d, d.buffers.prior_pull.data(), d.buffers.prior_step.data());
    return;
  }
  for (int j = 0; j < m.cols; ++j) {
    const double scale = At(m.columns, j).scale;
    const double gain =
        d.settle_gain > 0.0 ? d.settle_gain : std::min(kPriorGain, mu * scale * scale / (lambda2 + mu * scale * scale));
    At(d.buffers.prior_step, j) =
        mu > 0.0 && !At(d.bounds.held, j) && scale > 0.0 ? -gain * At(d.buffers.prior_offset, j) / scale : 0.0;
  }
}

// An effector's block times W, by segments (W's joint blocks).
void WeighBlockBySegments(const Data& d, const Effector& e, Block& block) {
  const auto rows = static_cast<std::size_t>(e.rows);
  for (std::size_t r = 0; r < rows; ++r) {
    const double* in = block.a.data() + r;
    double* out = block.wa.data() + r;
    for (const Segment& sg : e.segments) {
      const auto at = static_cast<std::size_t>(sg.start);
      if (sg.joint < 0) {
        out[at * rows] = in[at * rows] * At(d.weight.diagonal, e.columns[at]);
        continue;
      }
      const Eigen::Matrix3d& w = At(d.weight.joint, sg.joint);
      for (int k = 0; k < sg.count; ++k) {
        double sum = 0.0;
        for (int l = 0; l < sg.count; ++l) sum += in[(at + static_cast<std::size_t>(l)) * rows] * w(l, k);
        out[(at + static_cast<std::size_t>(k)) * rows] = sum;
      }
    }
  }
}

// Every block times W.
void WeighBlocks(const Model& m, Data& d) {
  for (std::size_t ei = 0; ei <= m.effectors.size(); ++ei) {
    if (ei == m.effectors.size() && !m.balance.enabled) break;
    const Effector& e = ei < m.effectors.size() ? m.effectors[ei] : m.balance.com;
    Block& block = ei < m.effectors.size() ? d.blocks[ei] : d.balance_block;
    if (d.weight.blocks) {
      WeighBlockBySegments(d, e, block);
      continue;
    }
    const std::size_t n = e.columns.size();
    const auto rows = static_cast<std::size_t>(e.rows);
    for (std::size_t i = 0; i < n; ++i) {
      const double w = At(d.weight.diagonal, e.columns[i]);
      for (std::size_t r = 0; r < rows; ++r) block.wa[i * rows + r] = block.a[i * rows + r] * w;
    }
  }
}

// y from the effector-space system: by levels with priorities, else (I + A W A^T) y = rhs.
bool SolveEffectorSpace(const Model& m, Data& d) {
  if (m.priorities) {
    Gram(m, d, true, 0.0);
    return SolveLevels(m, d);
  }
  Gram(m, d, true, 1.0);
  if (!Cholesky(d.buffers.gram.data(), m.rows)) return false;
  CholeskySolve(d.buffers.gram.data(), m.rows, d.buffers.effector_system.data());
  return true;
}

}  // namespace

bool DlsStep(const Model& m, Data& d, double lambda2, double mu) {
  StepBuffers& b = d.buffers;
  if (d.curvature.weight > 0.0 && !d.curvature.ready) BuildCurvature(m, d);
  ColumnWeights(m, d, lambda2, mu);
  // Without the curvature M is diagonal, and W is the diagonal alone.
  d.weight.blocks = d.curvature.weight > 0.0;
  if (d.weight.blocks) JointWeightBlocks(m, d, lambda2, mu);
  PriorStep(m, d, lambda2, mu);
  MultiplyA(m, d, b.prior_step.data(), b.linear_change.data());
  for (int i = 0; i < m.rows; ++i) {
    const double held = b.holding ? At(b.held_residual, i) : 0.0;
    At(b.effector_system, i) = At(b.residual, i) - held - At(b.linear_change, i);
  }
  WeighBlocks(m, d);
  if (!SolveEffectorSpace(m, d)) return false;
  MultiplyAt(m, d, b.effector_system.data(), b.at_y.data());
  MultiplyW(m, d, b.at_y.data(), b.step.data());
  for (int j = 0; j < m.cols; ++j) At(b.step, j) += At(b.prior_step, j);
  return AllFinite(b.step);
}

}  // namespace motionkit::ik_internal
