// Balance: the support polygon of the pinned bones, where the centre of mass must go when it leaves it,
// and the centre of mass's rows of the Jacobian.
#include "solver.hpp"

namespace motionkit::ik_internal {

namespace {

using Vec2 = Eigen::Vector2d;

double Cross(const Vec2& o, const Vec2& a, const Vec2& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

Vec2 ClosestOnSegment(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 d = b - a;
  const double n = d.squaredNorm();
  const double t = n > 0.0 ? std::clamp((p - a).dot(d) / n, 0.0, 1.0) : 0.0;
  return a + t * d;
}

}  // namespace

// The convex hull of the support points (Andrew's monotone chain, counter-
// clockwise), then the hull moved in by the frame's margin: each edge's line
// moved inwards, consecutive lines meeting at the new corners. A hull too thin
// for the margin keeps one point, its centroid. The frame's margin is the
// margin, or less when the input's centre of mass (fk_ holds the input pose)
// is nearer the edge or outside: the solve never leaves the body less balanced
// than the input has it.
void Solver::FindSupport() {
  std::size_t n = 0;
  for (int b : support_bones_) {
    const Vec3 head = At(fk_.head, b), tail = head + At(fk_.global, b) * Vec3(0.0, rig_.length(b), 0.0);
    for (const Vec3& p : {head, tail}) inner_[n++] = Vec2(side_.dot(p), ahead_.dot(p));
  }
  std::sort(inner_.begin(), inner_.begin() + static_cast<std::ptrdiff_t>(n), [](const Vec2& a, const Vec2& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  const double tiny = 1e-12 * size_ * size_;
  std::size_t k = 0;
  for (std::size_t i = 0; i < n; ++i) {  // lower hull
    while (k >= 2 && Cross(support_[k - 2], support_[k - 1], inner_[i]) <= tiny) --k;
    support_[k++] = inner_[i];
  }
  for (std::size_t i = n - 1, t = k + 1; i-- > 0;) {  // upper hull
    while (k >= t && Cross(support_[k - 2], support_[k - 1], inner_[i]) <= tiny) --k;
    support_[k++] = inner_[i];
  }
  if (k > 1) --k;  // the last point repeats the first
  hull_count_ = static_cast<int>(k);
  frame_margin_ = std::min(margin_, InsideDistance(Vec2(side_.dot(fk_.com), ahead_.dot(fk_.com))));
  if (k < 3) {  // a point or a segment: no room for a margin
    for (std::size_t i = 0; i < k; ++i) inner_[i] = support_[i];
    inner_count_ = hull_count_;
    return;
  }
  // The region {inside distance >= margin}: a box around the hull, clipped
  // by each edge's line moved in by the margin (out, when it is negative).
  // Clipping takes short and nearly parallel edges as they come, where
  // intersecting neighbouring lines would not.
  const double margin = frame_margin_;
  Vec2 lo = support_[0], hi = support_[0];
  for (std::size_t i = 1; i < k; ++i) {
    lo = lo.cwiseMin(support_[i]);
    hi = hi.cwiseMax(support_[i]);
  }
  const double pad = std::abs(margin) + size_;
  std::size_t count = 4;
  inner_[0] = Vec2(lo.x() - pad, lo.y() - pad);
  inner_[1] = Vec2(hi.x() + pad, lo.y() - pad);
  inner_[2] = Vec2(hi.x() + pad, hi.y() + pad);
  inner_[3] = Vec2(lo.x() - pad, hi.y() + pad);
  for (std::size_t e = 0; e < k && count > 0; ++e) {
    const Vec2 d = support_[(e + 1) % k] - support_[e];
    const Vec2 inward = Vec2(-d.y(), d.x()).normalized();
    const double c = inward.dot(support_[e]) + margin;  // keep inward.x >= c
    std::size_t out = 0;
    for (std::size_t i = 0; i < count; ++i) {
      const Vec2& a = inner_[i];
      const Vec2& b = inner_[(i + 1) % count];
      const double da = inward.dot(a) - c, db = inward.dot(b) - c;
      if (da >= 0.0) clip_[out++] = a;
      if ((da >= 0.0) != (db >= 0.0)) clip_[out++] = a + (b - a) * (da / (da - db));
    }
    count = out;
    std::swap(inner_, clip_);
  }
  if (count >= 3) {
    inner_count_ = static_cast<int>(count);
    return;
  }
  // Thinner than twice the margin: the centroid, as near the middle as there is.
  Vec2 centre = Vec2::Zero();
  for (std::size_t i = 0; i < k; ++i) centre += support_[i];
  inner_[0] = centre / static_cast<double>(k);
  inner_count_ = 1;
  frame_margin_ = 0.0;
}

double Solver::InsideDistance(const Vec2& p) const {
  const auto k = static_cast<std::size_t>(hull_count_);
  if (k == 0) return -kInf;
  if (k < 3) return -(p - (k == 1 ? support_[0] : ClosestOnSegment(p, support_[0], support_[1]))).norm();
  double inside = kInf;
  for (std::size_t i = 0; i < k; ++i) {
    const Vec2 d = support_[(i + 1) % k] - support_[i];
    inside = std::min(inside, Vec2(-d.y(), d.x()).normalized().dot(p - support_[i]));
  }
  return inside;
}

bool Solver::BalanceTarget(const Vec3& com, Vec3& target) const {
  const Vec2 p(side_.dot(com), ahead_.dot(com));
  const auto count = static_cast<std::size_t>(inner_count_);
  if (count == 0) return false;
  Vec2 best = inner_[0];
  if (count >= 3) {
    bool inside = true;
    for (std::size_t i = 0; i < count && inside; ++i) inside = Cross(inner_[i], inner_[(i + 1) % count], p) >= 0.0;
    if (inside) return false;
    double nearest = kInf;
    for (std::size_t i = 0; i < count; ++i) {
      const Vec2 q = ClosestOnSegment(p, inner_[i], inner_[(i + 1) % count]);
      if ((q - p).squaredNorm() < nearest) {
        nearest = (q - p).squaredNorm();
        best = q;
      }
    }
  } else {  // a point or a segment: within the frame's distance of it (if the input stands off it)
    best = count == 2 ? ClosestOnSegment(p, inner_[0], inner_[1]) : inner_[0];
    const double allowed = std::max(0.0, -frame_margin_), off = (p - best).norm();
    if (off <= allowed + 1e-12 * size_) return false;
    best += (p - best) * (allowed / off);
  }
  if ((best - p).norm() <= 1e-12 * size_) return false;
  target = com + side_ * (best.x() - p.x()) + ahead_ * (best.y() - p.y());
  return true;
}

// A turn about axis a at a joint moves the centre of mass by a x (c - head)
// times the share of the mass below the joint (c its subtree's centre); the
// root's translation moves it one to one. Only the horizontal part counts.
// With recruitment stages, only the root's translation.
void Solver::BuildBalance(const Fk& fk) {
  const double sw = com_.sqrt_weight;
  for (int c = 0; c < cols_; ++c) {
    const Column& column = columns_[static_cast<std::size_t>(c)];
    Vec3 d = Vec3::Zero();
    if (stages_ > 1 && column.kind != Kind::kTranslate) {
      // With recruitment, the hips' shift keeps the balance (the limbs and the spine serve the targets;
      // what they do to the centre of mass the next iteration's residual sees, and the hips answer).
    } else if (column.kind == Kind::kTranslate) {
      d[column.axis] = 1.0;
    } else if (column.kind == Kind::kRotate) {
      const int b = At(joints_, column.joint).bone;
      const Vec3 a = At(axes_, column.joint).col(column.axis);
      d = (column.scale / total_mass_) * a.cross(At(fk.moment, b) - At(subtree_mass_, b) * At(fk.head, b));
    }
    d -= up_ * up_.dot(d);
    for (int r = 0; r < 3; ++r) com_.block[static_cast<std::size_t>(3 * c + r)] = sw * d[r];
  }
}

}  // namespace motionkit::ik_internal
