#include "motionkit/key_reduction.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "so3.hpp"
#include "time_checks.hpp"

namespace motionkit {
namespace {

// When fewer than two samples lie inside a segment (or they nearly coincide)
// the two slopes are not determined; a ridge of this relative weight pulls
// them towards the chord slope and picks the solution nearest it. Segments
// whose slopes are determined get no ridge, so that a sampled cubic is fitted
// exactly.
constexpr double kRidge = 1e-9;
constexpr double kSingular = 1e-12;

// Angle between two rotations given as unit quaternions, accurate for tiny
// angles too (acos of the dot product is not).
double AngleBetween(const Eigen::Quaterniond& p, const Eigen::Quaterniond& q) {
  Eigen::Vector4d a = p.coeffs(), b = q.coeffs();
  if (a.dot(b) < 0.0) b = -b;
  // |a - b| and |a + b| are 2 sin and 2 cos of half the 4-D angle between a
  // and b, which is itself half the rotation angle.
  return 4.0 * std::atan2((a - b).norm(), (a + b).norm());
}

struct Hermite {
  double h0, h1, h2, h3;  // h2 and h3 already multiplied by the segment length
};

Hermite Basis(double u, double h) {
  const double u2 = u * u, u3 = u2 * u;
  return {2 * u3 - 3 * u2 + 1, 3 * u2 - 2 * u3, (u3 - 2 * u2 + u) * h, (u3 - u2) * h};
}

}  // namespace

Status KeyReductionJob::Validate() const {
  const Eigen::Index m = times.size();
  const Eigen::Index d = values.cols();
  if (m < 1) return Status::Fail("key reduction: no samples");
  if (values.rows() != m) {
    return Status::Fail("key reduction: values has " + std::to_string(values.rows()) +
                        " rows but there are " + std::to_string(m) + " sample times");
  }
  if (d < 1) return Status::Fail("key reduction: values has no channels");
  if (mode == KeyToleranceMode::kQuaternion && d != 4) {
    return Status::Fail("key reduction: quaternion mode needs 4 channels (w x y z), got " +
                        std::to_string(d));
  }
  if (mode == KeyToleranceMode::kEuler && d != 3) {
    return Status::Fail("key reduction: Euler mode needs 3 channels, got " + std::to_string(d));
  }
  if (stride < 1) return Status::Fail("key reduction: stride must be at least 1, got " + std::to_string(stride));
  if (!std::isfinite(tolerance) || tolerance < 0.0) {
    return Status::Fail("key reduction: tolerance must be finite and >= 0, got " +
                        std::to_string(tolerance));
  }
  for (Eigen::Index j = 0; j < m; ++j) {
    if (!internal::TimeInOrder(times.data(), j)) {
      return internal::TimeOrderFailure(times.data(), j, "key reduction: ", {"time of sample", "sample times", "sample"});
    }
    for (Eigen::Index c = 0; c < d; ++c) {
      if (!std::isfinite(values(j, c))) {
        return Status::Fail("key reduction: channel " + std::to_string(c) + " of sample " +
                            std::to_string(j) + " (time " + std::to_string(times[j]) +
                            ") is not finite");
      }
    }
    if (mode == KeyToleranceMode::kQuaternion && !internal::IsRotationQuaternion(values.row(j))) {
      return Status::Fail("key reduction: quaternion of sample " + std::to_string(j) + " (time " +
                          std::to_string(times[j]) + ") is zero");
    }
  }
  if (key_indices.size() != m || slopes_in.rows() != m || slopes_in.cols() != d ||
      slopes_out.rows() != m || slopes_out.cols() != d) {
    return Status::Fail("key reduction: outputs must be key_indices (" + std::to_string(m) +
                        ") and slopes " + std::to_string(m) + " x " + std::to_string(d) +
                        ", got " + std::to_string(key_indices.size()) + ", " +
                        std::to_string(slopes_in.rows()) + " x " + std::to_string(slopes_in.cols()) +
                        " and " + std::to_string(slopes_out.rows()) + " x " +
                        std::to_string(slopes_out.cols()));
  }
  return Status::Ok();
}

// Least-squares end slopes for the segment [a, b]; returns whether the
// segment is then within tolerance.
bool KeyReductionJob::FitSegment(Eigen::Index a, Eigen::Index b, double* slope_a,
                                 double* slope_b) {
  const Eigen::Index d = values.cols();
  const double t0 = times[a], h = times[b] - t0;
  for (Eigen::Index c = 0; c < d; ++c) slope_a[c] = slope_b[c] = (values(b, c) - values(a, c)) / h;
  if (b - a < 2) return true;  // the ends are exact and nothing lies between

  // Normal equations for the deviations from the chord slope; the 2 x 2
  // matrix is shared by every channel.
  double* rhs_a = scratch_.data();
  double* rhs_b = rhs_a + d;
  std::fill(rhs_a, rhs_a + 2 * d, 0.0);
  double g_aa = 0.0, g_ab = 0.0, g_bb = 0.0;
  for (Eigen::Index j = a + 1; j < b; ++j) {
    const Hermite w = Basis((times[j] - t0) / h, h);
    g_aa += w.h2 * w.h2;
    g_ab += w.h2 * w.h3;
    g_bb += w.h3 * w.h3;
    for (Eigen::Index c = 0; c < d; ++c) {
      const double residual = values(j, c) - w.h0 * values(a, c) - w.h1 * values(b, c) -
                              (w.h2 + w.h3) * slope_a[c];
      rhs_a[c] += w.h2 * residual;
      rhs_b[c] += w.h3 * residual;
    }
  }
  double det = g_aa * g_bb - g_ab * g_ab;
  if (b - a < 3 || !(det > kSingular * g_aa * g_bb)) {
    const double ridge = kRidge * (g_aa + g_bb);
    g_aa += ridge;
    g_bb += ridge;
    det = g_aa * g_bb - g_ab * g_ab;
  }
  for (Eigen::Index c = 0; c < d; ++c) {
    slope_a[c] += (g_bb * rhs_a[c] - g_ab * rhs_b[c]) / det;
    slope_b[c] += (g_aa * rhs_b[c] - g_ab * rhs_a[c]) / det;
  }
  return WithinTolerance(a, b, slope_a, slope_b);
}

bool KeyReductionJob::WithinTolerance(Eigen::Index a, Eigen::Index b, const double* slope_a,
                                      const double* slope_b) const {
  const Eigen::Index d = values.cols();
  const double t0 = times[a], h = times[b] - t0;
  double fitted[4];
  for (Eigen::Index j = a + 1; j < b; ++j) {
    const Hermite w = Basis((times[j] - t0) / h, h);
    if (mode == KeyToleranceMode::kAbsolute) {
      for (Eigen::Index c = 0; c < d; ++c) {
        const double y = w.h0 * values(a, c) + w.h1 * values(b, c) + w.h2 * slope_a[c] +
                         w.h3 * slope_b[c];
        if (!(std::abs(y - values(j, c)) <= tolerance)) return false;
      }
      continue;
    }
    for (Eigen::Index c = 0; c < d; ++c) {
      fitted[c] = w.h0 * values(a, c) + w.h1 * values(b, c) + w.h2 * slope_a[c] +
                  w.h3 * slope_b[c];
    }
    Eigen::Quaterniond fit_q, sample_q;
    if (mode == KeyToleranceMode::kQuaternion) {
      fit_q = Eigen::Quaterniond(fitted[0], fitted[1], fitted[2], fitted[3]);
      // Blender normalises what it poses; a curve through zero poses nothing.
      const double norm = fit_q.norm();
      if (!(norm > 1e-12)) return false;
      fit_q.coeffs() /= norm;
      sample_q = Eigen::Quaterniond(values(j, 0), values(j, 1), values(j, 2), values(j, 3));
      sample_q.normalize();
    } else {
      fit_q = EulerToQuaternion(Eigen::Vector3d(fitted[0], fitted[1], fitted[2]), euler_order);
      sample_q = EulerToQuaternion(values.row(j).transpose(), euler_order);
    }
    if (!(AngleBetween(fit_q, sample_q) <= tolerance)) return false;
  }
  return true;
}

void KeyReductionJob::Run() {
  Validate().ThrowIfFailed();
  const Eigen::Index m = times.size();
  const Eigen::Index d = values.cols();
  scratch_.assign(static_cast<std::size_t>(6 * d), 0.0);
  double* trial_a = scratch_.data() + 2 * d;
  double* trial_b = trial_a + d;
  double* best_a = trial_b + d;
  double* best_b = best_a + d;
  const auto keep = [&]() {
    std::copy(trial_a, trial_a + d, best_a);
    std::copy(trial_b, trial_b + d, best_b);
  };

  key_count = 1;
  key_indices[0] = 0;
  slopes_in.row(0).setZero();
  slopes_out.row(0).setZero();
  // The search runs over candidate keys: every stride-th sample and the last.
  // When even the next candidate is out of reach (a tolerance tighter than
  // the curve between two frames), the next sample becomes a key instead, so
  // the tolerance holds at every sample whatever the stride.
  const Eigen::Index last_candidate = (m - 2) / stride + 1;
  Eigen::Index a = 0;
  while (a < m - 1) {
    const Eigen::Index base = a / stride;
    const auto sample = [&](Eigen::Index j) { return std::min((base + j) * stride, m - 1); };
    const Eigen::Index last = last_candidate - base;
    Eigen::Index good = 1;
    Eigen::Index key = sample(1);
    if (FitSegment(a, key, trial_a, trial_b)) {
      keep();
      Eigen::Index bad = last + 1;  // the first end known to fail; past the end: none yet
      for (Eigen::Index step = 2; good < last; step *= 2) {
        const Eigen::Index end = std::min(step, last);
        if (FitSegment(a, sample(end), trial_a, trial_b)) {
          good = end;
          keep();
        } else {
          bad = end;
          break;
        }
      }
      while (bad <= last && bad - good > 1) {
        const Eigen::Index mid = good + (bad - good) / 2;
        if (FitSegment(a, sample(mid), trial_a, trial_b)) {
          good = mid;
          keep();
        } else {
          bad = mid;
        }
      }
      key = sample(good);
    } else {
      key = a + 1;
      FitSegment(a, key, trial_a, trial_b);  // no sample inside: always within tolerance
      keep();
    }
    const Eigen::Index k = key_count++;
    for (Eigen::Index c = 0; c < d; ++c) {
      slopes_out(k - 1, c) = best_a[c];
      slopes_in(k, c) = best_b[c];
    }
    key_indices[k] = key;
    a = key;
  }
  slopes_in.row(0) = slopes_out.row(0);
  slopes_out.row(key_count - 1) = slopes_in.row(key_count - 1);
}

}  // namespace motionkit
