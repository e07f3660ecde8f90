// The body's signed-distance field (native/include/motionkit/body_field.hpp).
#include "motionkit/body_field.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <thread>
#include <utility>

#include "../parallel.hpp"

namespace motionkit {
namespace {

using Vec3 = Eigen::Vector3d;

// The point of triangle abc nearest p (Ericson, Real-Time Collision Detection, 5.1.5).
Vec3 ClosestOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + (d1 / (d1 - d3)) * ab;
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  }
  const double denominator = 1.0 / (va + vb + vc);
  return a + ab * (vb * denominator) + ac * (vc * denominator);
}

class Grid {
 public:
  explicit Grid(const BodyFieldJob& job) : job_(job), dims_(job.dims) {}

  Eigen::Index Cell(int i, int j, int k) const {
    return (static_cast<Eigen::Index>(i) * dims_.y() + j) * dims_.z() + k;
  }
  Vec3 Centre(int i, int j, int k) const { return job_.origin + job_.spacing * Vec3(i, j, k); }
  // The cells' index range covering [low, high] along axis a, clamped to the grid.
  std::array<int, 2> Span(double low, double high, int a) const {
    const int first = static_cast<int>(std::ceil((low - job_.origin[a]) / job_.spacing));
    const int last = static_cast<int>(std::floor((high - job_.origin[a]) / job_.spacing));
    return {std::max(first, 0), std::min(last, dims_[a] - 1)};
  }
  const Eigen::Vector3i& dims() const { return dims_; }

 private:
  const BodyFieldJob& job_;
  Eigen::Vector3i dims_;
};

Vec3 Vertex(const BodyFieldJob& job, Eigen::Index t, int corner) {
  return job.vertices.row(job.triangles(t, corner)).transpose();
}

// The exact distance (squared, as the sweeps compare it, until Run takes its root), nearest point and its
// bone in every cell within two cells of a triangle.
void NearSurface(BodyFieldJob& job, const Grid& grid, std::vector<Vec3>& nearest) {
  const double band = 2.0 * job.spacing;
  for (Eigen::Index t = 0; t < job.triangles.rows(); ++t) {
    const std::array<Vec3, 3> v{Vertex(job, t, 0), Vertex(job, t, 1), Vertex(job, t, 2)};
    const Vec3 low = v[0].cwiseMin(v[1]).cwiseMin(v[2]).array() - band;
    const Vec3 high = v[0].cwiseMax(v[1]).cwiseMax(v[2]).array() + band;
    const auto si = grid.Span(low.x(), high.x(), 0), sj = grid.Span(low.y(), high.y(), 1),
               sk = grid.Span(low.z(), high.z(), 2);
    for (int i = si[0]; i <= si[1]; ++i) {
      for (int j = sj[0]; j <= sj[1]; ++j) {
        for (int k = sk[0]; k <= sk[1]; ++k) {
          const Vec3 centre = grid.Centre(i, j, k);
          const Vec3 point = ClosestOnTriangle(centre, v[0], v[1], v[2]);
          const double d = (point - centre).squaredNorm();
          const Eigen::Index cell = grid.Cell(i, j, k);
          if (d >= job.distance[cell]) continue;
          job.distance[cell] = d;
          nearest[static_cast<std::size_t>(cell)] = point;
          int corner = 0;
          for (int c = 1; c < 3; ++c) {
            if ((v[c] - point).squaredNorm() < (v[corner] - point).squaredNorm()) corner = c;
          }
          job.bone[cell] = job.vertex_bone[static_cast<std::size_t>(job.triangles(t, corner))];
        }
      }
    }
  }
}

