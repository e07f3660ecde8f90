// Building a solve group's Model: the rig's size and the defaults it scales, the solved joints and
// their columns, each effector's path, the balance's masses and support, the CCD chains.
#include "solver.hpp"

namespace motionkit::ik_internal {

namespace {

// The rig's size: the diagonal of its rest pose's bounding box.
double RigSize(const RigModel& rig) {
  Vec3 lo = Vec3::Constant(kInf), hi = Vec3::Constant(-kInf);
  for (int b = 0; b < rig.size(); ++b) {
    const Vec3 head = rig.head(b), tail = head + rig.rest(b) * (rig.length(b) * Vec3::UnitY());
    lo = lo.cwiseMin(head).cwiseMin(tail);
    hi = hi.cwiseMax(head).cwiseMax(tail);
  }
  return std::max((hi - lo).norm(), 1e-300);
}

// Marks each effector's bone and its ancestors.
std::vector<char> OnPaths(const Model& m, char others) {
  std::vector<char> on(static_cast<std::size_t>(m.bones), others);
  for (int id : m.ids) {
    for (int b = At(m.job.effectors, id).bone; b >= 0; b = m.rig.parent(b)) At(on, b) = 1;
  }
  return on;
}

// The joint of bone b, its columns appended (none when it has no free axis and no stretch).
Joint MakeJoint(Model& m, int b, const IkJoint& limits) {
  Joint j;
  j.bone = b;
  j.stage = std::max(0, limits.stage);
  m.stages = std::max(m.stages, j.stage + 1);
  j.first_column = static_cast<int>(m.columns.size());
  const int index = static_cast<int>(m.joints.size());
  for (int k = 0; k < 3; ++k) {
    const bool locked = limits.locked[static_cast<std::size_t>(k)];
    j.lo[k] = locked ? 0.0 : limits.min[k];
    j.hi[k] = locked ? 0.0 : limits.max[k];
    j.soft[static_cast<std::size_t>(k)] = limits.soft[static_cast<std::size_t>(k)] && !locked;
    // Swing components and the twist angle never leave [-pi, pi].
    if (j.lo[k] > -kPi || j.hi[k] < kPi) j.limited = true;
    j.free[static_cast<std::size_t>(k)] = !locked;
    if (locked) continue;
    const auto slot = static_cast<std::size_t>(j.axis_count++);
    j.axes[slot] = k;
    j.axis_scale[slot] = 1.0 - limits.stiffness[k];
    m.columns.push_back({Kind::kRotate, index, k, j.axis_scale[slot], StageCost(j.stage), j.stage});
  }
  if (limits.stretch > 0.0) {
    j.stretch = limits.stretch;
    j.min_scale = limits.min_scale;
    j.max_scale = limits.max_scale;
    j.stretch_column = static_cast<int>(m.columns.size());
    m.columns.push_back({Kind::kStretch, index, 1, limits.stretch, StageCost(j.stage), j.stage});
  }
  return j;
}

void PlanJoints(Model& m) {
  const auto limits_of = [&](int b) { return m.job.joints.empty() ? IkJoint{} : At(m.job.joints, b); };
  m.joint_of.assign(static_cast<std::size_t>(m.bones), -1);
  const bool root_needed = !m.order.needed.empty() && m.order.needed.front() == 0;
  m.translate = m.options.root_translation && root_needed && !limits_of(0).excluded;
  if (m.translate) {
    for (int k = 0; k < 3; ++k) {
      const int stage = std::max(0, limits_of(0).stage);
      m.columns.push_back({Kind::kTranslate, -1, k, 1.0, StageCost(stage) / (m.ls * m.ls), stage});
    }
  }
  // Only the effectors' paths are solved (balance places every bone, but moves none off them).
  const std::vector<char> on_path = OnPaths(m, 0);
  for (int b : m.order.needed) {
    const IkJoint limits = limits_of(b);
    if (!At(on_path, b) || limits.excluded || (b == 0 && !m.options.root_rotation)) continue;
    const Joint j = MakeJoint(m, b, limits);
    At(m.joint_of, b) = static_cast<int>(m.joints.size());
    m.joints.push_back(j);
  }
  m.cols = static_cast<int>(m.columns.size());
}

// The effector's path: the root's translation, then its ancestors' columns, root first.
void PlanPath(const Model& m, Effector& e) {
  std::vector<int> path;
  for (int b = e.bone; b >= 0; b = m.rig.parent(b)) path.push_back(b);
  std::reverse(path.begin(), path.end());
  if (m.translate && path.front() == 0) {
    for (int k = 0; k < 3; ++k) {
      e.segments.push_back({static_cast<int>(e.columns.size()), 1, -1});
      e.columns.push_back(k);
      e.levers.push_back(0.0);
    }
  }
  for (std::size_t i = 0; i < path.size(); ++i) {
    const int jo = At(m.joint_of, path[i]);
    if (jo < 0) continue;
    const Joint& j = At(m.joints, jo);
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
      e.levers.push_back(i + 1 == path.size() ? m.rig.length(path[i]) : m.rig.offset(path[i + 1]).y());
    }
  }
}

void PlanEffectors(Model& m) {
  m.rows = 0;
  for (int id : m.ids) {
    const IkEffector& in = At(m.job.effectors, id);
    Effector e;
    e.bone = in.bone;
    e.position = in.position;
    e.orientation = in.orientation;
    e.pin = in.pin;
    e.sqrt_weight = std::sqrt(in.weight) * (m.priorities && in.pin ? kPinScale : 1.0);
    e.level = in.pin ? 1 : 3;
    e.row = m.rows;
    e.rows = (in.position ? 3 : 0) + (in.orientation ? 3 : 0);
    m.rows += e.rows;
    PlanPath(m, e);
    m.effectors.push_back(std::move(e));
  }
  for (Effector& a : m.effectors) {
    for (const Effector& b : m.effectors) {
      std::size_t c = 0;
      while (c < a.columns.size() && c < b.columns.size() && a.columns[c] == b.columns[c]) ++c;
      a.prefix.push_back(static_cast<int>(c));
    }
  }
}

// The bones' masses and their subtrees'; false when the rig weighs nothing.
bool PlanMasses(Model& m) {
  BalanceModel& bm = m.balance;
  bm.mass.assign(static_cast<std::size_t>(m.bones), 0.0);
  bm.subtree_mass.assign(static_cast<std::size_t>(m.bones), 0.0);
  for (int b = 0; b < m.bones; ++b) {
    const double given = m.job.joints.empty() ? -1.0 : At(m.job.joints, b).mass;
    At(bm.mass, b) = given >= 0.0 ? given : m.rig.length(b);
  }
  for (int b = m.bones - 1; b >= 0; --b) {
    At(bm.subtree_mass, b) += At(bm.mass, b);
    if (m.rig.parent(b) >= 0) At(bm.subtree_mass, m.rig.parent(b)) += At(bm.subtree_mass, b);
  }
  for (int b = 0; b < m.bones; ++b) {
    if (m.rig.parent(b) < 0) bm.total_mass += At(bm.subtree_mass, b);
  }
  return bm.total_mass > 0.0;
}

// The centre of mass's rows: every column, one segment per joint; the
// bones' masses; the support's bones; the horizontal axes.
void PlanBalance(Model& m) {
  BalanceModel& bm = m.balance;
  if (!bm.enabled) return;
  if (!PlanMasses(m)) {
    bm.enabled = false;
    return;
  }
  bm.up = m.options.up.normalized();
  bm.side = bm.up.unitOrthogonal();
  bm.ahead = bm.up.cross(bm.side);
  bm.margin = m.options.balance_margin > 0.0 ? m.options.balance_margin : 0.005 * m.size;
  for (int b = 0; b < m.bones; ++b) {
    for (const Effector& e : m.effectors) {
      if (e.pin && m.rig.IsAncestor(e.bone, b)) {
        bm.support_bones.push_back(b);
        break;
      }
    }
  }
  Effector& com = bm.com;
  com.bone = -1;
  com.level = 2;
  com.row = m.rows;
  com.rows = 3;
  com.sqrt_weight = kBalanceScale;
  m.rows += 3;
  for (int c = 0; c < m.cols; ++c) {
    const Column& column = At(m.columns, c);
    if (column.kind != Kind::kRotate || column.axis == At(m.joints, column.joint).axes[0]) {
      const int jo = column.kind == Kind::kRotate ? column.joint : -1;
      com.segments.push_back({c, jo >= 0 ? At(m.joints, jo).axis_count : 1, jo});
    }
    com.columns.push_back(c);
    com.levers.push_back(0.0);
  }
}

// Ordinary CCD links from effector ei's bone up to `stop` (exclusive); a pin's own links are the bones
// no other effector hangs from.
void AddOrdinaryLinks(Model& m, int ei, int stop) {
  Effector& e = At(m.effectors, ei);
  int child = -1;
  for (int b = e.bone; b >= 0 && b != stop; child = b, b = m.rig.parent(b)) {
    if (e.pin) {
      bool shared = false;
      for (int o = 0; o < m.effector_count; ++o) {
        if (o != ei && m.rig.IsAncestor(b, At(m.effectors, o).bone)) shared = true;
      }
      if (shared) break;
    }
    const int jo = At(m.joint_of, b);
    if (jo < 0) continue;
    const double lever = child < 0 ? m.rig.length(b) : m.rig.offset(child).y();
    e.ccd.push_back({jo, false, -1, lever});
  }
}

int LowestCommonAncestor(const RigModel& rig, int a, int b) {
  for (int x = a; x >= 0; x = rig.parent(x)) {
    if (rig.IsAncestor(x, b)) return x;
  }
  return -1;
}

// A target's chain runs through the root towards the first pin on another branch, if the body can
// move: the pin (-1: none) and where the two branches meet.
std::pair<int, int> BodyAnchor(const Model& m, const Effector& e) {
  for (int a = 0; m.body && a < m.effector_count; ++a) {
    const Effector& pin = At(m.effectors, a);
    if (!pin.pin || m.rig.IsAncestor(pin.bone, e.bone) || m.rig.IsAncestor(e.bone, pin.bone)) continue;
    const int lca = LowestCommonAncestor(m.rig, pin.bone, e.bone);
    if (lca < 0) continue;
    bool any = false;
    for (int b = pin.bone; b != lca; b = m.rig.parent(b)) any = any || At(m.joint_of, b) >= 0;
    if (any) return {a, lca};
  }
  return {-1, -1};
}

void PlanCcd(Model& m) {
  m.body = m.translate && At(m.joint_of, 0) >= 0;
  for (int ei = 0; ei < m.effector_count; ++ei) {
    Effector& e = At(m.effectors, ei);
    if (e.pin) {
      AddOrdinaryLinks(m, ei, -1);
      continue;
    }
    const auto [anchor, meet] = BodyAnchor(m, e);
    AddOrdinaryLinks(m, ei, meet);
    if (anchor >= 0) {
      const std::size_t first = e.ccd.size();
      for (int b = At(m.effectors, anchor).bone; b != meet; b = m.rig.parent(b)) {
        if (At(m.joint_of, b) >= 0) e.ccd.push_back({At(m.joint_of, b), true, anchor, 0.0});
      }
      std::reverse(e.ccd.begin() + static_cast<std::ptrdiff_t>(first), e.ccd.end());
    }
  }
  for (int pass = 0; pass < 2; ++pass) {
    for (int e = 0; e < m.effector_count; ++e) {
      if (At(m.effectors, e).pin == (pass == 1)) m.ccd_order.push_back(e);
    }
  }
}

// The bones FK visits, and which of them move.
void PlanFkOrder(Model& m) {
  const std::vector<char> need = OnPaths(m, m.balance.enabled ? 1 : 0);  // balance weighs every bone
  for (int b = 0; b < m.bones; ++b) {
    if (At(need, b)) m.order.needed.push_back(b);
  }
}

void SplitFixedAndMoving(Model& m) {
  std::vector<char> moves(static_cast<std::size_t>(m.bones), 0);
  for (int b : m.order.needed) {
    const int p = m.rig.parent(b);
    At(moves, b) = At(m.joint_of, b) >= 0 || (p >= 0 ? At(moves, p) : b == 0 && m.translate);
    (At(moves, b) ? m.order.moving : m.order.fixed).push_back(b);
  }
}

}  // namespace

