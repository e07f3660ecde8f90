// Sizing a run's Data from its Model: every buffer the frame loop uses, allocated once.
#include "solver.hpp"

namespace motionkit::ik_internal {

namespace {

void SizeBuffers(const Model& m, StepBuffers& b) {
  const auto rows = static_cast<std::size_t>(m.rows), cols = static_cast<std::size_t>(m.cols);
  for (std::vector<double>* v :
       {&b.residual, &b.trial_residual, &b.effector_system, &b.linear_change, &b.held_residual}) {
    v->assign(rows, 0.0);
  }
  b.gram.assign(rows * rows, 0.0);
  for (std::vector<double>* v : {&b.step, &b.prior_step, &b.direction, &b.prior_pull, &b.at_y, &b.prior_offset,
                                 &b.trial_prior_offset}) {
    v->assign(cols, 0.0);
  }
}

void SizeBalance(const Model& m, Data& d) {
  const std::size_t supports = m.balance.support_bones.size();
  d.support.hull.assign(2 * supports + 1, Eigen::Vector2d::Zero());
  // Clipping a convex polygon by a line adds at most one corner: the box's 4, then one per hull edge.
  d.support.inner.assign(2 * supports + 8, Eigen::Vector2d::Zero());
  d.support.clip = d.support.inner;
  d.balance_block.a.assign(3 * static_cast<std::size_t>(m.cols), 0.0);
  d.balance_block.wa = d.balance_block.a;
}

void SizeSecondPass(const Model& m, SecondPass& s) {
  const std::size_t joints = m.joints.size(), effectors = static_cast<std::size_t>(m.effector_count);
  s.rotation_sum.assign(joints, Vec3::Zero());
  s.scale_sum.assign(joints, 0.0);
  s.shift_sum.assign(effectors, Vec3::Zero());
  s.aside.assign(effectors, Vec3::Zero());
}

}  // namespace

Data::Data(const Model& m) {
  for (Pose* p : {&input, &current, &trial, &reference, &warm.last, &warm.earlier, &warm.ended, &warm.start,
                  &fallback.pose, &ccd.best, &ccd.previous, &correction.pose}) {
    *p = MakePose(m);
  }
  for (Fk* f : {&fk, &trial_fk, &correction.fk}) *f = MakeFk(m);
  const auto effectors = static_cast<std::size_t>(m.effector_count), joints = m.joints.size();
  const auto rows = static_cast<std::size_t>(m.rows), cols = static_cast<std::size_t>(m.cols);
  target_position.assign(effectors, Vec3::Zero());
  target_orientation.assign(effectors, Quat::Identity());
  for (const Joint& j : m.joints) {
    limit_lo.push_back(j.lo);
    limit_hi.push_back(j.hi);
  }
  joint_axes.assign(joints, Eigen::Matrix3d::Zero());
  for (const Effector& e : m.effectors) {
    Block b;
    b.a.assign(static_cast<std::size_t>(e.rows) * e.columns.size(), 0.0);
    b.wa = b.a;
    blocks.push_back(std::move(b));
  }
  SizeBuffers(m, buffers);
  weight.diagonal.assign(cols, 0.0);
  weight.joint.assign(joints, Eigen::Matrix3d::Zero());
  curvature.world.assign(joints, Eigen::Matrix3d::Zero());
  curvature.joint.assign(joints, Eigen::Matrix3d::Zero());
  bounds.held.assign(cols, 0);
  bounds.coordinates.assign(joints, Vec3::Zero());
  levels.rows.assign(rows, 0);
  levels.held_rows.assign(rows, 0);
  for (std::vector<double>* v : {&levels.held_gram, &levels.held_solve, &levels.level_gram}) {
    v->assign(rows * rows, 0.0);
  }
  levels.level_rhs.assign(2 * rows, 0.0);
  if (m.balance.enabled) SizeBalance(m, *this);
  const auto points = static_cast<std::size_t>(3 + m.effector_count);
  ccd.points.assign(points, Vec3::Zero());
  ccd.targets.assign(points, Vec3::Zero());
  ccd.weights.assign(points, 0.0);
  ccd.placed.assign(points, 0);
  correction.residual.assign(rows, 0.0);
  SizeSecondPass(m, second_pass);
  escape.effector_met.assign(effectors, 0);
  escape.joint_bent.assign(joints, 0);
  stage = m.stages - 1;
}

}  // namespace motionkit::ik_internal
