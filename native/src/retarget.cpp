#include "motionkit/retarget.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "parallel.hpp"
#include "so3.hpp"

namespace motionkit {

namespace {

const Eigen::Vector3d kBoneAxis = Eigen::Vector3d::UnitY();  // Blender bones run along their Y axis

std::string Bone(const RigModel& rig, int b) { return "'" + rig.name(b) + "'"; }

// How one target bone gets its orientation on every frame.
struct Drive {
  enum Kind { kKeep, kMapped, kChain } kind = kKeep;
  int from = -1;     // source bone (kMapped), or the chain's upper source bone (kChain)
  int to = -1;       // kChain: the lower source bone
  double alpha = 0;  // kChain: slerp parameter from `from` to `to`
  Eigen::Quaterniond align = Eigen::Quaterniond::Identity();  // the bone posed as the source's match pose
  double fit = -2;   // kChain: how well the chain continues this bone (for bones on two chains)
  double other_fit = -2;  // kChain: how well the next best chain through this bone continues it
};

// Source bones from just below `top` down to `bottom` (inclusive), top first.
std::vector<int> SourcePath(const RigModel& rig, int top, int bottom) {
  std::vector<int> path;
  for (int b = bottom; b != top && b >= 0; b = rig.parent(b)) path.push_back(b);
  std::reverse(path.begin(), path.end());
  return path;
}

// Heads of every bone of `rig` posed with world orientations `globals` (root heads at the rest's).
std::vector<Eigen::Vector3d> PosedHeads(const RigModel& rig, const std::vector<Eigen::Quaterniond>& globals) {
  std::vector<Eigen::Vector3d> heads(static_cast<std::size_t>(rig.size()));
  for (int b = 0; b < rig.size(); ++b) {
    const int p = rig.parent(b);
    heads[static_cast<std::size_t>(b)] =
        p < 0 ? rig.offset(b)
              : Eigen::Vector3d(heads[static_cast<std::size_t>(p)] + globals[static_cast<std::size_t>(p)] * rig.offset(b));
  }
  return heads;
}

// The rest of the job's state, set up once per Run from the match poses.
class Plan {
 public:
  explicit Plan(const RetargetJob& job) : job_(job) {
    const RigModel& t = job.target;
    const int nt = t.size();
    match_.resize(static_cast<std::size_t>(nt));
    for (int b = 0; b < nt; ++b) {
      const Eigen::Quaterniond basis = QuatAt(job.target_match_basis, 0, b).normalized();
      const int p = t.parent(b);
      match_[static_cast<std::size_t>(b)] =
          ((p < 0 ? Eigen::Quaterniond::Identity() : match_[static_cast<std::size_t>(p)]) * t.relative(b) * basis)
              .normalized();
      match_basis_.push_back(basis);
    }
    const int ns = job.source.size();
    std::vector<Eigen::Quaterniond> source_match(static_cast<std::size_t>(ns));
    source_match_inverse_.resize(static_cast<std::size_t>(ns));
    for (int a = 0; a < ns; ++a) {
      source_match[static_cast<std::size_t>(a)] = QuatAt(job.source_match, 0, a).normalized();
      source_match_inverse_[static_cast<std::size_t>(a)] = source_match[static_cast<std::size_t>(a)].conjugate();
    }
    source_heads_ = PosedHeads(job.source, source_match);
    target_heads_ = PosedHeads(t, match_);
    drives_.resize(static_cast<std::size_t>(nt));
    kept_.assign(static_cast<std::size_t>(nt), false);
    for (int b : job.options.posture_bones) kept_[static_cast<std::size_t>(b)] = true;
    always_.assign(static_cast<std::size_t>(nt), false);
    for (int b : job.options.posture_always) {
      kept_[static_cast<std::size_t>(b)] = always_[static_cast<std::size_t>(b)] = true;
    }
    for (int b = 0; b < nt; ++b) {
      const int a = job.bone_map[static_cast<std::size_t>(b)];
      if (a < 0) continue;
      Drive& d = drives_[static_cast<std::size_t>(b)];
      d.kind = Drive::kMapped;
      d.from = a;
    }
    CountMappedBranches();
    spanned_.assign(static_cast<std::size_t>(nt), false);
    helper_.assign(static_cast<std::size_t>(nt), false);
    for (int b : job.options.helper_bones) helper_[static_cast<std::size_t>(b)] = true;
    for (int b = 0; b < nt; ++b) {
      if (job.bone_map[static_cast<std::size_t>(b)] >= 0) PlanChain(b);
    }
    for (int b = 0; b < nt; ++b) {
      if (spanned_[static_cast<std::size_t>(b)]) drives_[static_cast<std::size_t>(b)].kind = Drive::kKeep;
    }
    // A bone two chains continue alike (a pelvis both legs hang from) follows neither: it is carried.
    for (Drive& d : drives_) {
      if (d.kind == Drive::kChain && d.other_fit > d.fit - kTie) d.kind = Drive::kKeep;
    }
    AlignDownTheHierarchy();
  }

