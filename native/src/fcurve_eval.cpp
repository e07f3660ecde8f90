#include "motionkit/fcurve_eval.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace motionkit {
namespace {

constexpr double kOnKey = 1e-4;  // BKE_fcurve_bezt_binarysearch_index_ex's threshold

struct Key {
  double x, y, lx, ly, rx, ry;
  int interpolation;
};

Key KeyAt(const FCurveEvaluateJob& job, Eigen::Index k) {
  return {job.co(k, 0),           job.co(k, 1),           job.handle_left(k, 0),
          job.handle_left(k, 1),  job.handle_right(k, 0), job.handle_right(k, 1),
          job.interpolation[k]};
}

// Parameter t in [0, 1] where the Bezier's time x(t) equals `time`; the
// corrected handles make x(t) monotonic, so bisection-safeguarded Newton works.
double SolveBezierTime(double x0, double x1, double x2, double x3, double time) {
  const double a = x3 - 3.0 * x2 + 3.0 * x1 - x0;
  const double b = 3.0 * (x2 - 2.0 * x1 + x0);
  const double c = 3.0 * (x1 - x0);
  const double d = x0 - time;
  double lo = 0.0, hi = 1.0;
  double t = (time - x0) / (x3 - x0);
  for (int i = 0; i < 64; ++i) {
    const double f = ((a * t + b) * t + c) * t + d;
    if (f == 0.0) return t;
    if (f < 0.0) lo = t; else hi = t;
    const double df = (3.0 * a * t + 2.0 * b) * t + c;
    double next = df != 0.0 ? t - f / df : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - t) < 1e-15) return next;
    t = next;
  }
  return t;
}

double EvaluateSegment(const Key& k0, const Key& k1, double time) {
  if (k1.x == k0.x) return k0.y;
  switch (k0.interpolation) {
    case kKeyConstant:
      return k0.y;
    case kKeyLinear:
      return k0.y + (k1.y - k0.y) * (time - k0.x) / (k1.x - k0.x);
    default: {
      double v1x = k0.x, v1y = k0.y, v2x = k0.rx, v2y = k0.ry;
      double v3x = k1.lx, v3y = k1.ly, v4x = k1.x, v4y = k1.y;
      const float eps = std::numeric_limits<float>::epsilon();
      if (std::abs(v1y - v4y) < eps && std::abs(v2y - v3y) < eps && std::abs(v3y - v4y) < eps) {
        return v1y;
      }
      // A handle may not reach past the segment (BKE_fcurve_correct_bezpart):
      // each is shortened on its own, keeping its direction, which keeps the
      // segment's time monotonic in its parameter.
      const double len = v4x - v1x;
      const double h1x = v1x - v2x, h1y = v1y - v2y;
      const double h2x = v4x - v3x, h2y = v4y - v3y;
      if (std::abs(h1x) > len) {
        const double fac = len / std::abs(h1x);
        v2x = v1x - fac * h1x;
        v2y = v1y - fac * h1y;
      }
      if (std::abs(h2x) > len) {
        const double fac = len / std::abs(h2x);
        v3x = v4x - fac * h2x;
        v3y = v4y - fac * h2y;
      }
      const double t = SolveBezierTime(v1x, v2x, v3x, v4x, time);
      const double s = 1.0 - t;
      return s * s * s * v1y + 3.0 * s * s * t * v2y + 3.0 * s * t * t * v3y + t * t * t * v4y;
    }
  }
}

// Before the first key (`first` true) or after the last, as Blender extrapolates.
double Extrapolate(const Key& end, const Key& neighbour, bool first, bool linear, bool single,
                   double time) {
  // As Blender's fcurve_eval_keyframes_extrapolate.
  if (!linear || single || end.interpolation == kKeyConstant) return end.y;
  // A linear end key extends the line to its neighbour; any other, its outer handle.
  if (end.interpolation == kKeyLinear) {
    const double dx = end.x - neighbour.x;
    return dx != 0.0 ? end.y + (time - end.x) * (end.y - neighbour.y) / dx : end.y;
  }
  const double hx = first ? end.x - end.lx : end.rx - end.x;
  const double hy = first ? end.y - end.ly : end.ry - end.y;
  return hx != 0.0 ? end.y + (time - end.x) * hy / hx : end.y;
}

}  // namespace