Model::Model(const IkClipJob& job_in, std::vector<int> ids_in)
    : job(job_in), rig(job_in.rig), options(job_in.options), ids(std::move(ids_in)) {
  bones = rig.size();
  effector_count = static_cast<int>(ids.size());
  size = options.size > 0 ? options.size : RigSize(rig);
  lambda = options.damping > 0 ? options.damping : 1e-3 * size;
  ls = options.orientation_scale > 0 ? options.orientation_scale : 0.1 * size;
  mu = options.regularization;
  tolerance = options.tolerance > 0 ? options.tolerance : 3e-7 * size;
  priorities = options.priorities && options.method == IkMethod::kDls;
  pin_tolerance = priorities ? std::min(tolerance, 1e-7 * size) : tolerance;
  for (int id : ids) pinned = pinned || At(job.effectors, id).pin;
  balance.enabled = priorities && options.balance && pinned;
  PlanFkOrder(*this);
  PlanJoints(*this);
  SplitFixedAndMoving(*this);
  separate_prior = priorities && stages > 1;
  for (Joint& j : joints) {
    for (int id : ids) {
      const IkEffector& e = At(job.effectors, id);
      j.pinned_chain = j.pinned_chain || (e.pin && rig.IsAncestor(j.bone, e.bone));
    }
  }
  PlanEffectors(*this);
  PlanBalance(*this);
  PlanCcd(*this);
}

}  // namespace motionkit::ik_internal