  const Drive& drive(int b) const { return drives_[static_cast<std::size_t>(b)]; }
  const Eigen::Quaterniond& match(int b) const { return match_[static_cast<std::size_t>(b)]; }
  bool kept(int b) const { return kept_[static_cast<std::size_t>(b)]; }
  const Eigen::Quaterniond& match_basis(int b) const { return match_basis_[static_cast<std::size_t>(b)]; }
  const Eigen::Quaterniond& source_match_inverse(int a) const {
    return source_match_inverse_[static_cast<std::size_t>(a)];
  }

 private:
  // Where the source points in the match pose, between bones `from` and `to`
  // at alpha, in target armature space.
  Eigen::Vector3d SourceDirection(int from, int to, double alpha) const {
    const Eigen::Quaterniond qa = source_match_inverse(from).conjugate();
    const Eigen::Quaterniond qb = source_match_inverse(to).conjugate();
    const Eigen::Vector3d aim = ((1.0 - alpha) * Aim(job_.source_aims, from) + alpha * Aim(job_.source_aims, to));
    return job_.options.space * (qa.slerp(alpha, qb) * aim.normalized());
  }

  // Where a bone points in its own frame: its Y axis unless the caller says otherwise.
  static Eigen::Vector3d Aim(const RowMatrixXd& aims, int bone) {
    if (aims.rows() == 0) return kBoneAxis;
    return aims.row(bone).transpose().normalized();
  }

  // The target posed as the source's match pose (each drive's `align`), parents first: a bone is carried
  // by its aligned parent, as an animator turning a T-pose into an A-pose carries the hand with the arm,
  // then turned the shortest way onto the source's direction, and a mapped bone with children spread
  // about its line (a hand's fingers, hips' thighs) turned about that line onto the source's spread.
  void AlignDownTheHierarchy() {
    const RigModel& t = job_.target;
    for (int b = 0; b < t.size(); ++b) {
      Drive& d = drives_[static_cast<std::size_t>(b)];
      const int p = t.parent(b);
      const Eigen::Quaterniond carried =
          (p < 0 ? Eigen::Quaterniond::Identity() : drives_[static_cast<std::size_t>(p)].align) * t.relative(b) *
          match_basis(b);
      if (d.kind == Drive::kKeep) {
        d.align = carried.normalized();
        continue;
      }
      const Eigen::Vector3d direction = d.kind == Drive::kMapped ? SourceDirection(d.from, d.from, 0.0)
                                                                 : SourceDirection(d.from, d.to, d.alpha);
      const Eigen::Vector3d own = carried * Aim(job_.target_aims, b);
      // A bone kept where its parents carry it unless it then points across the source's: a capture's foot
      // pointing down its shin, an arm lying along a zero pose's spine turned upright, are poses.
      const auto i = static_cast<std::size_t>(b);
      const bool kept = kept_[i] && (always_[i] || own.normalized().dot(direction.normalized()) >= kPostureCos);
      kept_[i] = kept;
      if (kept) {
        d.align = carried.normalized();
        continue;
      }
      d.align = (Eigen::Quaterniond::FromTwoVectors(own, direction) * carried).normalized();
      if (d.kind == Drive::kMapped) d.align = (SpreadTurn(b, d.align, direction.normalized()) * d.align).normalized();
    }
  }