Status FCurveEvaluateJob::Validate() const {
  const Eigen::Index keys = co.rows();
  const Eigen::Index curves = key_offsets.size() - 1;
  if (co.cols() != 2 || handle_left.rows() != keys || handle_left.cols() != 2 ||
      handle_right.rows() != keys || handle_right.cols() != 2 || interpolation.size() != keys) {
    return Status::Fail("fcurve evaluate: co, handle_left and handle_right must be keys x 2 and "
                        "interpolation must have one entry per key");
  }
  if (curves < 0 || linear_extrapolation.size() != curves) {
    return Status::Fail("fcurve evaluate: key_offsets needs curves + 1 entries and "
                        "linear_extrapolation one per curve");
  }
  if (values.rows() != curves || values.cols() != times.size()) {
    return Status::Fail("fcurve evaluate: values must be " + std::to_string(curves) + " x " +
                        std::to_string(times.size()));
  }
  if (key_offsets[0] != 0 || key_offsets[curves] != keys) {
    return Status::Fail("fcurve evaluate: key_offsets must run from 0 to the number of keys");
  }
  for (Eigen::Index c = 0; c < curves; ++c) {
    const int begin = key_offsets[c], end = key_offsets[c + 1];
    if (end <= begin) {
      return Status::Fail("fcurve evaluate: curve " + std::to_string(c) + " has no keys");
    }
    for (int k = begin; k < end; ++k) {
      if (!co.row(k).allFinite() || !handle_left.row(k).allFinite() ||
          !handle_right.row(k).allFinite()) {
        return Status::Fail("fcurve evaluate: curve " + std::to_string(c) + ", key " +
                            std::to_string(k - begin) + " is not finite");
      }
      if (k > begin && co(k, 0) < co(k - 1, 0)) {
        return Status::Fail("fcurve evaluate: curve " + std::to_string(c) + ", key " +
                            std::to_string(k - begin) + " comes before the key it follows");
      }
    }
  }
  if (!times.allFinite()) return Status::Fail("fcurve evaluate: a time is not finite");
  return Status::Ok();
}

void FCurveEvaluateJob::Run() {
  Validate().ThrowIfFailed();
  const Eigen::Index curves = key_offsets.size() - 1;
  for (Eigen::Index c = 0; c < curves; ++c) {
    const int begin = key_offsets[c], end = key_offsets[c + 1];
    const Key first = KeyAt(*this, begin), last = KeyAt(*this, end - 1);
    const bool single = end - begin == 1;
    const bool linear = linear_extrapolation[c] != 0;
    int k = begin;  // times are usually increasing: walk forward, search otherwise
    for (Eigen::Index s = 0; s < times.size(); ++s) {
      const double time = times[s];
      double value;
      if (time <= first.x) {
        value = time == first.x ? first.y
                                : Extrapolate(first, single ? first : KeyAt(*this, begin + 1), true,
                                              linear, single, time);
      } else if (time >= last.x) {
        value = time == last.x ? last.y
                               : Extrapolate(last, single ? last : KeyAt(*this, end - 2), false,
                                             linear, single, time);
      } else {
        if (!(co(k, 0) <= time && time < co(k + 1, 0))) {
          // Binary search for the segment [k, k + 1) holding time.
          int lo = begin, hi = end - 1;
          while (hi - lo > 1) {
            const int mid = (lo + hi) / 2;
            if (co(mid, 0) <= time) lo = mid; else hi = mid;
          }
          k = lo;
        }
        const Key k0 = KeyAt(*this, k), k1 = KeyAt(*this, k + 1);
        // Blender snaps a time within 1e-4 frames of a key onto the key.
        if (std::abs(time - k0.x) < kOnKey) {
          value = k0.y;
        } else if (std::abs(k1.x - time) < kOnKey) {
          value = k1.y;
        } else {
          value = EvaluateSegment(k0, k1, time);
        }
      }
      values(c, s) = value;
    }
  }
}

}  // namespace motionkit