// One sweep of the vector distance transform: each cell takes a neighbour's nearest surface point where it
// is nearer, the neighbours visited before it in the sweep's order (direction +1 or -1).
void Sweep(BodyFieldJob& job, const Grid& grid, std::vector<Vec3>& nearest, int direction) {
  const Eigen::Vector3i& n = grid.dims();
  const auto range = [&](int size, int index) { return direction > 0 ? index : size - 1 - index; };
  for (int ii = 0; ii < n.x(); ++ii) {
    const int i = range(n.x(), ii);
    for (int jj = 0; jj < n.y(); ++jj) {
      const int j = range(n.y(), jj);
      for (int kk = 0; kk < n.z(); ++kk) {
        const int k = range(n.z(), kk);
        const Eigen::Index cell = grid.Cell(i, j, k);
        const Vec3 centre = grid.Centre(i, j, k);
        for (int di = -1; di <= 0; ++di) {
          for (int dj = -1; dj <= 1; ++dj) {
            for (int dk = -1; dk <= 1; ++dk) {
              // Neighbours already visited in this order: lexicographically before (di, dj, dk) = 0.
              if (di == 0 && (dj > 0 || (dj == 0 && dk >= 0))) continue;
              const int a = i + direction * di, b = j + direction * dj, c = k + direction * dk;
              if (a < 0 || b < 0 || c < 0 || a >= n.x() || b >= n.y() || c >= n.z()) continue;
              const Eigen::Index from = grid.Cell(a, b, c);
              if (!std::isfinite(job.distance[from])) continue;
              const Vec3& point = nearest[static_cast<std::size_t>(from)];
              const double d = (point - centre).squaredNorm();
              if (d < job.distance[cell]) {
                job.distance[cell] = d;
                nearest[static_cast<std::size_t>(cell)] = point;
                job.bone[cell] = job.bone[from];
              }
            }
          }
        }
      }
    }
  }
}

// Adds 1 to votes[cell] for every cell that rays along axis `a` find inside: the surface's crossings below
// it, counted +1 entering and -1 leaving by each triangle's winding, do not sum to zero (the nonzero rule,
// so that a region two shells cover, a coat over a body or hair over a head, is inside, where parity would
// call it outside; a mesh wound inside out counts the same). The rays pass a millionth of a cell off the
// cells' centres, so that none runs exactly along a shared edge (counted twice or not at all).
void VoteAlong(const BodyFieldJob& job, const Grid& grid, int a, std::vector<std::uint8_t>& votes) {
  const int u = (a + 1) % 3, v = (a + 2) % 3;
  const Eigen::Vector3i& n = grid.dims();
  const double du = 1.234567e-6 * job.spacing, dv = 3.456789e-6 * job.spacing;
  const std::size_t columns = static_cast<std::size_t>(n[u]) * static_cast<std::size_t>(n[v]);
  std::vector<std::vector<std::pair<double, int>>> hits(columns);
  for (Eigen::Index t = 0; t < job.triangles.rows(); ++t) {
    const std::array<Vec3, 3> p{Vertex(job, t, 0), Vertex(job, t, 1), Vertex(job, t, 2)};
    const double area = (p[1][u] - p[0][u]) * (p[2][v] - p[0][v]) - (p[2][u] - p[0][u]) * (p[1][v] - p[0][v]);
    if (area == 0.0) continue;  // edge-on to these rays
    const auto su = grid.Span(std::min({p[0][u], p[1][u], p[2][u]}) - du, std::max({p[0][u], p[1][u], p[2][u]}), u);
    const auto sv = grid.Span(std::min({p[0][v], p[1][v], p[2][v]}) - dv, std::max({p[0][v], p[1][v], p[2][v]}), v);
    for (int iu = su[0]; iu <= su[1]; ++iu) {
      const double x = job.origin[u] + job.spacing * iu + du;
      for (int iv = sv[0]; iv <= sv[1]; ++iv) {
        const double y = job.origin[v] + job.spacing * iv + dv;
        std::array<double, 3> w{};
        for (int e = 0; e < 3; ++e) {
          const Vec3& q = p[static_cast<std::size_t>((e + 1) % 3)];
          const Vec3& r = p[static_cast<std::size_t>((e + 2) % 3)];
          w[static_cast<std::size_t>(e)] = ((r[u] - q[u]) * (y - q[v]) - (r[v] - q[v]) * (x - q[u])) / area;
        }
        if (w[0] < 0.0 || w[1] < 0.0 || w[2] < 0.0) continue;
        hits[static_cast<std::size_t>(iu) * static_cast<std::size_t>(n[v]) + static_cast<std::size_t>(iv)]
            .emplace_back(w[0] * p[0][a] + w[1] * p[1][a] + w[2] * p[2][a], area < 0.0 ? 1 : -1);
      }
    }
  }
  for (int iu = 0; iu < n[u]; ++iu) {
    for (int iv = 0; iv < n[v]; ++iv) {
      auto& column = hits[static_cast<std::size_t>(iu) * static_cast<std::size_t>(n[v]) + static_cast<std::size_t>(iv)];
      std::sort(column.begin(), column.end());
      std::size_t below = 0;
      int winding = 0;
      for (int ia = 0; ia < n[a]; ++ia) {
        const double at = job.origin[a] + job.spacing * ia;
        for (; below < column.size() && column[below].first < at; ++below) winding += column[below].second;
        if (winding != 0) {
          std::array<int, 3> index{};
          index[static_cast<std::size_t>(a)] = ia;
          index[static_cast<std::size_t>(u)] = iu;
          index[static_cast<std::size_t>(v)] = iv;
          ++votes[static_cast<std::size_t>(grid.Cell(index[0], index[1], index[2]))];
        }
      }
    }
  }
}

}  // namespace