  // The turn about `axis` that lays the target's mapped children around bone b (posed `aligned`) best onto
  // the source's around its bone, each child's head seen from its bone's head and taken as a direction;
  // none where fewer than two children stand off the line or the two spreads do not agree.
  Eigen::Quaterniond SpreadTurn(int b, const Eigen::Quaterniond& aligned, const Eigen::Vector3d& axis) const {
    const RigModel& t = job_.target;
    const int a = job_.bone_map[static_cast<std::size_t>(b)];
    const Eigen::Quaterniond to_aligned = aligned * match(b).conjugate();
    double along = 0.0, across = 0.0, weight = 0.0;
    int spread = 0;
    for (int c = b + 1; c < t.size(); ++c) {
      const int ac = job_.bone_map[static_cast<std::size_t>(c)];
      if (ac < 0 || ac == a || !job_.source.IsAncestor(a, ac) || NearestMappedAbove(c) != b) continue;
      const Eigen::Vector3d target_offset =
          to_aligned * (target_heads_[static_cast<std::size_t>(c)] - target_heads_[static_cast<std::size_t>(b)]);
      const Eigen::Vector3d source_offset =
          job_.options.space *
          (source_heads_[static_cast<std::size_t>(ac)] - source_heads_[static_cast<std::size_t>(a)]);
      if (target_offset.norm() < 1e-12 || source_offset.norm() < 1e-12) continue;
      const Eigen::Vector3d pt = Across(axis, target_offset.normalized());
      const Eigen::Vector3d ps = Across(axis, source_offset.normalized());
      if (pt.norm() > kOffLine && ps.norm() > kOffLine) ++spread;
      along += pt.dot(ps);
      across += axis.dot(pt.cross(ps));
      weight += pt.norm() * ps.norm();
    }
    if (spread < 2 || std::hypot(along, across) < 0.5 * weight) return Eigen::Quaterniond::Identity();
    return Eigen::Quaterniond(Eigen::AngleAxisd(std::atan2(across, along), axis));
  }

  static constexpr double kPostureCos = 0.7071067811865476;  // cos 45 degrees: bodies differ less, poses more
  static constexpr double kOffLine = 0.17;  // sin 10 degrees: a child head this far off the line shows a roll
  static constexpr double kTie = 0.05;      // chains continuing a bone within this (in cosine) are alike
  static constexpr double kSpans = 0.99999;  // cos 0.26 degrees: a bone aimed at a head (bone_axes) points at it

  static Eigen::Vector3d Across(const Eigen::Vector3d& axis, const Eigen::Vector3d& v) {
    return v - v.dot(axis) * axis;
  }

  int NearestMappedAbove(int c) const {
    int up = job_.target.parent(c);
    while (up >= 0 && job_.bone_map[static_cast<std::size_t>(up)] < 0) up = job_.target.parent(up);
    return up;
  }

