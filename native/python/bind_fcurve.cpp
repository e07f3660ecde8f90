// Native evaluation of Blender F-curves (constant, linear, Bezier keys).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "motionkit/fcurve_eval.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace motionkit::python {

void BindFCurve(py::module_& m) {
  m.def(
      "evaluate_fcurves",
      [](Eigen::Ref<const RowMatrixXd> co, Eigen::Ref<const RowMatrixXd> handle_left,
         Eigen::Ref<const RowMatrixXd> handle_right, Eigen::Ref<const Eigen::VectorXi> interpolation,
         Eigen::Ref<const Eigen::VectorXi> key_offsets, Eigen::Ref<const Eigen::VectorXi> linear_extrapolation,
         Eigen::Ref<const Eigen::VectorXd> times) {
        const Eigen::Index curves = std::max<Eigen::Index>(key_offsets.size() - 1, 0);
        Output<> values(curves, times.size());
        FCurveEvaluateJob job(co, handle_left, handle_right, interpolation, key_offsets, linear_extrapolation,
                              times, values.view);
        RunWithoutGil(job);
        return values.array;
      },
      "co"_a.noconvert(), "handle_left"_a.noconvert(), "handle_right"_a.noconvert(), "interpolation"_a.noconvert(),
      "key_offsets"_a.noconvert(), "linear_extrapolation"_a.noconvert(), "times"_a.noconvert(),
      R"pbdoc(
        Evaluate many F-curves at many times, as fcurve.evaluate does for
        CONSTANT, LINEAR and BEZIER keys (no easing types, no modifiers).
        co, handle_left, handle_right: float64 (keys, 2), all curves back to back;
        interpolation: int32 (keys,) Blender enum values; key_offsets: int32
        (curves + 1,); linear_extrapolation: int32 (curves,); times: float64
        (samples,). Returns values, float64 (curves, samples).
      )pbdoc");
}

}  // namespace motionkit::python
