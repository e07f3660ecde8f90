// Keyframe interpolation: sampling curves and their Hermite (Bezier) form.
// Unlike the in-place calls, these return new arrays: the result's shape
// follows the input's (1-D values in, 1-D samples out).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "bindings.hpp"
#include "motionkit/error.hpp"
#include "motionkit/interpolation.hpp"
#include "motionkit/types.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace motionkit::python {
namespace {

// The curve data: float64, C order, never copied (anything else is a TypeError).
using Exact = py::array_t<double, py::array::c_style>;
// Small option arrays: converted from lists or other dtypes.
using Loose = std::optional<py::array_t<double, py::array::c_style | py::array::forcecast>>;

using MapMatrix = Eigen::Map<const RowMatrixXd>;
using MapVector = Eigen::Map<const Eigen::VectorXd>;

Interpolant Kind(const std::string& name) {
  const auto kind = ParseInterpolant(name);
  if (!kind) {
    throw Error("unknown interpolation kind '" + name + "'; expected one of: " + InterpolantNames());
  }
  return *kind;
}

std::string Shape(const py::array& a) {
  std::string text = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) text += (i ? ", " : "") + std::to_string(a.shape(i));
  return text + (a.ndim() == 1 ? ",)" : ")");
}

MapVector Vector(const char* where, const char* what, const py::array_t<double, py::array::c_style>& a) {
  if (a.ndim() != 1) throw Error(std::string(where) + ": " + what + " must be 1-D, got shape " + Shape(a));
  return MapVector(a.data(), a.shape(0));
}

// 1-D arrays are one component per key.
MapMatrix Matrix(const char* where, const char* what, const py::array_t<double, py::array::c_style>& a) {
  if (a.ndim() == 1) return MapMatrix(a.data(), a.shape(0), 1);
  if (a.ndim() == 2) return MapMatrix(a.data(), a.shape(0), a.shape(1));
  throw Error(std::string(where) + ": " + what + " must be 1-D or 2-D, got shape " + Shape(a));
}

// Option arrays shared by the three calls. `ends` is the number of end
// slopes per end: d for one curve, c for many scalar curves.
InterpolationOptions Options(const char* where, Interpolant kind, const Loose& slopes,
                             const Loose& end_slopes, Eigen::Index ends, const Loose& tension,
                             const Loose& continuity, const Loose& bias) {
  InterpolationOptions options;
  options.interpolant = kind;
  if (slopes) options.slopes.emplace(Matrix(where, "slopes", *slopes));
  if (end_slopes) {
    const py::array& e = *end_slopes;
    const bool ok = e.ndim() == 2 ? e.shape(0) == 2 && e.shape(1) == ends
                                  : e.ndim() == 1 && ends == 1 && e.shape(0) == 2;
    if (!ok) {
      throw Error(std::string(where) + ": end_slopes must be (start, end): shape (2, " +
                  std::to_string(ends) + ")" + (ends == 1 ? " or (2,)" : "") + ", got " + Shape(e));
    }
    options.start_slope.emplace(MapVector(end_slopes->data(), ends));
    options.end_slope.emplace(MapVector(end_slopes->data() + ends, ends));
  }
  if (tension) options.tension.emplace(Vector(where, "tension", *tension));
  if (continuity) options.continuity.emplace(Vector(where, "continuity", *continuity));
  if (bias) options.bias.emplace(Vector(where, "bias", *bias));
  return options;
}

// An output shaped as the values are: (rows,) for 1-D values (one component), else (rows, cols).
Output<> Like(const py::array& values, Eigen::Index rows, Eigen::Index cols) {
  return values.ndim() == 1 ? Output<>(rows) : Output<>(rows, cols);
}

py::object Interpolate(const Exact& times, const Exact& values, const Exact& eval_times,
                       const std::string& kind, const Loose& slopes, const Loose& end_slopes,
                       const Loose& tension, const Loose& continuity, const Loose& bias,
                       bool derivative) {
  const char* where = "interpolate";
  const MapVector t = Vector(where, "times", times);
  const MapMatrix y = Matrix(where, "values", values);
  const MapVector x = Vector(where, "eval_times", eval_times);
  const InterpolationOptions options =
      Options(where, Kind(kind), slopes, end_slopes, y.cols(), tension, continuity, bias);
  Output<> samples = Like(values, x.size(), y.cols());
  Output<> derivatives = Like(values, derivative ? x.size() : 0, y.cols());
  InterpolateJob job(t, y, options, x, samples.view);
  if (derivative) job.derivatives.emplace(derivatives.view);
  RunWithoutGil(job);
  if (derivative) return py::make_tuple(samples.array, derivatives.array);
  return py::object(samples.array);
}

py::tuple HermiteForm(const Exact& times, const Exact& values, const std::string& kind,
                      const Loose& slopes, const Loose& end_slopes, const Loose& tension,
                      const Loose& continuity, const Loose& bias) {
  const char* where = "hermite_form";
  const MapVector t = Vector(where, "times", times);
  const MapMatrix y = Matrix(where, "values", values);
  const InterpolationOptions options =
      Options(where, Kind(kind), slopes, end_slopes, y.cols(), tension, continuity, bias);
  Output<> slopes_in = Like(values, y.rows(), y.cols());
  Output<> slopes_out = Like(values, y.rows(), y.cols());
  HermiteFormJob job(t, y, options, slopes_in.view, slopes_out.view);
  RunWithoutGil(job);
  return py::make_tuple(slopes_in.array, slopes_out.array);
}