  // Unmapped target bones between mapped `b` and its nearest mapped ancestor.
  void PlanChain(int b) {
    const RigModel& t = job_.target;
    const RigModel& s = job_.source;
    std::vector<int> chain{b};
    int top = t.parent(b);
    while (top >= 0 && job_.bone_map[static_cast<std::size_t>(top)] < 0) {
      chain.push_back(top);
      top = t.parent(top);
    }
    if (top < 0 || chain.size() < 2) return;
    // Helper joints between (Mixamo's `*_split` joints, options.helper_bones) are carried, unturned, as
    // Mixamo's own retargets leave them: in a chain kept in the target's posture always (each mapped bone
    // carries its source bone's turn, whatever the top bone's axis points at: a bone whose children all
    // start at its head points nowhere), in a matched one where the top bone aims past them at b (a
    // clavicle past a `*_split` joint at its arm, core/bone_axes) and so spans the chain itself, as the
    // source's one bone does. Other joints between (a two-bone neck's, a spine's) are segments: they share
    // the turn.
    if (AllHelpers(chain) && (AllKept(chain) || SpansHelpers(top, chain))) {
      for (std::size_t j = 1; j < chain.size(); ++j) spanned_[static_cast<std::size_t>(chain[j])] = true;
      return;
    }
    const int a = job_.bone_map[static_cast<std::size_t>(b)];
    const int a0 = job_.bone_map[static_cast<std::size_t>(top)];
    if (a0 == a || !s.IsAncestor(a0, a)) return;
    std::reverse(chain.begin(), chain.end());
    const std::vector<int> path = SourcePath(s, a0, a);
    // Where a0 only leads on to a (a neck to its head), the source's span runs from a0's head to a's tail
    // against the target's from top's head to b's tail: a target bone whose tail lies within a0's own
    // reach continues a0 (a two-bone neck under a one-bone neck shares its turn), one beyond it blends the
    // source bones its tail lies between. Where a0 branches (a chest carrying arms and a head), its reach
    // is no chain's: the span runs from a0's tail, the target's from top's.
    const bool through = mapped_branches_[static_cast<std::size_t>(a0)] == 1;
    const std::vector<double> source_ends = Ends(s, source_heads_, a0, path, through);
    const std::vector<double> target_ends = Ends(t, target_heads_, top, chain, through);
    for (std::size_t j = 0; j + 1 < chain.size(); ++j) {
      const int c = chain[j];
      const double f = target_ends[j + 2] / target_ends.back() * source_ends.back();
      std::size_t i = 1;
      while (i + 1 < source_ends.size() && source_ends[i] < f) ++i;
      const int upper = i <= 2 ? a0 : path[i - 3];
      const int lower = i == 1 ? a0 : path[i - 2];
      const double span = source_ends[i] - source_ends[i - 1];
      const double alpha = i == 1 || span <= 0.0 ? 0.0 : std::clamp((f - source_ends[i - 1]) / span, 0.0, 1.0);
      // A bone on two chains (an unmapped chest under the neck and both
      // arms) follows the one that continues it best.
      const Eigen::Vector3d own = t.rest(c) * kBoneAxis;
      const double fit = own.dot(t.rest(chain[j + 1]) * kBoneAxis);
      Drive& d = drives_[static_cast<std::size_t>(c)];
      if (d.kind == Drive::kChain && d.fit >= fit) {
        d.other_fit = std::max(d.other_fit, fit);
        continue;
      }
      if (d.kind == Drive::kChain) d.other_fit = d.fit;
      d.kind = Drive::kChain;
      d.from = upper;
      d.to = lower;
      d.alpha = alpha;
      d.fit = fit;
    }
  }

  // Whether `top` points at the chain's mapped end (chain[0]).
  bool SpansHelpers(int top, const std::vector<int>& chain) const {
    const Eigen::Vector3d to_end =
        target_heads_[static_cast<std::size_t>(chain[0])] - target_heads_[static_cast<std::size_t>(top)];
    return to_end.norm() >= 1e-12 && (match(top) * Aim(job_.target_aims, top)).dot(to_end.normalized()) > kSpans;
  }

  // Whether every joint between the chain's mapped end (chain[0]) and its top is a helper (options.helper_bones),
  // and whether every one keeps its posture (options.posture_bones).
  bool AllHelpers(const std::vector<int>& chain) const {
    return std::all_of(chain.begin() + 1, chain.end(), [this](int c) { return helper_[static_cast<std::size_t>(c)]; });
  }
  bool AllKept(const std::vector<int>& chain) const {
    return std::all_of(chain.begin() + 1, chain.end(), [this](int c) { return kept_[static_cast<std::size_t>(c)]; });
  }

  // Where each bone of `first` then `bones` (a chain, top first) ends along it, from first's head: 0, then
  // each bone's reach to the next one's head (the last one's length); first's reach counted only
  // with_first (else 0: nothing ends within it).
  static std::vector<double> Ends(const RigModel& rig, const std::vector<Eigen::Vector3d>& heads, int first,
                                  const std::vector<int>& bones, bool with_first) {
    std::vector<int> all{first};
    all.insert(all.end(), bones.begin(), bones.end());
    std::vector<double> ends{0.0};
    for (std::size_t k = 0; k < all.size(); ++k) {
      double reach = rig.length(all[k]);
      if (k == 0 && !with_first) {
        reach = 0.0;
      } else if (k + 1 < all.size()) {
        reach = (heads[static_cast<std::size_t>(all[k + 1])] - heads[static_cast<std::size_t>(all[k])]).norm();
      }
      ends.push_back(ends.back() + reach);
    }
    return ends;
  }

