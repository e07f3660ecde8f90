// A, the Jacobian (one dense block per effector), its curvature term, its products with vectors, and
// the effector-space Gram matrix.
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

// Effector ei's block: per column, how its position and orientation rows move.
void BuildEffectorBlock(const Model& m, Data& d, const Fk& fk, int ei) {
  const Effector& e = At(m.effectors, ei);
  std::vector<double>& block = At(d.blocks, ei).a;
  const Vec3& tip = At(fk.tip, ei);
  const auto rows = static_cast<std::size_t>(e.rows);
  const std::size_t ori = e.position ? 3 : 0;  // the orientation rows' offset in a column
  const double sw = e.sqrt_weight;
  const auto store = [&](std::size_t i, const Vec3& dp, const Vec3& dr) {
    double* out = block.data() + i * rows;
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
      const Column& c = At(m.columns, e.columns[at]);
      Vec3 dp = Vec3::Zero();
      if (c.kind == Kind::kTranslate) {
        dp[c.axis] = 1.0;  // the root's head moves every effector below it one to one
      } else {
        const Joint& j = At(m.joints, c.joint);
        dp = (c.scale * e.levers[at]) * (At(fk.global, j.bone) * Vec3::UnitY());
      }
      store(at, dp, Vec3::Zero());
      continue;
    }
    const Vec3 lever = tip - At(fk.head, At(m.joints, sg.joint).bone);
    const Eigen::Matrix3d& axes = At(d.joint_axes, sg.joint);
    for (int k = 0; k < sg.count; ++k) {
      const std::size_t i = at + static_cast<std::size_t>(k);
      const Column& c = At(m.columns, e.columns[i]);
      const Vec3 a = axes.col(c.axis);
      store(i, c.scale * a.cross(lever), (c.scale * m.ls) * a);
    }
  }
}

// The Gram matrix's entries against the centre of mass's rows, whose block spans every column
// (indexed by column): against an effector, a sum over that effector's columns.
void GramBalance(const Model& m, Data& d, bool weighted, double diagonal) {
  const int n = m.rows;
  const Effector& cm = m.balance.com;
  const double* com = d.balance_block.a.data();
  const double* wcom = weighted ? d.balance_block.wa.data() : com;
  const auto put = [&](int i0, int i1, double s) {
    if (i0 == i1) s += diagonal;
    d.buffers.gram[static_cast<std::size_t>(i0 * n + i1)] = s;
    d.buffers.gram[static_cast<std::size_t>(i1 * n + i0)] = s;
  };
  for (std::size_t ei = 0; ei < m.effectors.size(); ++ei) {
    const Effector& e = m.effectors[ei];
    const double* left = weighted ? d.blocks[ei].wa.data() : d.blocks[ei].a.data();
    const auto rows = static_cast<std::size_t>(e.rows);
    for (std::size_t r = 0; r < rows; ++r) {
      for (int k = 0; k < 3; ++k) {
        double s = 0.0;
        for (std::size_t i = 0; i < e.columns.size(); ++i) {
          s += left[i * rows + r] * com[3 * static_cast<std::size_t>(e.columns[i]) + static_cast<std::size_t>(k)];
        }
        put(e.row + static_cast<int>(r), cm.row + k, s);
      }
    }
  }
  for (int a = 0; a < 3; ++a) {
    for (int b = a; b < 3; ++b) {
      double s = 0.0;
      for (int c = 0; c < m.cols; ++c) s += wcom[3 * c + a] * com[3 * c + b];
      put(cm.row + a, cm.row + b, s);
    }
  }
}

}  // namespace

void BuildJacobian(const Model& m, Data& d, const Fk& fk) {
  for (std::size_t jo = 0; jo < m.joints.size(); ++jo) {
    d.joint_axes[jo] = At(fk.frame, m.joints[jo].bone).toRotationMatrix();
  }
  d.curvature.ready = false;
  for (int ei = 0; ei < m.effector_count; ++ei) BuildEffectorBlock(m, d, fk, ei);
  if (m.balance.enabled) BuildBalanceRows(m, d, fk);
}

