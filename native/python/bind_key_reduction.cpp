// Fitting the fewest Bézier keys to densely sampled curves.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <string>

#include "bindings.hpp"
#include "motionkit/error.hpp"
#include "motionkit/key_reduction.hpp"
#include "motionkit/rig.hpp"
#include "motionkit/types.hpp"
#include "motionkit/world_key_reduction.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace motionkit::python {
namespace {

KeyToleranceMode Mode(const std::string& text) {
  if (text == "absolute") return KeyToleranceMode::kAbsolute;
  if (text == "quaternion") return KeyToleranceMode::kQuaternion;
  if (text == "euler") return KeyToleranceMode::kEuler;
  throw Error("unknown key reduction mode '" + text + "'; expected absolute, quaternion or euler");
}

py::tuple ReduceKeys(const ConstVectorView& times, const ConstMatrixView& values, double tolerance,
                     const std::string& mode_text, const std::string& euler_order, Eigen::Index stride) {
  const auto order = ParseEulerOrder(euler_order);
  if (!order) {
    throw Error("unknown Euler order '" + euler_order + "'; expected XYZ, XZY, YXZ, YZX, ZXY or ZYX");
  }
  const py::ssize_t m = times.size(), d = values.cols();
  OutputVector<std::int64_t> indices(m);
  Output<> slopes_in(m, d), slopes_out(m, d);
  KeyReductionJob job(times, values, tolerance, indices.view, slopes_in.view, slopes_out.view);
  job.mode = Mode(mode_text);
  job.euler_order = *order;
  job.stride = stride;
  RunWithoutGil(job);
  const py::slice keys(0, static_cast<py::ssize_t>(job.key_count), 1);
  return py::make_tuple(indices.array[keys].attr("copy")(), slopes_in.array[keys].attr("copy")(),
                        slopes_out.array[keys].attr("copy")());
}

py::tuple ReduceKeysWorld(const RigModel& rig, const ConstVectorView& times, const ConstMatrixView& channels,
                          const Eigen::Ref<const Eigen::VectorXi>& rotation_modes,
                          const ConstIntMatrixView& group_ranges, double distance, double axis_length,
                          Eigen::Index stride) {
  const Eigen::Index m = times.size(), bones = rig.size();
  Output<bool> keys(m, 3 * bones);
  Output<> slopes_in(m, 10 * bones), slopes_out(m, 10 * bones);
  WorldKeyReductionJob job(rig, times, channels, rotation_modes, group_ranges, keys.view, slopes_in.view,
                           slopes_out.view);
  job.distance = distance;
  job.axis_length = axis_length;
  job.stride = stride;
  RunWithoutGil(job);
  return py::make_tuple(keys.array, slopes_in.array, slopes_out.array, job.worst_error);
}

}  // namespace

void BindKeyReduction(py::module_& m) {
  m.def("reduce_keys", &ReduceKeys, "times"_a.noconvert(), "values"_a.noconvert(), "tolerance"_a,
        "mode"_a = "absolute", "euler_order"_a = "XYZ", "stride"_a = 1,
        R"pbdoc(
        The fewest Bezier keys (free handles at 1/3 of each segment) whose curve
        stays within tolerance of the samples.

        times: float64 (m,), strictly increasing; values: float64 (m, d).
        mode "absolute": every channel within tolerance; "quaternion": d = 4
        channels w x y z, interpolated per channel and normalised as Blender
        poses a bone, error = angle to the sample's rotation (radians);
        "euler": d = 3 angles in the letter order of euler_order (intrinsic, as
        euler_to_quaternion: Blender rotation_mode 'XYZ' is euler_order "ZYX"
        with columns rotation_euler[::-1]), error = angle between rotations.
        stride: keys only at every stride-th sample and the last (samples taken
        several times per frame keep their keys on frames).

        Returns (indices int64 (k,), slopes_in (k, d), slopes_out (k, d)): the
        samples kept as keys (always the first and last) and each key's
        incoming and outgoing slope in value per time unit. Within tolerance at
        every sample given (pass 4-10 samples per frame for "everywhere").
        The GIL is released while it runs.
      )pbdoc");

  m.def("reduce_keys_world", &ReduceKeysWorld, "rig"_a, "times"_a.noconvert(), "channels"_a.noconvert(),
        "rotation_modes"_a.noconvert(), "group_ranges"_a.noconvert(), "distance"_a, "axis_length"_a,
        "stride"_a = 1,
        R"pbdoc(
        The fewest Bezier keys keeping every joint of the rig, and points
        axis_length along each bone's axes, within distance of the original
        pose on every sample (native/include/motionkit/world_key_reduction.hpp).

        times: float64 (m,); channels: float64 (m, 10 B), per bone rotation (4;
        Euler: 3 angles in the intrinsic order's letter order, then unused),
        location (3), scale (3); rotation_modes: int32 (B,) 0 quaternion,
        1 axis-angle, 2 + i Euler order i of XYZ XZY YXZ YZX ZXY ZYX;
        group_ranges: int32 (3 B, 2) first and last sample of the keys of each
        bone's rotation, location and scale, or -1 -1 to keep a group.
        Returns (keys bool (m, 3 B), slopes_in (m, 10 B), slopes_out (m, 10 B),
        worst error). The GIL is released while it runs.
      )pbdoc");
}

}  // namespace motionkit::python