  // How many of source bone a's children lead to a mapped source bone.
  // Per source bone, how many of its children lead to a mapped source bone; set once, before the chains.
  void CountMappedBranches() {
    const RigModel& s = job_.source;
    std::vector<bool> leads(static_cast<std::size_t>(s.size()), false);
    for (int m : job_.bone_map) {
      for (int x = m; x >= 0 && !leads[static_cast<std::size_t>(x)]; x = s.parent(x)) {
        leads[static_cast<std::size_t>(x)] = true;
      }
    }
    mapped_branches_.assign(static_cast<std::size_t>(s.size()), 0);
    for (int c = 0; c < s.size(); ++c) {
      const int p = s.parent(c);
      if (p >= 0 && leads[static_cast<std::size_t>(c)]) ++mapped_branches_[static_cast<std::size_t>(p)];
    }
  }

  const RetargetJob& job_;
  std::vector<Eigen::Quaterniond> match_, match_basis_, source_match_inverse_;
  std::vector<Eigen::Vector3d> source_heads_, target_heads_;
  std::vector<Drive> drives_;
  std::vector<bool> kept_;    // per target bone: keeps its own posture (options.posture_bones, posture_always)
  std::vector<bool> always_;  // per target bone: whatever the angle (options.posture_always)
  std::vector<int> mapped_branches_;  // per source bone: children leading to a mapped bone
  std::vector<bool> spanned_;         // per target bone: between a mapped bone and the one it aims at past it
  std::vector<bool> helper_;          // per target bone: options.helper_bones
};

// Poses the target frame by frame from the plan: every bone's orientation, written as its pose basis, then
// the root's location channel. Orientations are kept per frame in armature space (globals_), as children
// and the root's placement read them.
class TargetPoser {
 public:
  TargetPoser(RetargetJob& job, const Plan& plan)
      : job_(job),
        plan_(plan),
        space_(job.options.space.normalized()),
        space_inverse_(space_.conjugate()),
        globals_(static_cast<std::size_t>(job.target.size())),
        heads_(static_cast<std::size_t>(job.target.size())) {
    std::vector<Eigen::Quaterniond> match_globals(static_cast<std::size_t>(job.target.size()));
    for (int b = 0; b < job.target.size(); ++b) match_globals[static_cast<std::size_t>(b)] = plan.match(b);
    PoseHeads(match_globals, job.target_match_location);
    const int root = job.target_root;
    target_match_root_ = root >= 0 ? heads_[static_cast<std::size_t>(root)] : Eigen::Vector3d::Zero();
    // The target root's ancestors, top first: their heads place the root.
    for (int b = root >= 0 ? job.target.parent(root) : -1; b >= 0; b = job.target.parent(b)) {
      root_ancestors_.push_back(b);
    }
    std::reverse(root_ancestors_.begin(), root_ancestors_.end());
  }

  // The first frame this poser poses: its rotations are continuous from there on (MakeContinuousAcross
  // joins them to the frames before).
  void StartAt(Eigen::Index f) { first_frame_ = f; }

  void PoseFrame(Eigen::Index f) {
    for (int b = 0; b < job_.target.size(); ++b) PoseBoneAt(f, b);
    if (job_.target_root < 0) {
      job_.root_locations.row(f).setZero();
      return;
    }
    job_.root_locations.row(f) = RootLocation(WantedRootHead(f)).transpose();
  }

 private:
  Eigen::Quaterniond ParentGlobal(int b) const {
    const int p = job_.target.parent(b);
    return p < 0 ? Eigen::Quaterniond::Identity() : globals_[static_cast<std::size_t>(p)];
  }

