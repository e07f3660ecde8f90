// Evaluating Blender F-curves natively, many curves at many times in one call,
// as Blender's fcurve.evaluate does for constant, linear and Bezier keys:
// a Bezier handle that reaches past its segment is first shortened
// (BKE_fcurve_correct_bezpart), then the segment's cubic is solved for its
// parameter at the asked time. Easing interpolations (SINE, BOUNCE, ...) and
// F-curve modifiers are not handled here; callers fall back to Blender.
#pragma once

#include "motionkit/error.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

// Blender's Keyframe.interpolation values that we evaluate.
enum KeyInterpolation : int { kKeyConstant = 0, kKeyLinear = 1, kKeyBezier = 2 };

// Curves are stored back to back: curve c owns key rows
// [key_offsets[c], key_offsets[c + 1]) of co, handle_left, handle_right and
// interpolation. linear_extrapolation[c] selects Blender's 'LINEAR'
// extrapolation for curve c (else 'CONSTANT').
struct FCurveEvaluateJob {
  FCurveEvaluateJob(ConstMatrixView co_in, ConstMatrixView handle_left_in,
                    ConstMatrixView handle_right_in,
                    Eigen::Ref<const Eigen::VectorXi> interpolation_in,
                    Eigen::Ref<const Eigen::VectorXi> key_offsets_in,
                    Eigen::Ref<const Eigen::VectorXi> linear_extrapolation_in,
                    ConstVectorView times_in, Eigen::Ref<RowMatrixXd> values_out)
      : co(co_in),
        handle_left(handle_left_in),
        handle_right(handle_right_in),
        interpolation(interpolation_in),
        key_offsets(key_offsets_in),
        linear_extrapolation(linear_extrapolation_in),
        times(times_in),
        values(values_out) {}

  ConstMatrixView co;            // keys x 2: frame, value
  ConstMatrixView handle_left;   // keys x 2
  ConstMatrixView handle_right;  // keys x 2
  Eigen::Ref<const Eigen::VectorXi> interpolation;         // keys
  Eigen::Ref<const Eigen::VectorXi> key_offsets;           // curves + 1
  Eigen::Ref<const Eigen::VectorXi> linear_extrapolation;  // curves
  ConstVectorView times;                                   // samples
  Eigen::Ref<RowMatrixXd> values;                          // curves x samples

  Status Validate() const;
  void Run();
};

}  // namespace motionkit
