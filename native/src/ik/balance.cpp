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

Vec2 Ground(const BalanceModel& bm, const Vec3& p) { return Vec2(bm.side.dot(p), bm.ahead.dot(p)); }

// How far p lies inside the hull, from its edges (negative: outside).
double InsideDistance(const Support& s, const Vec2& p) {
  const auto k = static_cast<std::size_t>(s.hull_count);
  if (k == 0) return -kInf;
  if (k < 3) return -(p - (k == 1 ? s.hull[0] : ClosestOnSegment(p, s.hull[0], s.hull[1]))).norm();
  double inside = kInf;
  for (std::size_t i = 0; i < k; ++i) {
    const Vec2 e = s.hull[(i + 1) % k] - s.hull[i];
    inside = std::min(inside, Vec2(-e.y(), e.x()).normalized().dot(p - s.hull[i]));
  }
  return inside;
}

// The convex hull of the support points (Andrew's monotone chain, counter-clockwise) into
// support.hull; the points are projected into support.inner first, as scratch.
void FindHull(const Model& m, Data& d) {
  Support& s = d.support;
  std::size_t n = 0;
  for (int b : m.balance.support_bones) {
    const Vec3 head = At(d.fk.head, b), tail = head + At(d.fk.global, b) * Vec3(0.0, m.rig.length(b), 0.0);
    for (const Vec3& p : {head, tail}) s.inner[n++] = Ground(m.balance, p);
  }
  std::sort(s.inner.begin(), s.inner.begin() + static_cast<std::ptrdiff_t>(n), [](const Vec2& a, const Vec2& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  const double tiny = 1e-12 * m.size * m.size;
  std::size_t k = 0;
  for (std::size_t i = 0; i < n; ++i) {  // lower hull
    while (k >= 2 && Cross(s.hull[k - 2], s.hull[k - 1], s.inner[i]) <= tiny) --k;
    s.hull[k++] = s.inner[i];
  }
  for (std::size_t i = n - 1, t = k + 1; i-- > 0;) {  // upper hull
    while (k >= t && Cross(s.hull[k - 2], s.hull[k - 1], s.inner[i]) <= tiny) --k;
    s.hull[k++] = s.inner[i];
  }
  if (k > 1) --k;  // the last point repeats the first
  s.hull_count = static_cast<int>(k);
}

// The region {inside distance >= margin}: a box around the hull, clipped by
// each edge's line moved in by the margin (out, when it is negative).
// Clipping takes short and nearly parallel edges as they come, where
// intersecting neighbouring lines would not. Returns its corners' count.
std::size_t ClipInner(const Model& m, Support& s) {
  const auto k = static_cast<std::size_t>(s.hull_count);
  const double margin = s.frame_margin;
  Vec2 lo = s.hull[0], hi = s.hull[0];
  for (std::size_t i = 1; i < k; ++i) {
    lo = lo.cwiseMin(s.hull[i]);
    hi = hi.cwiseMax(s.hull[i]);
  }
  const double pad = std::abs(margin) + m.size;
  std::size_t count = 4;
  s.inner[0] = Vec2(lo.x() - pad, lo.y() - pad);
  s.inner[1] = Vec2(hi.x() + pad, lo.y() - pad);
  s.inner[2] = Vec2(hi.x() + pad, hi.y() + pad);
  s.inner[3] = Vec2(lo.x() - pad, hi.y() + pad);
  for (std::size_t e = 0; e < k && count > 0; ++e) {
    const Vec2 edge = s.hull[(e + 1) % k] - s.hull[e];
    const Vec2 inward = Vec2(-edge.y(), edge.x()).normalized();
    const double c = inward.dot(s.hull[e]) + margin;  // keep inward.x >= c
    std::size_t out = 0;
    for (std::size_t i = 0; i < count; ++i) {
      const Vec2& a = s.inner[i];
      const Vec2& b = s.inner[(i + 1) % count];
      const double da = inward.dot(a) - c, db = inward.dot(b) - c;
      if (da >= 0.0) s.clip[out++] = a;
      if ((da >= 0.0) != (db >= 0.0)) s.clip[out++] = a + (b - a) * (da / (da - db));
    }
    count = out;
    std::swap(s.inner, s.clip);
  }
  return count;
}

}  // namespace

// The support's hull, then the hull moved in by the frame's margin. A hull
// too thin for the margin keeps one point, its centroid. The frame's margin
// is the margin, or less when the input's centre of mass (d.fk holds the
// input pose) is nearer the edge or outside: the solve never leaves the body
// less balanced than the input has it.
void FindSupport(const Model& m, Data& d) {
  Support& s = d.support;
  FindHull(m, d);
  const auto k = static_cast<std::size_t>(s.hull_count);
  s.frame_margin = std::min(m.balance.margin, InsideDistance(s, Ground(m.balance, d.fk.com)));
  if (k < 3) {  // a point or a segment: no room for a margin
    for (std::size_t i = 0; i < k; ++i) s.inner[i] = s.hull[i];
    s.inner_count = s.hull_count;
    return;
  }
  const std::size_t count = ClipInner(m, s);
  if (count >= 3) {
    s.inner_count = static_cast<int>(count);
    return;
  }
  // Thinner than twice the margin: the centroid, as near the middle as there is.
  Vec2 centre = Vec2::Zero();
  for (std::size_t i = 0; i < k; ++i) centre += s.hull[i];
  s.inner[0] = centre / static_cast<double>(k);
  s.inner_count = 1;
  s.frame_margin = 0.0;
}

// Where the centre of mass should go; false when it is where it may be (inside, the frame's margin
// from the edges).
bool BalanceTarget(const Model& m, const Data& d, const Vec3& com, Vec3& target) {
  const Support& s = d.support;
  const Vec2 p = Ground(m.balance, com);
  const auto count = static_cast<std::size_t>(s.inner_count);
  if (count == 0) return false;
  Vec2 best = s.inner[0];
  if (count >= 3) {
    bool inside = true;
    for (std::size_t i = 0; i < count && inside; ++i) inside = Cross(s.inner[i], s.inner[(i + 1) % count], p) >= 0.0;
    if (inside) return false;
    double nearest = kInf;
    for (std::size_t i = 0; i < count; ++i) {
      const Vec2 q = ClosestOnSegment(p, s.inner[i], s.inner[(i + 1) % count]);
      if ((q - p).squaredNorm() < nearest) {
        nearest = (q - p).squaredNorm();
        best = q;
      }
    }
  } else {  // a point or a segment: within the frame's distance of it (if the input stands off it)
    best = count == 2 ? ClosestOnSegment(p, s.inner[0], s.inner[1]) : s.inner[0];
    const double allowed = std::max(0.0, -s.frame_margin), off = (p - best).norm();
    if (off <= allowed + 1e-12 * m.size) return false;
    best += (p - best) * (allowed / off);
  }
  if ((best - p).norm() <= 1e-12 * m.size) return false;
  target = com + m.balance.side * (best.x() - p.x()) + m.balance.ahead * (best.y() - p.y());
  return true;
}

// A turn about axis a at a joint moves the centre of mass by a x (c - head)
// times the share of the mass below the joint (c its subtree's centre); the
// root's translation moves it one to one. Only the horizontal part counts.
// With recruitment stages, only the root's translation.
void BuildBalanceRows(const Model& m, Data& d, const Fk& fk) {
  const BalanceModel& bm = m.balance;
  const double sw = bm.com.sqrt_weight;
  for (int c = 0; c < m.cols; ++c) {
    const Column& column = At(m.columns, c);
    Vec3 shift = Vec3::Zero();
    if (m.stages > 1 && column.kind != Kind::kTranslate) {
      // With recruitment, the hips' shift keeps the balance (the limbs and the spine serve the targets;
      // what they do to the centre of mass the next iteration's residual sees, and the hips answer).
    } else if (column.kind == Kind::kTranslate) {
      shift[column.axis] = 1.0;
    } else if (column.kind == Kind::kRotate) {
      const int b = At(m.joints, column.joint).bone;
      const Vec3 a = At(d.joint_axes, column.joint).col(column.axis);
      shift = (column.scale / bm.total_mass) * a.cross(At(fk.moment, b) - At(bm.subtree_mass, b) * At(fk.head, b));
    }
    shift -= bm.up * bm.up.dot(shift);
    for (int r = 0; r < 3; ++r) d.balance_block.a[static_cast<std::size_t>(3 * c + r)] = sw * shift[r];
  }
}

}  // namespace motionkit::ik_internal