  // Heads of every target bone posed with orientations `globals`, the root's location channel at
  // `root_location`.
  void PoseHeads(const std::vector<Eigen::Quaterniond>& globals, const Eigen::Vector3d& root_location) {
    const RigModel& target = job_.target;
    for (int b = 0; b < target.size(); ++b) {
      const int p = target.parent(b);
      heads_[static_cast<std::size_t>(b)] =
          PoseBone(target, b, p < 0 ? Eigen::Quaterniond::Identity() : globals[static_cast<std::size_t>(p)],
                   p < 0 ? Eigen::Vector3d::Zero() : heads_[static_cast<std::size_t>(p)],
                   Eigen::Quaterniond::Identity(), b == job_.target_root ? root_location : Eigen::Vector3d::Zero())
              .head;
    }
  }

  // How source bone a has turned from its match pose on frame f, in target armature space.
  Eigen::Quaterniond SourceTurn(Eigen::Index f, int a) const {
    return space_ * QuatAt(job_.source_rotations, f, a).normalized() * plan_.source_match_inverse(a) *
           space_inverse_;
  }

  // Bone b's orientation on frame f (its drive), kept in globals_ and written as its pose basis.
  void PoseBoneAt(Eigen::Index f, int b) {
    const Drive& d = plan_.drive(b);
    const Eigen::Quaterniond parent = ParentGlobal(b);
    Eigen::Quaterniond g;
    if (d.kind == Drive::kKeep) {
      g = RestFrame(job_.target, b, parent) * plan_.match_basis(b);
    } else {
      const Eigen::Quaterniond rotation =
          d.kind == Drive::kMapped ? SourceTurn(f, d.from) : SourceTurn(f, d.from).slerp(d.alpha, SourceTurn(f, d.to));
      g = rotation * d.align;
    }
    g.normalize();
    globals_[static_cast<std::size_t>(b)] = g;
    Eigen::Quaterniond basis = RestFrame(job_.target, b, parent).conjugate() * g;
    basis.normalize();
    StoreContinuous(job_.rotations, f, b, basis, first_frame_);
  }

  // The root's head on frame f: horizontally the match pose's, moved as the source root moved; along up
  // at the source root's height above its floor (as the root motion option says).
  Eigen::Vector3d WantedRootHead(Eigen::Index f) const {
    const RetargetOptions& options = job_.options;
    const Eigen::Vector3d& up = options.up;
    Eigen::Vector3d moved = Eigen::Vector3d::Zero();
    double height = 0.0;
    if (job_.source_root >= 0) {
      const Eigen::Vector3d head = job_.source_root_heads.row(f).transpose();
      moved = space_ * (head - job_.source_match_root);
      height = (space_ * head).dot(up) - options.source_floor;
    }
    const Eigen::Vector3d across = moved - moved.dot(up) * up;
    Eigen::Vector3d wanted = target_match_root_;
    double wanted_height = wanted.dot(up);
    switch (options.root_motion) {
      case RootMotion::kScaled:
        wanted += options.scale * options.scale_horizontal * across;
        wanted_height = options.target_floor + options.scale * height;
        break;
      case RootMotion::kInPlace:
        wanted_height = options.target_floor + options.scale * height;
        break;
      case RootMotion::kOffset:
        wanted += options.scale * options.scale_horizontal * across;
        wanted_height = options.target_floor + options.unit_scale * height + options.vertical_offset;
        break;
      case RootMotion::kNone:
        break;
    }
    wanted += (wanted_height - wanted.dot(up)) * up;
    return wanted;
  }

  // The root's location channel that puts its head at `wanted`: head = anchor + frame * location, from
  // the root's parent as posed this frame.
  Eigen::Vector3d RootLocation(const Eigen::Vector3d& wanted) const {
    const RigModel& target = job_.target;
    Eigen::Vector3d parent_head = Eigen::Vector3d::Zero();
    for (int b : root_ancestors_) {
      parent_head =
          PoseBone(target, b, ParentGlobal(b), parent_head, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero())
              .head;
    }
    const PosedBone at_rest = PoseBone(target, job_.target_root, ParentGlobal(job_.target_root), parent_head,
                                       Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero());
    return at_rest.frame.conjugate() * (wanted - at_rest.head);
  }

