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
      tangent_.row(i).head<3>() = internal::RotationVector(input_[i].conjugate() * input_[i + 1]);
    }
    FilterTangents(n - 1);
    reference_[0] = input_[0];
    for (Eigen::Index i = 0; i + 1 < n; ++i) {
      reference_[i + 1] = (reference_[i] * internal::FromRotationVector(smoothed_.row(i).head<3>())).normalized();
    }
  }

  // Moves the reference by the filtered deviation of the input from it; the
  // largest move (radians).
  double Correct(Eigen::Index n) {
    for (Eigen::Index i = 0; i < n; ++i) {
      tangent_.row(i).head<3>() = internal::RotationVector(reference_[i].conjugate() * input_[i]);
    }
    FilterTangents(n);
    double largest = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::Vector3d move = smoothed_.row(i).head<3>();
      largest = std::max(largest, move.norm());
      reference_[i] = (reference_[i] * internal::FromRotationVector(move)).normalized();
    }
    return largest;
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
