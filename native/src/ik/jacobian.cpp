// The Jacobian methods' linear algebra: the Jacobian and its curvature term, products with it, the
// effector-space Gram matrix, the step's direction, and applying a step.
#include "solver.hpp"

namespace motionkit::ik_internal {

namespace {

// The part of -r . d2p/dtheta_k dtheta_l (rotations about axes k, l through
// a joint, v from the joint to the effector, r the effector's residual) that
// is positive semi-definite: (r.v) I - sym(r v^T) less its negative
// eigenvalues, 1/2 (r.v - |r||v|) along r^ + v^ and r.v across both.
Eigen::Matrix3d PositiveBend(const Vec3& r, const Vec3& v) {
  const double rv = r.dot(v), nr = r.norm(), nv = v.norm();
  if (!(nr * nv > 0.0)) return Eigen::Matrix3d::Zero();
  Eigen::Matrix3d s = rv * Eigen::Matrix3d::Identity() - 0.5 * (r * v.transpose() + v * r.transpose());
  Vec3 plus = r / nr + v / nv;
  const double np = plus.norm();
  if (np < 1e-9) return Eigen::Matrix3d::Zero();  // opposite: nothing positive
  plus /= np;
  s -= (0.5 * (rv - nr * nv)) * plus * plus.transpose();
  if (rv < 0.0) {
    Vec3 across = r.cross(v);
    const double na = across.norm();
    if (na > 0.0) {
      across /= na;
      s -= rv * across * across.transpose();
    }
  }
  return s;
}

}  // namespace

void Solver::BuildJacobian(const Fk& fk) {
  for (std::size_t jo = 0; jo < joints_.size(); ++jo) axes_[jo] = At(fk.frame, joints_[jo].bone).toRotationMatrix();
  bend_ready_ = false;
  for (int ei = 0; ei < effector_count_; ++ei) {
    Effector& e = At(effectors_, ei);
    const Vec3& tip = At(fk.tip, ei);
    const auto rows = static_cast<std::size_t>(e.rows);
    const std::size_t ori = e.position ? 3 : 0;  // the orientation rows' offset in a column
    const double sw = e.sqrt_weight;
    const auto store = [&](std::size_t i, const Vec3& dp, const Vec3& dr) {
      double* out = e.block.data() + i * rows;
      if (e.position) {
        for (int k = 0; k < 3; ++k) out[k] = sw * dp[k];
      }
      if (e.orientation) {
        for (int k = 0; k < 3; ++k) out[ori + static_cast<std::size_t>(k)] = sw * dr[k];
      }
    };
    for (const Segment& sg : e.segments) {
      const auto at = static_cast<std::size_t>(sg.start);
      if (sg.joint < 0) {  // the root's translation, or a stretch column
        const Column& c = columns_[static_cast<std::size_t>(e.columns[at])];
        Vec3 dp = Vec3::Zero();
        if (c.kind == Kind::kTranslate) {
          dp[c.axis] = 1.0;  // the root's head moves every effector below it one to one
        } else {
          const Joint& j = At(joints_, c.joint);
          dp = (c.scale * e.levers[at]) * (At(fk.global, j.bone) * Vec3::UnitY());
        }
        store(at, dp, Vec3::Zero());
        continue;
      }
      const Vec3 lever = tip - At(fk.head, At(joints_, sg.joint).bone);
      const Eigen::Matrix3d& axes = At(axes_, sg.joint);
      for (int k = 0; k < sg.count; ++k) {
        const std::size_t i = at + static_cast<std::size_t>(k);
        const Column& c = columns_[static_cast<std::size_t>(e.columns[i])];
        const Vec3 a = axes.col(c.axis);
        store(i, c.scale * a.cross(lever), (c.scale * ls_) * a);
      }
    }
  }
  if (balance_) BuildBalance(fk);
}

// The residuals' curvature per joint (DLS), at the pose the Jacobian was
// built at (fk_): summed over the effectors below the joint in armature
// space, then C = (A D)^T S (A D) in the joint's columns, A its free axes.
void Solver::BuildBend() {
  std::fill(bend_world_.begin(), bend_world_.end(), Eigen::Matrix3d::Zero());
  for (int ei = 0; ei < effector_count_; ++ei) {
    const Effector& e = At(effectors_, ei);
    if (!e.position) continue;
    const Vec3& tip = At(fk_.tip, ei);
    const Vec3 residual = At(target_position_, ei) - tip;
    const double weight = e.sqrt_weight * e.sqrt_weight;
    for (const Segment& sg : e.segments) {
      if (sg.joint < 0) continue;
      At(bend_world_, sg.joint) += weight * PositiveBend(residual, tip - At(fk_.head, At(joints_, sg.joint).bone));
    }
  }
  for (std::size_t jo = 0; jo < joints_.size(); ++jo) {
    const Joint& j = joints_[jo];
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    for (int k = 0; k < j.axis_count; ++k) {
      const auto slot = static_cast<std::size_t>(k);
      a.col(k) = j.axis_scale[slot] * axes_[jo].col(j.axes[slot]);
    }
    bend_[jo] = a.transpose() * bend_world_[jo] * a;
  }
  bend_ready_ = true;
}

void Solver::MultiplyA(const double* x, double* out) const {
  for (const Effector& e : effectors_) {
    const std::size_t n = e.columns.size();
    if (e.rows == 3) {
      BlockTimes<3>(e.block.data(), e.columns.data(), n, x, out + e.row);
    } else {
      BlockTimes<6>(e.block.data(), e.columns.data(), n, x, out + e.row);
    }
  }
  if (balance_) BlockTimes<3>(com_.block.data(), com_.columns.data(), com_.columns.size(), x, out + com_.row);
}

void Solver::MultiplyW(const double* x, double* out) const {
  for (int j = 0; j < cols_; ++j) out[j] = At(w_, j) * x[j];
  if (!full_weight_) return;
  for (std::size_t jo = 0; jo < joints_.size(); ++jo) {
    const Joint& j = joints_[jo];
    const double* in = x + j.first_column;
    for (int k = 0; k < j.axis_count; ++k) {
      double sum = 0.0;
      for (int l = 0; l < j.axis_count; ++l) sum += weight_[jo](k, l) * in[l];
      out[j.first_column + k] = sum;
    }
  }
}

void Solver::MultiplyAt(const double* y, double* out) const {
  std::fill(out, out + cols_, 0.0);
  for (const Effector& e : effectors_) {
    const std::size_t n = e.columns.size();
    if (e.rows == 3) {
      BlockTransposeTimes<3>(e.block.data(), e.columns.data(), n, y + e.row, out);
    } else {
      BlockTransposeTimes<6>(e.block.data(), e.columns.data(), n, y + e.row, out);
    }
  }
  if (balance_) {
    BlockTransposeTimes<3>(com_.block.data(), com_.columns.data(), com_.columns.size(), y + com_.row, out);
  }
}

void Solver::Gram(bool weighted, double diagonal) {
  const int m = rows_;
  for (int a = 0; a < effector_count_; ++a) {
    const Effector& ea = At(effectors_, a);
    const double* left = weighted ? ea.wblock.data() : ea.block.data();
    const auto ra_count = static_cast<std::size_t>(ea.rows);
    for (int b = a; b < effector_count_; ++b) {
      const Effector& eb = At(effectors_, b);
      const auto rb_count = static_cast<std::size_t>(eb.rows);
      const auto c = static_cast<std::size_t>(At(ea.prefix, b));
      // Over the shared leading columns: sum[ra][rb] += x[ra] z[rb].
      std::array<std::array<double, 6>, 6> sum;
      const double* z = eb.block.data();
      if (ra_count == 3) {
        if (rb_count == 3) BlockDots<3, 3>(left, z, c, sum);
        else BlockDots<3, 6>(left, z, c, sum);
      } else {
        if (rb_count == 3) BlockDots<6, 3>(left, z, c, sum);
        else BlockDots<6, 6>(left, z, c, sum);
      }
      for (std::size_t ra = 0; ra < ra_count; ++ra) {
        for (std::size_t rb = (a == b ? ra : 0); rb < rb_count; ++rb) {
          double s = sum[ra][rb];
          const int i0 = ea.row + static_cast<int>(ra), i1 = eb.row + static_cast<int>(rb);
          if (i0 == i1) s += diagonal;
          s_[static_cast<std::size_t>(i0 * m + i1)] = s;
          s_[static_cast<std::size_t>(i1 * m + i0)] = s;
        }
      }
    }
  }
  if (!balance_) return;
  // The centre of mass's rows span every column (its block is indexed by
  // column): against an effector, a sum over that effector's columns.
  const double* com = com_.block.data();
  const double* wcom = weighted ? com_.wblock.data() : com;
  const auto put = [&](int i0, int i1, double s) {
    if (i0 == i1) s += diagonal;
    s_[static_cast<std::size_t>(i0 * m + i1)] = s;
    s_[static_cast<std::size_t>(i1 * m + i0)] = s;
  };
  for (const Effector& e : effectors_) {
    const double* left = weighted ? e.wblock.data() : e.block.data();
    const auto rows = static_cast<std::size_t>(e.rows);
    for (std::size_t r = 0; r < rows; ++r) {
      for (int k = 0; k < 3; ++k) {
        double s = 0.0;
        for (std::size_t i = 0; i < e.columns.size(); ++i) {
          s += left[i * rows + r] * com[3 * static_cast<std::size_t>(e.columns[i]) + static_cast<std::size_t>(k)];
        }
        put(e.row + static_cast<int>(r), com_.row + k, s);
      }
    }
  }
  for (int a = 0; a < 3; ++a) {
    for (int b = a; b < 3; ++b) {
      double s = 0.0;
      for (int c = 0; c < cols_; ++c) s += wcom[3 * c + a] * com[3 * c + b];
      put(com_.row + a, com_.row + b, s);
    }
  }
}

bool Solver::Direction(double lambda2, double mu) {
  switch (options_.method) {
    case IkMethod::kDls: {
      // min |A u - e|^2 + lambda^2 |u|_G^2 + mu |rho + D u|_G^2 + u^T C u (G
      // the columns' metric: 1, or 1 / ls^2 for the root's move): with
      // M = (lambda^2 + mu D^2) G + C (block diagonal: 3 x 3 per joint) and
      // W = M^-1, u = W b + W A^T (I + A W A^T)^-1 (e - A W b),
      // b = -mu D rho (Woodbury): an effector-space system. C is the
      // residual's curvature at each joint that Gauss-Newton leaves out
      // (BuildJacobian): it stops a chain reaching for an unreachable target
      // from overshooting, so lambda need not grow to do it.
      if (bend_weight_ > 0.0 && !bend_ready_) BuildBend();
      for (int j = 0; j < cols_; ++j) {
        const Column& c = columns_[static_cast<std::size_t>(j)];
        const double d = c.scale;
        const bool held = At(frozen_, j);
        // With natural defaults the prior is a level of its own (u0, which
        // the levels above undo where it would move them), not extra damping
        // of the targets' steps: W keeps lambda alone.
        const double prior = separate_prior_ ? 0.0 : mu;
        // Settling, W is the prior's own metric (d^2 G)^-1: the levels then
        // take back the W-orthogonal part of the prior's Newton step, and what
        // is left is the prior's step on the levels' null space (in any other
        // metric it need not even lower the prior).
        const double settle = settle_gain_ > 0.0 ? d * d : 1.0;
        At(w_, j) = held || !(settle > 0.0) ? 0.0 : 1.0 / ((lambda2 + prior * d * d) * settle * c.metric);
        At(g_, j) = mu > 0.0 && !held ? -mu * d * c.metric * At(rho_, j) : 0.0;  // b
      }
      // Without the curvature M is diagonal, and W is w_ (a held column's 0).
      full_weight_ = bend_weight_ > 0.0;
      for (std::size_t jo = 0; full_weight_ && jo < joints_.size(); ++jo) {
        const Joint& j = joints_[jo];
        if (j.axis_count == 0) continue;
        Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
        for (int k = 0; k < j.axis_count; ++k) {
          if (At(frozen_, j.first_column + k)) continue;
          for (int l = 0; l < j.axis_count; ++l) {
            const bool bend = bend_weight_ > 0.0 && !At(frozen_, j.first_column + l);
            m(k, l) = bend ? bend_weight_ * bend_[jo](k, l) : 0.0;
          }
          const double d = j.axis_scale[static_cast<std::size_t>(k)];
          m(k, k) += (lambda2 + (separate_prior_ ? 0.0 : mu) * d * d) * StageCost(j.stage);
        }
        weight_[jo] = m.inverse();
        for (int k = 0; k < j.axis_count; ++k) {
          if (!At(frozen_, j.first_column + k)) continue;
          weight_[jo].row(k).setZero();
          weight_[jo].col(k).setZero();
        }
      }
      if (separate_prior_) {
        // The prior's own step: the share mu d^2 / (lambda^2 + mu d^2) of the
        // way back, at most kPriorGain of it an iteration (a whole return at
        // once is a large move that the levels above undo only to first order).
        for (int j = 0; j < cols_; ++j) {
          const Column& c = columns_[static_cast<std::size_t>(j)];
          const double d = c.scale;
          const double gain = settle_gain_ > 0.0 ? settle_gain_ : std::min(kPriorGain, mu * d * d / (lambda2 + mu * d * d));
          At(u0_, j) = mu > 0.0 && !At(frozen_, j) && d > 0.0 ? -gain * At(rho_, j) / d : 0.0;
        }
      } else {
        MultiplyW(g_.data(), u0_.data());  // u0 = W b
      }
      MultiplyA(u0_.data(), h_.data());
      for (int i = 0; i < rows_; ++i) At(y_, i) = At(e_, i) - (holding_ ? At(hold_, i) : 0.0) - At(h_, i);
      for (std::size_t ei = 0; ei <= effectors_.size(); ++ei) {
        if (ei == effectors_.size() && !balance_) break;
        Effector& e = ei < effectors_.size() ? effectors_[ei] : com_;
        const std::size_t n = e.columns.size();
        const auto rows = static_cast<std::size_t>(e.rows);
        if (!full_weight_) {
          for (std::size_t i = 0; i < n; ++i) {
            const double w = At(w_, e.columns[i]);
            for (std::size_t r = 0; r < rows; ++r) e.wblock[i * rows + r] = e.block[i * rows + r] * w;
          }
          continue;
        }
        for (std::size_t r = 0; r < rows; ++r) {
          const double* in = e.block.data() + r;
          double* out = e.wblock.data() + r;
          for (const Segment& sg : e.segments) {
            const auto at = static_cast<std::size_t>(sg.start);
            if (sg.joint < 0) {
              out[at * rows] = in[at * rows] * At(w_, e.columns[at]);
              continue;
            }
            const Eigen::Matrix3d& w = At(weight_, sg.joint);
            for (int k = 0; k < sg.count; ++k) {
              double sum = 0.0;
              for (int l = 0; l < sg.count; ++l) sum += in[(at + static_cast<std::size_t>(l)) * rows] * w(l, k);
              out[(at + static_cast<std::size_t>(k)) * rows] = sum;
            }
          }
        }
      }
      if (priorities_) {
        Gram(true, 0.0);
        if (!SolveLevels()) return false;
      } else {
        Gram(true, 1.0);
        if (!Cholesky(s_.data(), rows_)) return false;
        CholeskySolve(s_.data(), rows_, y_.data());
      }
      MultiplyAt(y_.data(), g_.data());
      MultiplyW(g_.data(), u_.data());
      for (int j = 0; j < cols_; ++j) At(u_, j) += At(u0_, j);
      for (double v : u_) {
        if (!std::isfinite(v)) return false;
      }
      return true;
    }
    case IkMethod::kPseudoInverse: {
      // u = A^T (A A^T + eps I)^-1 e.
      Gram(false, lambda2);
      if (!Cholesky(s_.data(), rows_)) return false;
      std::copy(e_.begin(), e_.end(), y_.begin());
      CholeskySolve(s_.data(), rows_, y_.data());
      MultiplyAt(y_.data(), u_.data());
      for (double v : u_) {
        if (!std::isfinite(v)) return false;
      }
      return true;
    }
    case IkMethod::kTranspose: {
      // u = alpha A^T e, alpha = <e, A A^T e> / |A A^T e|^2 (Buss).
      MultiplyAt(e_.data(), u0_.data());
      MultiplyA(u0_.data(), h_.data());
      double num = 0.0, den = 0.0;
      for (int i = 0; i < rows_; ++i) {
        num += At(e_, i) * At(h_, i);
        den += At(h_, i) * At(h_, i);
      }
      if (!(den > 0.0)) return false;
      for (double& v : u0_) v *= num / den;
      break;
    }
    case IkMethod::kCcd:
      return false;
  }
  for (double v : u0_) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

// Scales the step so that no joint turns more than max_step radians, no scale
// changes more than max_step and the root moves at most max_step * ls.
void Solver::ClampStep(double* u) const {
  double largest = 0.0;
  if (translate_) largest = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) / ls_;
  for (const Joint& j : joints_) {
    double sum = 0.0;
    for (int k = 0; k < j.axis_count; ++k) {
      const double v = j.axis_scale[static_cast<std::size_t>(k)] * u[j.first_column + k];
      sum += v * v;
    }
    largest = std::max(largest, std::sqrt(sum));
    if (j.stretch_column >= 0) largest = std::max(largest, std::abs(j.stretch * u[j.stretch_column]));
  }
  if (largest > options_.max_step) {
    const double f = options_.max_step / largest;
    for (int i = 0; i < cols_; ++i) u[i] *= f;
  }
}

void Solver::Apply(const Pose& from, const double* u, Pose& to) const {
  if (translate_) to.root = from.root + Vec3(u[0], u[1], u[2]);
  for (const Joint& j : joints_) {
    const int b = j.bone;
    if (j.axis_count > 0) {
      Vec3 delta = Vec3::Zero();
      for (int k = 0; k < j.axis_count; ++k) {
        const auto slot = static_cast<std::size_t>(k);
        delta[j.axes[slot]] = j.axis_scale[slot] * u[j.first_column + k];
      }
      At(to.basis, b) = (FromRotationVector(delta) * At(from.basis, b)).normalized();
    } else {
      At(to.basis, b) = At(from.basis, b);
    }
    if (j.stretch_column >= 0) At(to.scale, b) = At(from.scale, b) + j.stretch * u[j.stretch_column];
    ClampJoint(j, to);
  }
}

}  // namespace motionkit::ik_internal