py::object InterpolateCurves(const py::array& offsets, const Exact& times, const Exact& values,
                             const Exact& eval_times, const std::string& kind, const Loose& slopes,
                             const Loose& end_slopes, const Loose& tension, const Loose& continuity,
                             const Loose& bias, bool derivative) {
  const char* where = "interpolate_curves";
  if (offsets.ndim() != 1 || (offsets.dtype().kind() != 'i' && offsets.dtype().kind() != 'u')) {
    throw py::type_error("interpolate_curves: offsets must be a 1-D integer array");
  }
  const auto wide = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(offsets);
  Eigen::VectorXi starts(wide.shape(0));
  for (Eigen::Index c = 0; c < starts.size(); ++c) {
    const std::int64_t v = wide.at(c);
    if (v < 0 || v > std::numeric_limits<int>::max()) {
      throw Error("interpolate_curves: offsets[" + std::to_string(c) + "] = " + std::to_string(v) +
                  " is out of range");
    }
    starts[c] = static_cast<int>(v);
  }
  if (starts.size() == 0) throw Error("interpolate_curves: offsets needs curves + 1 entries");
  const Eigen::Index curves = starts.size() - 1;
  const MapVector t = Vector(where, "times", times);
  const MapVector y = Vector(where, "values", values);
  const MapVector x = Vector(where, "eval_times", eval_times);
  const InterpolationOptions options =
      Options(where, Kind(kind), slopes, end_slopes, curves, tension, continuity, bias);
  Output<> samples(curves, x.size()), derivatives(derivative ? curves : 0, x.size());
  InterpolateCurvesJob job(starts, t, y, options, x, samples.view);
  if (derivative) job.derivatives.emplace(derivatives.view);
  RunWithoutGil(job);
  if (derivative) return py::make_tuple(samples.array, derivatives.array);
  return py::object(samples.array);
}

}  // namespace

void BindInterpolation(py::module_& m) {
  m.def("interpolate", &Interpolate, "times"_a.noconvert(), "values"_a.noconvert(),
        "eval_times"_a.noconvert(), "kind"_a = "natural", py::kw_only(), "slopes"_a = py::none(),
        "end_slopes"_a = py::none(), "tension"_a = py::none(), "continuity"_a = py::none(),
        "bias"_a = py::none(), "derivative"_a = false,
        R"pbdoc(
        Sample a keyed curve at eval_times (any order; sorted is fastest).

        times: float64 (n,), strictly increasing. values: float64 (n,) or
        (n, d), C order. eval_times: float64 (m,). Returns (m,) or (m, d) as
        values, and with derivative=True a tuple (samples, d/dt samples).
        kind: stepped, linear, polynomial, natural, clamped, periodic,
        not-a-knot (the splines equal scipy's CubicSpline bc_type), hermite
        (slopes shaped as values), catmull-rom, centripetal, chordal,
        kochanek-bartels (tension, continuity, bias: (n,) each, default 0),
        monotone (= scipy's PchipInterpolator). end_slopes: clamped's first
        derivatives as (start, end), shape (2,) or (2, d); default 0.
        Outside the keys the end values are held (derivative 0).
        Raises MotionKitError naming the key or component at fault.
      )pbdoc");

  m.def("hermite_form", &HermiteForm, "times"_a.noconvert(), "values"_a.noconvert(),
        "kind"_a = "natural", py::kw_only(), "slopes"_a = py::none(), "end_slopes"_a = py::none(),
        "tension"_a = py::none(), "continuity"_a = py::none(), "bias"_a = py::none(),
        R"pbdoc(
        The curve as cubic Hermite segments: (slopes_in, slopes_out), shaped as
        values, in value per time unit. On [t_i, t_i+1] the curve is the cubic
        Hermite from (t_i, y_i, slopes_out[i]) to (t_i+1, y_i+1, slopes_in[i+1]);
        as Bezier handles, h = t_i+1 - t_i: right handle of key i at
        (t_i + h/3, y_i + slopes_out[i] h/3), left handle of key i+1 at
        (t_i+1 - h/3, y_i+1 - slopes_in[i+1] h/3). Not for stepped or
        polynomial. Arguments as for interpolate().
      )pbdoc");

  TestingModule(m).def("interpolate_curves", &InterpolateCurves, "offsets"_a, "times"_a.noconvert(),
        "values"_a.noconvert(), "eval_times"_a.noconvert(), "kind"_a = "natural", py::kw_only(),
        "slopes"_a = py::none(), "end_slopes"_a = py::none(), "tension"_a = py::none(),
        "continuity"_a = py::none(), "bias"_a = py::none(), "derivative"_a = false,
        R"pbdoc(
        Sample many scalar curves, each with its own keys, at shared times.

        Curve k owns times[offsets[k]:offsets[k+1]] and the same slice of
        values (and of slopes, tension, continuity, bias). offsets: integer
        (c + 1,); times, values: float64 (total,); eval_times: float64 (m,).
        end_slopes: clamped's (start, end) per curve, shape (2, c).
        Returns (c, m), and with derivative=True a tuple with d/dt (c, m).
      )pbdoc");
}

}  // namespace motionkit::python