  RetargetJob& job_;
  const Plan& plan_;
  const Eigen::Quaterniond space_, space_inverse_;
  std::vector<Eigen::Quaterniond> globals_;  // this frame's orientations, armature space
  std::vector<Eigen::Vector3d> heads_;
  std::vector<int> root_ancestors_;
  Eigen::Vector3d target_match_root_ = Eigen::Vector3d::Zero();
  Eigen::Index first_frame_ = 0;
};

}  // namespace

std::optional<RootMotion> ParseRootMotion(std::string_view text) {
  if (text == "scaled") return RootMotion::kScaled;
  if (text == "in_place") return RootMotion::kInPlace;
  if (text == "offset") return RootMotion::kOffset;
  if (text == "none") return RootMotion::kNone;
  return std::nullopt;
}

Status RetargetJob::Validate() const {
  const int ns = source.size(), nt = target.size();
  const Eigen::Index frames = source_rotations.rows();
  if (source_rotations.cols() != 4 * ns) {
    return Status::Fail("retarget: source rotations need 4 columns per source bone");
  }
  if (source_root_heads.rows() != frames || source_root_heads.cols() != 3) {
    return Status::Fail("retarget: source root heads must be frames x 3");
  }
  if (source_match.rows() != 1 || source_match.cols() != 4 * ns) {
    return Status::Fail("retarget: the source match pose needs one row of 4 numbers per source bone");
  }
  if (target_match_basis.rows() != 1 || target_match_basis.cols() != 4 * nt) {
    return Status::Fail("retarget: the target match pose needs one row of 4 numbers per target bone");
  }
  if (rotations.rows() != frames || rotations.cols() != 4 * nt || root_locations.rows() != frames ||
      root_locations.cols() != 3) {
    return Status::Fail("retarget: outputs must be frames x 4 per target bone and frames x 3");
  }
  if (bone_map.size() != static_cast<std::size_t>(nt)) {
    return Status::Fail("retarget: the bone map needs one entry per target bone");
  }
  if (!(std::isfinite(options.scale) && options.scale > 0 && std::isfinite(options.unit_scale) &&
        options.unit_scale > 0 && std::isfinite(options.vertical_offset) && std::isfinite(options.scale_horizontal) &&
        options.scale_horizontal >= 0)) {
    return Status::Fail(
        "retarget: scale and unit_scale must be positive, scale_horizontal not negative, vertical_offset finite");
  }
  if (!options.up.allFinite() || std::abs(options.up.norm() - 1.0) > 1e-6) {
    return Status::Fail("retarget: up must be a unit vector");
  }
  if (!(std::isfinite(options.source_floor) && std::isfinite(options.target_floor))) {
    return Status::Fail("retarget: the floors' heights must be finite");
  }
  if (!internal::IsUnitQuaternion(options.space, 1e-6)) {
    return Status::Fail("retarget: the space rotation must be a unit quaternion");
  }
  if (!source_match_root.allFinite() || !target_match_location.allFinite()) {
    return Status::Fail("retarget: the match-pose root positions must be finite");
  }
  if (source_root < -1 || source_root >= ns || target_root < -1 || target_root >= nt) {
    return Status::Fail("retarget: root bone index out of range");
  }
  if (options.threads < 0) return Status::Fail("retarget: threads must be 0 (all) or more");
  for (const auto* bones : {&options.posture_bones, &options.posture_always}) {
    for (int k : *bones) {
      if (k < 0 || k >= nt) return Status::Fail("retarget: posture bone index out of range");
    }
  }
  for (int k : options.helper_bones) {
    if (k < 0 || k >= nt) return Status::Fail("retarget: helper bone index out of range");
  }
  for (const bool is_source : {true, false}) {
    const RowMatrixXd& aims = is_source ? source_aims : target_aims;
    const RigModel& rig = is_source ? source : target;
    const std::string side = is_source ? "source" : "target";
    if (aims.rows() == 0) continue;
    if (aims.rows() != rig.size() || aims.cols() != 3) {
      return Status::Fail("retarget: " + side + " aims must be one row of 3 numbers per bone");
    }
    for (int b = 0; b < rig.size(); ++b) {
      if (!aims.row(b).allFinite() || aims.row(b).norm() < 1e-12) {
        return Status::Fail("retarget: the " + side + " aim of bone " + Bone(rig, b) + " is not a direction");
      }
    }
  }
  int mapped = 0;
  for (int b = 0; b < nt; ++b) {
    const int a = bone_map[static_cast<std::size_t>(b)];
    if (a < -1 || a >= ns) {
      return Status::Fail("retarget: target bone " + Bone(target, b) + " maps to source index " +
                          std::to_string(a) + ", out of range");
    }
    if (a < 0) continue;
    ++mapped;
    // A map that turns the hierarchy upside down has no consistent answer.
    for (int up = target.parent(b); up >= 0; up = target.parent(up)) {
      const int a0 = bone_map[static_cast<std::size_t>(up)];
      if (a0 < 0) continue;
      if (a0 != a && source.IsAncestor(a, a0)) {
        return Status::Fail("retarget: the bone map crosses the hierarchy (a cycle): target " + Bone(target, up) +
                            " is above " + Bone(target, b) + " but its source " + Bone(source, a0) +
                            " is below " + Bone(source, a));
      }
      break;
    }
  }
  if (mapped == 0) return Status::Fail("retarget: the bone map maps no bone (no common bones)");
  for (int b = 0; b < nt; ++b) {
    if (!internal::IsRotationQuaternion(QuatAt(target_match_basis, 0, b))) {
      return Status::Fail("retarget: the target match pose of " + Bone(target, b) + " is not a rotation");
    }
  }
  for (int a = 0; a < ns; ++a) {
    if (!internal::IsRotationQuaternion(QuatAt(source_match, 0, a))) {
      return Status::Fail("retarget: the source match pose of " + Bone(source, a) + " is not a rotation");
    }
  }
  for (Eigen::Index f = 0; f < frames; ++f) {
    for (int a = 0; a < ns; ++a) {
      if (!internal::IsRotationQuaternion(QuatAt(source_rotations, f, a))) {
        return Status::Fail("retarget: source bone " + Bone(source, a) + " has no valid rotation at frame index " +
                            std::to_string(f));
      }
    }
    if (!source_root_heads.row(f).allFinite()) {
      return Status::Fail("retarget: the source root's head is not finite at frame index " + std::to_string(f));
    }
  }
  return Status::Ok();
}

void RetargetJob::Run() {
  Validate().ThrowIfFailed();
  const Plan plan(*this);
  kept_posture.clear();
  for (int b = 0; b < target.size(); ++b) {
    if (plan.kept(b)) kept_posture.push_back(b);
  }
  // No frame depends on another: blocks of frames on threads, a poser (its own
  // per-frame buffers) for each block, every frame computed as on one thread.
  const Eigen::Index frames = source_rotations.rows();
  const Eigen::Index per_block = ArmaturePoseJob::kFramesPerBlock;
  const int blocks = static_cast<int>((frames + per_block - 1) / per_block);
  const int workers =
      options.threads > 0 ? options.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<std::exception_ptr> failed(static_cast<std::size_t>(blocks));
  internal::ParallelFor(blocks, workers, [&](int block) {
    try {
      TargetPoser poser(*this, plan);
      const Eigen::Index first = static_cast<Eigen::Index>(block) * per_block;
      poser.StartAt(first);
      for (Eigen::Index f = first; f < std::min(frames, first + per_block); ++f) poser.PoseFrame(f);
    } catch (...) {  // out of memory for a block's buffers: said on the calling thread
      failed[static_cast<std::size_t>(block)] = std::current_exception();
    }
  });
  for (const std::exception_ptr& error : failed) {
    if (error) std::rethrow_exception(error);
  }
  for (Eigen::Index first = per_block; first < frames; first += per_block) {
    MakeContinuousAcross(rotations, first, std::min(frames, first + per_block));
  }
}

}  // namespace motionkit
