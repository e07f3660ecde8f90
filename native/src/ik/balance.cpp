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
// clockwise), then the hull moved in by the margin: each edge's line moved
// inwards, consecutive lines meeting at the new corners. A hull too thin for
// the margin keeps one point, its centroid.
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
  if (k < 3) {  // a point or a segment: no room for a margin
    for (std::size_t i = 0; i < k; ++i) inner_[i] = support_[i];
    inner_count_ = hull_count_;
    return;
  }
  const auto normal = [&](std::size_t i) {  // the inward normal of edge i (counter-clockwise: to its left)
    const Vec2 d = support_[(i + 1) % k] - support_[i];
    return Vec2(-d.y(), d.x()).normalized();
  };
  bool fits = true;
  for (std::size_t i = 0; i < k && fits; ++i) {
    const std::size_t prev = (i + k - 1) % k;
    const Vec2 n0 = normal(prev), n1 = normal(i);
    const double c0 = n0.dot(support_[prev]) + margin_, c1 = n1.dot(support_[i]) + margin_;
    const double det = n0.x() * n1.y() - n0.y() * n1.x();
    if (std::abs(det) < 1e-12) {
      fits = false;
      break;
    }
    inner_[i] = Vec2((c0 * n1.y() - c1 * n0.y()) / det, (n0.x() * c1 - n1.x() * c0) / det);
    for (std::size_t j = 0; j < k; ++j) {
      if (normal(j).dot(inner_[i] - support_[j]) < margin_ - 1e-9 * size_) fits = false;
    }
  }
  if (fits) {
    inner_count_ = hull_count_;
    return;
  }
  Vec2 centre = Vec2::Zero();
  for (std::size_t i = 0; i < k; ++i) centre += support_[i];
  inner_[0] = centre / static_cast<double>(k);
  inner_count_ = 1;
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
  } else if (count == 2) {
    best = ClosestOnSegment(p, inner_[0], inner_[1]);
  }
  if ((best - p).norm() <= 1e-12 * size_) return false;
  target = com + side_ * (best.x() - p.x()) + ahead_ * (best.y() - p.y());
  return true;
}

// A turn about axis a at a joint moves the centre of mass by a x (c - head)
// times the share of the mass below the joint (c its subtree's centre); the
// root's translation moves it one to one. Only the horizontal part counts.
void Solver::BuildBalance(const Fk& fk) {
  const double sw = com_.sqrt_weight;
  for (int c = 0; c < cols_; ++c) {
    const Column& column = columns_[static_cast<std::size_t>(c)];
    Vec3 d = Vec3::Zero();
    if (column.kind == Kind::kTranslate) {
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
