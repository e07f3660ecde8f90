// What every frame of a solve shares, worked out once: the solved joints and their columns, each
// effector's path, the CCD chains, and every buffer sized.
#include "solver.hpp"

namespace motionkit::ik_internal {

Solver::Solver(IkClipJob& job, std::vector<int> ids, int* iterations)
    : job_(job), rig_(job.rig), options_(job.options), ids_(std::move(ids)), iterations_(iterations) {
  bones_ = rig_.size();
  effector_count_ = static_cast<int>(ids_.size());
  // The rig's size: the diagonal of its rest pose's bounding box.
  Vec3 lo = Vec3::Constant(kInf), hi = Vec3::Constant(-kInf);
  for (int b = 0; b < bones_; ++b) {
    const Vec3 head = rig_.head(b), tail = head + rig_.rest(b) * (rig_.length(b) * Vec3::UnitY());
    lo = lo.cwiseMin(head).cwiseMin(tail);
    hi = hi.cwiseMax(head).cwiseMax(tail);
  }
  size_ = options_.size > 0 ? options_.size : std::max((hi - lo).norm(), 1e-300);
  lambda_ = options_.damping > 0 ? options_.damping : 1e-3 * size_;
  ls_ = options_.orientation_scale > 0 ? options_.orientation_scale : 0.1 * size_;
  mu_ = options_.regularization;
  tolerance_ = options_.tolerance;
  priorities_ = options_.priorities && options_.method == IkMethod::kDls;
  pin_tolerance_ = priorities_ ? std::min(tolerance_, 1e-7 * size_) : tolerance_;
  for (int id : ids_) pinned_ = pinned_ || At(job.effectors, id).pin;
  balance_ = priorities_ && options_.balance && pinned_;

  std::vector<char> need(static_cast<std::size_t>(bones_), balance_ ? 1 : 0);  // balance weighs every bone
  for (int id : ids_) {
    for (int b = At(job.effectors, id).bone; b >= 0; b = rig_.parent(b)) At(need, b) = 1;
  }
  for (int b = 0; b < bones_; ++b) {
    if (At(need, b)) needed_.push_back(b);
  }
  PlanJoints();
  std::vector<char> moves(static_cast<std::size_t>(bones_), 0);
  for (int b : needed_) {
    const int p = rig_.parent(b);
    At(moves, b) = At(joint_of_, b) >= 0 || (p >= 0 ? At(moves, p) : b == 0 && translate_);
    (At(moves, b) ? moving_ : fixed_).push_back(b);
  }
  stage_ = stages_ - 1;
  separate_prior_ = priorities_ && stages_ > 1;
  for (Joint& j : joints_) {
    for (int id : ids_) {
      const IkEffector& e = At(job.effectors, id);
      j.pinned_chain = j.pinned_chain || (e.pin && rig_.IsAncestor(j.bone, e.bone));
    }
  }
  PlanEffectors();
  PlanBalance();
  PlanCcd();

  input_ = MakePose();
  current_ = MakePose();
  trial_ = MakePose();
  reference_ = MakePose();
  solution_ = MakePose();
  earlier_ = MakePose();
  backup_ = MakePose();
  best_ = MakePose();
  fk_ = MakeFk();
  trial_fk_ = MakeFk();
  target_position_.assign(static_cast<std::size_t>(effector_count_), Vec3::Zero());
  target_orientation_.assign(static_cast<std::size_t>(effector_count_), Quat::Identity());
  const auto rows = static_cast<std::size_t>(rows_), cols = static_cast<std::size_t>(cols_);
  for (std::vector<double>* v : {&e_, &r_, &y_, &h_, &hold_}) v->assign(rows, 0.0);
  s_.assign(rows * rows, 0.0);
  for (std::vector<double>* v : {&u_, &u0_, &g_, &w_, &rho_, &trial_rho_}) v->assign(cols, 0.0);
  for (auto* v : {&axes_, &bend_world_, &bend_, &weight_}) v->assign(joints_.size(), Eigen::Matrix3d::Zero());
  met_.assign(static_cast<std::size_t>(effector_count_), 0);
  frozen_.assign(cols, 0);
  staged_out_.assign(cols, 0);
  fk_.moment.assign(static_cast<std::size_t>(bones_), Vec3::Zero());
  fk_scratch_ = MakeFk();
  h_scratch_.assign(rows, 0.0);
  trial_fk_.moment = fk_.moment;
  rotation_sum_.assign(joints_.size(), Vec3::Zero());
  scale_sum_.assign(joints_.size(), 0.0);
  shift_sum_.assign(static_cast<std::size_t>(effector_count_), Vec3::Zero());
  aside_.assign(static_cast<std::size_t>(effector_count_), Vec3::Zero());
  level_rows_.assign(rows, 0);
  held_rows_.assign(rows, 0);
  level_a_.assign(rows * rows, 0.0);
  level_x_.assign(rows * rows, 0.0);
  level_t_.assign(rows * rows, 0.0);
  level_r_.assign(2 * rows, 0.0);
  const auto points = static_cast<std::size_t>(3 + effector_count_);
  ccd_points_.assign(points, Vec3::Zero());
  ccd_targets_.assign(points, Vec3::Zero());
  ccd_weights_.assign(points, 0.0);
  ccd_placed_.assign(points, 0);
  coordinates_.assign(joints_.size(), Vec3::Zero());
  kick_.assign(joints_.size(), 0);
}

void Solver::PlanJoints() {
  const auto limits_of = [&](int b) { return job_.joints.empty() ? IkJoint{} : At(job_.joints, b); };
  joint_of_.assign(static_cast<std::size_t>(bones_), -1);
  const bool root_needed = !needed_.empty() && needed_.front() == 0;
  translate_ = options_.root_translation && root_needed && !limits_of(0).excluded;
  if (translate_) {
    for (int k = 0; k < 3; ++k) {
      const int stage = std::max(0, limits_of(0).stage);
      columns_.push_back({Kind::kTranslate, -1, k, 1.0, StageCost(stage) / (ls_ * ls_), stage});
    }
  }
  // Only the effectors' paths are solved (balance places every bone, but moves none off them).
  std::vector<char> on_path(static_cast<std::size_t>(bones_), 0);
  for (int id : ids_) {
    for (int b = At(job_.effectors, id).bone; b >= 0; b = rig_.parent(b)) At(on_path, b) = 1;
  }
  for (int b : needed_) {
    const IkJoint limits = limits_of(b);
    if (!At(on_path, b) || limits.excluded || (b == 0 && !options_.root_rotation)) continue;
    Joint j;
    j.bone = b;
    j.stage = std::max(0, limits.stage);
    stages_ = std::max(stages_, j.stage + 1);
    j.first_column = static_cast<int>(columns_.size());
    for (int k = 0; k < 3; ++k) {
      const bool locked = limits.locked[static_cast<std::size_t>(k)];
      j.lo[k] = j.base_lo[k] = locked ? 0.0 : limits.min[k];
      j.hi[k] = j.base_hi[k] = locked ? 0.0 : limits.max[k];
      j.soft[static_cast<std::size_t>(k)] = limits.soft[static_cast<std::size_t>(k)] && !locked;
      // Swing components and the twist angle never leave [-pi, pi].
      if (j.lo[k] > -kPi || j.hi[k] < kPi) j.limited = true;
      j.free[static_cast<std::size_t>(k)] = !locked;
      if (locked) continue;
      const auto slot = static_cast<std::size_t>(j.axis_count++);
      j.axes[slot] = k;
      j.axis_scale[slot] = 1.0 - limits.stiffness[k];
      columns_.push_back({Kind::kRotate, static_cast<int>(joints_.size()), k, j.axis_scale[slot], StageCost(j.stage),
                          j.stage});
    }
    if (limits.stretch > 0.0) {
      j.stretch = limits.stretch;
      j.min_scale = limits.min_scale;
      j.max_scale = limits.max_scale;
      j.stretch_column = static_cast<int>(columns_.size());
      columns_.push_back({Kind::kStretch, static_cast<int>(joints_.size()), 1, limits.stretch, StageCost(j.stage),
                          j.stage});
    }
    At(joint_of_, b) = static_cast<int>(joints_.size());
    joints_.push_back(j);
  }
  cols_ = static_cast<int>(columns_.size());
}

void Solver::PlanEffectors() {
  rows_ = 0;
  std::vector<int> path;
  for (int id : ids_) {
    const IkEffector& in = At(job_.effectors, id);
    Effector e;
    e.bone = in.bone;
    e.position = in.position;
    e.orientation = in.orientation;
    e.pin = in.pin;
    e.sqrt_weight = std::sqrt(in.weight) * (priorities_ && in.pin ? kPinScale : 1.0);
    e.level = in.pin ? 1 : 3;
    e.row = rows_;
    e.rows = (in.position ? 3 : 0) + (in.orientation ? 3 : 0);
    rows_ += e.rows;
    path.clear();
    for (int b = in.bone; b >= 0; b = rig_.parent(b)) path.push_back(b);
    std::reverse(path.begin(), path.end());
    if (translate_ && path.front() == 0) {
      for (int k = 0; k < 3; ++k) {
        e.segments.push_back({static_cast<int>(e.columns.size()), 1, -1});
        e.columns.push_back(k);
        e.levers.push_back(0.0);
      }
    }
    for (std::size_t i = 0; i < path.size(); ++i) {
      const int jo = At(joint_of_, path[i]);
      if (jo < 0) continue;
      const Joint& j = At(joints_, jo);
      if (j.axis_count > 0) e.segments.push_back({static_cast<int>(e.columns.size()), j.axis_count, jo});
      for (int k = 0; k < j.axis_count; ++k) {
        e.columns.push_back(j.first_column + k);
        e.levers.push_back(0.0);
      }
      if (j.stretch_column >= 0) {
        e.segments.push_back({static_cast<int>(e.columns.size()), 1, -1});
        // The effector is this bone's tail, or hangs from the head of a child
        // whose offset along the bone the scale stretches.
        e.columns.push_back(j.stretch_column);
        e.levers.push_back(i + 1 == path.size() ? rig_.length(path[i]) : rig_.offset(path[i + 1]).y());
      }
    }
    e.block.assign(static_cast<std::size_t>(e.rows) * e.columns.size(), 0.0);
    e.wblock = e.block;
    effectors_.push_back(std::move(e));
  }
  for (Effector& a : effectors_) {
    for (const Effector& b : effectors_) {
      std::size_t c = 0;
      while (c < a.columns.size() && c < b.columns.size() && a.columns[c] == b.columns[c]) ++c;
      a.prefix.push_back(static_cast<int>(c));
    }
  }
}

// The centre of mass's rows: every column, one segment per joint; the
// bones' masses and their subtrees'; the support's bones; the horizontal axes.
void Solver::PlanBalance() {
  if (!balance_) return;
  mass_.assign(static_cast<std::size_t>(bones_), 0.0);
  subtree_mass_.assign(static_cast<std::size_t>(bones_), 0.0);
  for (int b = 0; b < bones_; ++b) {
    const double given = job_.joints.empty() ? -1.0 : At(job_.joints, b).mass;
    At(mass_, b) = given >= 0.0 ? given : rig_.length(b);
  }
  for (int b = bones_ - 1; b >= 0; --b) {
    At(subtree_mass_, b) += At(mass_, b);
    if (rig_.parent(b) >= 0) At(subtree_mass_, rig_.parent(b)) += At(subtree_mass_, b);
  }
  for (int b = 0; b < bones_; ++b) {
    if (rig_.parent(b) < 0) total_mass_ += At(subtree_mass_, b);
  }
  if (!(total_mass_ > 0.0)) {
    balance_ = false;
    return;
  }
  up_ = options_.up.normalized();
  side_ = up_.unitOrthogonal();
  ahead_ = up_.cross(side_);
  margin_ = options_.balance_margin > 0.0 ? options_.balance_margin : 0.005 * size_;
  for (int b = 0; b < bones_; ++b) {
    for (const Effector& e : effectors_) {
      if (e.pin && rig_.IsAncestor(e.bone, b)) {
        support_bones_.push_back(b);
        break;
      }
    }
  }
  support_.assign(2 * support_bones_.size() + 1, Eigen::Vector2d::Zero());
  // Clipping a convex polygon by a line adds at most one corner: the box's 4, then one per hull edge.
  inner_.assign(2 * support_bones_.size() + 8, Eigen::Vector2d::Zero());
  clip_ = inner_;
  com_.bone = -1;
  com_.level = 2;
  com_.row = rows_;
  com_.rows = 3;
  com_.sqrt_weight = kBalanceScale;
  rows_ += 3;
  for (int c = 0; c < cols_; ++c) {
    const Column& column = columns_[static_cast<std::size_t>(c)];
    if (column.kind != Kind::kRotate || column.axis == At(joints_, column.joint).axes[0]) {
      const int jo = column.kind == Kind::kRotate ? column.joint : -1;
      com_.segments.push_back({c, jo >= 0 ? At(joints_, jo).axis_count : 1, jo});
    }
    com_.columns.push_back(c);
    com_.levers.push_back(0.0);
  }
  com_.block.assign(3 * static_cast<std::size_t>(cols_), 0.0);
  com_.wblock = com_.block;
}

void Solver::PlanCcd() {
  body_ = translate_ && At(joint_of_, 0) >= 0;
  const auto lowest_common = [&](int a, int b) {
    for (int x = a; x >= 0; x = rig_.parent(x)) {
      if (rig_.IsAncestor(x, b)) return x;
    }
    return -1;
  };
  for (int ei = 0; ei < effector_count_; ++ei) {
    Effector& e = At(effectors_, ei);
    // Ordinary links from the effector's bone up to `stop` (exclusive).
    const auto ordinary = [&](int stop, bool pin) {
      int child = -1;
      for (int b = e.bone; b >= 0 && b != stop; child = b, b = rig_.parent(b)) {
        if (pin) {  // a pin's own links are the bones no other effector hangs from
          bool shared = false;
          for (int o = 0; o < effector_count_; ++o) {
            if (o != ei && rig_.IsAncestor(b, At(effectors_, o).bone)) shared = true;
          }
          if (shared) break;
        }
        const int jo = At(joint_of_, b);
        if (jo < 0) continue;
        const double lever = child < 0 ? rig_.length(b) : rig_.offset(child).y();
        e.ccd.push_back({jo, false, -1, lever});
      }
    };
    if (e.pin) {
      ordinary(-1, true);
      continue;
    }
    // Through the root towards the first pin on another branch, if the body can move.
    int anchor = -1, meet = -1;
    for (int a = 0; body_ && a < effector_count_ && anchor < 0; ++a) {
      const Effector& pin = At(effectors_, a);
      if (!pin.pin || rig_.IsAncestor(pin.bone, e.bone) || rig_.IsAncestor(e.bone, pin.bone)) continue;
      const int lca = lowest_common(pin.bone, e.bone);
      if (lca < 0) continue;
      bool any = false;
      for (int b = pin.bone; b != lca; b = rig_.parent(b)) any = any || At(joint_of_, b) >= 0;
      if (any) {
        anchor = a;
        meet = lca;
      }
    }
    ordinary(meet, false);
    if (anchor >= 0) {
      const std::size_t first = e.ccd.size();
      for (int b = At(effectors_, anchor).bone; b != meet; b = rig_.parent(b)) {
        if (At(joint_of_, b) >= 0) e.ccd.push_back({At(joint_of_, b), true, anchor, 0.0});
      }
      std::reverse(e.ccd.begin() + static_cast<std::ptrdiff_t>(first), e.ccd.end());
    }
  }
  for (int pass = 0; pass < 2; ++pass) {
    for (int e = 0; e < effector_count_; ++e) {
      if (At(effectors_, e).pin == (pass == 1)) ccd_order_.push_back(e);
    }
  }
}

}  // namespace motionkit::ik_internal