// The residuals' curvature per joint (DLS), at the pose the Jacobian was
// built at (d.fk): summed over the effectors below the joint in armature
// space, then C = (A D)^T S (A D) in the joint's columns, A its free axes.
void BuildCurvature(const Model& m, Data& d) {
  Curvature& cv = d.curvature;
  std::fill(cv.world.begin(), cv.world.end(), Eigen::Matrix3d::Zero());
  for (int ei = 0; ei < m.effector_count; ++ei) {
    const Effector& e = At(m.effectors, ei);
    if (!e.position) continue;
    const Vec3& tip = At(d.fk.tip, ei);
    const Vec3 residual = At(d.target_position, ei) - tip;
    const double weight = e.sqrt_weight * e.sqrt_weight;
    for (const Segment& sg : e.segments) {
      if (sg.joint < 0) continue;
      At(cv.world, sg.joint) += weight * PositiveBend(residual, tip - At(d.fk.head, At(m.joints, sg.joint).bone));
    }
  }
  for (std::size_t jo = 0; jo < m.joints.size(); ++jo) {
    const Joint& j = m.joints[jo];
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    for (int k = 0; k < j.axis_count; ++k) {
      const auto slot = static_cast<std::size_t>(k);
      a.col(k) = j.axis_scale[slot] * d.joint_axes[jo].col(j.axes[slot]);
    }
    cv.joint[jo] = a.transpose() * cv.world[jo] * a;
  }
  cv.ready = true;
}

void MultiplyA(const Model& m, const Data& d, const double* x, double* out) {
  for (std::size_t ei = 0; ei < m.effectors.size(); ++ei) {
    const Effector& e = m.effectors[ei];
    const std::size_t n = e.columns.size();
    if (e.rows == 3) {
      BlockTimes<3>(d.blocks[ei].a.data(), e.columns.data(), n, x, out + e.row);
    } else {
      BlockTimes<6>(d.blocks[ei].a.data(), e.columns.data(), n, x, out + e.row);
    }
  }
  if (m.balance.enabled) {
    const Effector& com = m.balance.com;
    BlockTimes<3>(d.balance_block.a.data(), com.columns.data(), com.columns.size(), x, out + com.row);
  }
}

void MultiplyW(const Model& m, const Data& d, const double* x, double* out) {
  for (int j = 0; j < m.cols; ++j) out[j] = At(d.weight.diagonal, j) * x[j];
  if (!d.weight.blocks) return;
  for (std::size_t jo = 0; jo < m.joints.size(); ++jo) {
    const Joint& j = m.joints[jo];
    const double* in = x + j.first_column;
    for (int k = 0; k < j.axis_count; ++k) {
      double sum = 0.0;
      for (int l = 0; l < j.axis_count; ++l) sum += d.weight.joint[jo](k, l) * in[l];
      out[j.first_column + k] = sum;
    }
  }
}

void MultiplyAt(const Model& m, const Data& d, const double* y, double* out) {
  std::fill(out, out + m.cols, 0.0);
  for (std::size_t ei = 0; ei < m.effectors.size(); ++ei) {
    const Effector& e = m.effectors[ei];
    const std::size_t n = e.columns.size();
    if (e.rows == 3) {
      BlockTransposeTimes<3>(d.blocks[ei].a.data(), e.columns.data(), n, y + e.row, out);
    } else {
      BlockTransposeTimes<6>(d.blocks[ei].a.data(), e.columns.data(), n, y + e.row, out);
    }
  }
  if (m.balance.enabled) {
    const Effector& com = m.balance.com;
    BlockTransposeTimes<3>(d.balance_block.a.data(), com.columns.data(), com.columns.size(), y + com.row, out);
  }
}

void Gram(const Model& m, Data& d, bool weighted, double diagonal) {
  const int n = m.rows;
  for (int a = 0; a < m.effector_count; ++a) {
    const Effector& ea = At(m.effectors, a);
    const double* left = weighted ? At(d.blocks, a).wa.data() : At(d.blocks, a).a.data();
    const auto ra_count = static_cast<std::size_t>(ea.rows);
    for (int b = a; b < m.effector_count; ++b) {
      const Effector& eb = At(m.effectors, b);
      const auto rb_count = static_cast<std::size_t>(eb.rows);
      const auto c = static_cast<std::size_t>(At(ea.prefix, b));
      // Over the shared leading columns: sum[ra][rb] += x[ra] z[rb].
      std::array<std::array<double, 6>, 6> sum;
      const double* z = At(d.blocks, b).a.data();
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
          d.buffers.gram[static_cast<std::size_t>(i0 * n + i1)] = s;
          d.buffers.gram[static_cast<std::size_t>(i1 * n + i0)] = s;
        }
      }
    }
  }
  if (m.balance.enabled) GramBalance(m, d, weighted, diagonal);
}

}  // namespace motionkit::ik_internal