Status BodyFieldJob::Validate() const {
  const Eigen::Index cells = static_cast<Eigen::Index>(dims.x()) * dims.y() * dims.z();
  if (vertices.cols() != 3) return Status::Fail("body field: vertices must be (V, 3)");
  if (triangles.rows() == 0) return Status::Fail("body field: the mesh has no triangles");
  if (static_cast<Eigen::Index>(vertex_bone.size()) != vertices.rows()) {
    return Status::Fail("body field: one bone per vertex expected, " + std::to_string(vertex_bone.size()) +
                        " for " + std::to_string(vertices.rows()) + " vertices");
  }
  for (Eigen::Index v = 0; v < vertices.rows(); ++v) {
    if (!vertices.row(v).allFinite()) return Status::Fail("body field: vertex " + std::to_string(v) + " is not finite");
  }
  for (Eigen::Index t = 0; t < triangles.rows(); ++t) {
    for (int c = 0; c < 3; ++c) {
      if (triangles(t, c) < 0 || triangles(t, c) >= vertices.rows()) {
        return Status::Fail("body field: triangle " + std::to_string(t) + " names vertex " +
                            std::to_string(triangles(t, c)) + ", out of range");
      }
    }
  }
  if (!(spacing > 0.0) || !std::isfinite(spacing) || !origin.allFinite()) {
    return Status::Fail("body field: the grid's spacing must be positive and its origin finite");
  }
  if (dims.minCoeff() < 2) return Status::Fail("body field: the grid needs at least 2 cells along each axis");
  if (distance.size() != cells || bone.size() != cells) {
    return Status::Fail("body field: outputs of " + std::to_string(cells) + " cells expected");
  }
  return Status::Ok();
}

void BodyFieldJob::Run() {
  Validate().ThrowIfFailed();
  const Grid grid(*this);
  distance.setConstant(std::numeric_limits<double>::infinity());
  bone.setConstant(-1);
  // The distances (the band, then the sweeps) and each axis' inside votes are independent: four tasks on
  // the threads there are, each writing its own buffer, the same result on any number.
  std::vector<Vec3> nearest(static_cast<std::size_t>(distance.size()), Vec3::Zero());
  std::array<std::vector<std::uint8_t>, 3> axis_votes;
  for (auto& along : axis_votes) along.assign(static_cast<std::size_t>(distance.size()), 0);
  internal::ParallelFor(4, threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency())),
                        [&](int task) {
                          if (task == 0) {
                            NearSurface(*this, grid, nearest);
                            // Two passes each way carry a nearest point around any corner of a body's surface.
                            for (int pass = 0; pass < 2; ++pass) {
                              Sweep(*this, grid, nearest, +1);
                              Sweep(*this, grid, nearest, -1);
                            }
                            return;
                          }
                          VoteAlong(*this, grid, task - 1, axis_votes[static_cast<std::size_t>(task - 1)]);
                        });
  std::vector<std::uint8_t> votes(static_cast<std::size_t>(distance.size()), 0);
  for (const auto& along : axis_votes) {
    for (std::size_t cell = 0; cell < votes.size(); ++cell) votes[cell] = static_cast<std::uint8_t>(votes[cell] + along[cell]);
  }
  for (Eigen::Index cell = 0; cell < distance.size(); ++cell) {
    distance[cell] = std::sqrt(distance[cell]);
    if (votes[static_cast<std::size_t>(cell)] >= 2) distance[cell] = -distance[cell];
  }
}

}  // namespace motionkit
