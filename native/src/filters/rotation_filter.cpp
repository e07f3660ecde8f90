// Rotations filtered on the sphere (Lee and Shin 2002): the scalar filter runs
// on rotation vectors in the tangent space of a smooth reference, never on
// Euler angles or quaternion components.
#include <cmath>
#include <string>

#include "../so3.hpp"
#include "filter_internal.hpp"

namespace motionkit {
namespace {

// Quaternions from numbers such as Blender's float32 bone rotations are unit to a few 1e-7.
constexpr double kUnitTolerance = 1e-6;

// A frame's turn and a filter's deviation or move are small angles: below kSmall
// (the tangent of a half-angle, or a half-angle) the maps below use power series
// whose first omitted term is under 1e-18 of the sum, exact to double rounding at
// a fraction of the cost of atan2, sincos and their square roots and divisions
// (in one pass of the filter every sample takes both maps). Larger angles take
// so3.hpp's closed forms.
constexpr double kSmall = 1.0 / 16.0;

// atan(x) / x for y = x^2 <= kSmall^2: 1 - y/3 + y^2/5 - ...; the first term
// left out, x^14 / 15, is at most 16^-14 / 15 < 1e-18. Summed in pairs
// (Estrin's scheme), a third of the chain of dependent steps of Horner's.
inline double AtanOverX(double y) {
  const double y2 = y * y;
  const double low = (1.0 - y * (1.0 / 3.0)) + y2 * (1.0 / 5.0 - y * (1.0 / 7.0));
  const double high = (1.0 / 9.0 - y * (1.0 / 11.0)) + y2 * (1.0 / 13.0);
  return low + (y2 * y2) * high;
}

// sin(h) / h and cos(h) for z = h^2 <= kSmall^2, to z^4: the terms left out are
// below 16^-10 / 10! < 3e-19.
inline double SinOverX(double z) {
  return 1.0 + z * (-1.0 / 6.0 + z * (1.0 / 120.0 + z * (-1.0 / 5040.0 + z * (1.0 / 362880.0))));
}
inline double Cosine(double z) {
  return 1.0 + z * (-1.0 / 2.0 + z * (1.0 / 24.0 + z * (-1.0 / 720.0 + z * (1.0 / 40320.0))));
}

// internal::RotationVector: q's rotation vector, 2 atan2(|v|, w) v / |v| with w
// made >= 0; for |v| <= kSmall w, that is (2 / w) (atan(x) / x) v with x = |v| / w.
// Scale-free like atan2, so a quaternion from float32 numbers (unit to 1e-7)
// gives the same vector either way.
inline Eigen::Vector3d Tangent(const Eigen::Quaterniond& q) {
  const double w = std::abs(q.w()), s2 = q.vec().squaredNorm();
  if (!(s2 <= kSmall * kSmall * w * w)) return internal::RotationVector(q);
  const double inverse = (q.w() < 0.0 ? -1.0 : 1.0) / w;  // 1 / w, with the sign that flips q to w >= 0
  return (2.0 * inverse * AtanOverX(s2 * inverse * inverse)) * q.vec();
}

// a b, written out in scalars: Eigen's SSE2 product loads its operands as
// pairs, and a quaternion built from four scalars just before (Turn's) reaches
// it through memory, where the processor stalls on every such load (two 8-byte
// stores do not forward to one 16-byte load); about a tenth of the filter's time.
inline Eigen::Quaterniond Product(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return Eigen::Quaterniond(a.w() * b.w() - a.x() * b.x() - a.y() * b.y() - a.z() * b.z(),
                            a.w() * b.x() + a.x() * b.w() + a.y() * b.z() - a.z() * b.y(),
                            a.w() * b.y() - a.x() * b.z() + a.y() * b.w() + a.z() * b.x(),
                            a.w() * b.z() + a.x() * b.y() - a.y() * b.x() + a.z() * b.w());
}

// q / |q| for a product of unit quaternions, |q|^2 = 1 + e with |e| tiny: one
// Newton step for 1 / sqrt(1 + e), 1 - e / 2, is exact to 3 e^2 / 8 (below
// 4e-19 for the |e| <= 1e-9 it takes), without the square root and division.
// The first frame comes from float32 numbers, further from unit: that takes the
// exact way.
inline Eigen::Quaterniond Unit(const Eigen::Quaterniond& q) {
  const double e = q.squaredNorm() - 1.0;
  if (!(std::abs(e) <= 1e-9)) return q.normalized();
  return Eigen::Quaterniond((1.0 - 0.5 * e) * q.coeffs());
}

// internal::FromRotationVector: (cos(a / 2), sin(a / 2) v / a) for the rotation
// vector v of angle a = |v|, by the series in z = a^2 / 4 where a / 2 <= kSmall
// (no square root at all). squared_norm: |v|^2.
inline Eigen::Quaterniond Turn(const Eigen::Vector3d& v, double squared_norm) {
  const double z = 0.25 * squared_norm;
  if (!(z <= kSmall * kSmall)) return internal::FromRotationVector(v);
  const double s = 0.5 * SinOverX(z);  // sin(a / 2) / a
  return Eigen::Quaterniond(Cosine(z), s * v.x(), s * v.y(), s * v.z());
}

Eigen::Quaterniond QuaternionAt(const ConstMatrixView& quaternions, Eigen::Index frame, Eigen::Index bone) {
  const auto wxyz = quaternions.row(frame).segment<4>(4 * bone);
  return Eigen::Quaterniond(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
}

// One bone's filter, with scratch for a whole clip sized once and reused for
// every bone a thread filters.
class BoneFilter {
 public:
  BoneFilter(const internal::FilterDesign& design, Eigen::Index frames)
      : design_(design), filter_(design, frames), input_(frames), reference_(frames),
        tangent_(frames, 4), smoothed_(frames, 4) {}

  void Run(const ConstMatrixView& quaternions, Eigen::Index bone, Eigen::Ref<RowMatrixXd> filtered) {
    const Eigen::Index n = quaternions.rows();
    for (Eigen::Index i = 0; i < n; ++i) {
      input_[i] = QuaternionAt(quaternions, i, bone);
      if (i > 0 && input_[i].dot(input_[i - 1]) < 0.0) input_[i].coeffs() = -input_[i].coeffs();
    }
    if (design_.settings.kind == FilterKind::kOneEuro) {
      internal::OneEuroRotations(design_.settings, input_.data(), n, reference_.data());
    } else if (design_.settings.kind == FilterKind::kMedian) {
      std::copy(input_.begin(), input_.end(), reference_.begin());
      // tangent_ holds 4 frames >= 3 size values (Validate).
      Repeat([&] { return internal::MedianRotations(design_.settings.size, input_.data(), n, reference_.data(),
                                                    tangent_.data()); });
    } else {
      IntegrateFilteredVelocities(n);
      Repeat([&] { return Correct(n); });
    }
    // The first frame takes the input's sign, each later one its predecessor's hemisphere.
    Eigen::Quaterniond previous = input_[0];
    for (Eigen::Index i = 0; i < n; ++i) {
      Eigen::Quaterniond q = reference_[i];
      if (q.dot(previous) < 0.0) q.coeffs() = -q.coeffs();
      filtered.row(i).segment<4>(4 * bone) << q.w(), q.x(), q.y(), q.z();
      previous = q;
    }
  }

 private:
  // pass() at most kCorrections times, until the largest move it returns (radians) is below kConverged.
  template <class Pass>
  static void Repeat(const Pass& pass) {
    for (int k = 0; k < FilterRotationsJob::kCorrections; ++k) {
      if (pass() < FilterRotationsJob::kConverged) return;
    }
  }

  // The first reference: the first sample, then each step the filtered angular
  // velocity. A constant velocity passes every kind unchanged, so a
  // constant-speed rotation is its own reference.
  void IntegrateFilteredVelocities(Eigen::Index n) {
    for (Eigen::Index i = 0; i + 1 < n; ++i) {
      tangent_.row(i).head<3>() = Tangent(Product(input_[i].conjugate(), input_[i + 1]));
    }
    FilterTangents(n - 1);
    reference_[0] = input_[0];
    for (Eigen::Index i = 0; i + 1 < n; ++i) {
      const Eigen::Vector3d step = smoothed_.row(i).head<3>();
      reference_[i + 1] = Unit(Product(reference_[i], Turn(step, step.squaredNorm())));
    }
  }

  // Moves the reference by the filtered deviation of the input from it; the
  // largest move (radians).
  double Correct(Eigen::Index n) {
    for (Eigen::Index i = 0; i < n; ++i) {
      tangent_.row(i).head<3>() = Tangent(Product(reference_[i].conjugate(), input_[i]));
    }
    FilterTangents(n);
    double largest = 0.0;  // squared
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::Vector3d move = smoothed_.row(i).head<3>();
      const double squared = move.squaredNorm();
      largest = std::max(largest, squared);
      reference_[i] = Unit(Product(reference_[i], Turn(move, squared)));
    }
    return std::sqrt(largest);
  }

  void FilterTangents(Eigen::Index n) {
    if (n < 1) return;
    filter_.Apply(tangent_.data(), 4, 3, n, smoothed_.data(), 4);
  }

  // A frame a row, its three components side by side for the filter's lanes (the fourth unused).
  using Tangents = Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor>;

  const internal::FilterDesign& design_;
  internal::ScalarFilter filter_;
  std::vector<Eigen::Quaterniond> input_, reference_;
  Tangents tangent_, smoothed_;
};

}  // namespace

Status FilterRotationsJob::Validate() const {
  const Eigen::Index frames = quaternions.rows(), columns = quaternions.cols();
  if (columns % 4 != 0 || filtered.rows() != frames || filtered.cols() != columns) {
    return Status::Fail("filter_rotations: quaternions must be (frames, 4 * bones) and the output as large; got " +
                        std::to_string(frames) + " x " + std::to_string(columns) + " and " +
                        std::to_string(filtered.rows()) + " x " + std::to_string(filtered.cols()));
  }
  const Status status = settings.Validate(frames);
  if (!status) return status;
  for (Eigen::Index i = 0; i < frames; ++i) {
    for (Eigen::Index bone = 0; bone < columns / 4; ++bone) {
      const Eigen::Quaterniond q = QuaternionAt(quaternions, i, bone);
      if (!internal::IsUnitQuaternion(q, kUnitTolerance)) {
        const bool finite = q.coeffs().allFinite();
        return Status::Fail("filter_rotations: the quaternion of bone " + std::to_string(bone) + " at frame " +
                            std::to_string(i) +
                            (finite ? " has length " + internal::Number(q.norm()) + ", not 1"
                                    : std::string(" is not finite")));
      }
    }
  }
  return Status::Ok();
}

void FilterRotationsJob::Run() {
  Validate().ThrowIfFailed();
  const internal::FilterDesign design = internal::DesignFilter(settings);
  internal::ForEachRange(quaternions.cols() / 4, threads, [&](Eigen::Index begin, Eigen::Index end) {
    BoneFilter bone_filter(design, quaternions.rows());
    for (Eigen::Index bone = begin; bone < end; ++bone) bone_filter.Run(quaternions, bone, filtered);
  });
}

}  // namespace motionkit
