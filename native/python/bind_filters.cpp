// Filters over whole clips: scalar channels and rotations on the sphere.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>

#include "bindings.hpp"
#include "motionkit/error.hpp"
#include "motionkit/filters.hpp"
#include "motionkit/types.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace motionkit::python {
namespace {

FilterSettings Settings(const std::string& kind, double fps, double cutoff, int order, double sigma, int size,
                        double min_cutoff, double beta, double d_cutoff) {
  const auto parsed = ParseFilterKind(kind);
  if (!parsed) throw Error("unknown filter kind '" + kind + "'; expected butterworth, gaussian, median or one_euro");
  FilterSettings settings;
  settings.kind = *parsed;
  settings.fps = fps;
  settings.cutoff = cutoff;
  settings.order = order;
  settings.sigma = sigma;
  settings.size = size;
  settings.min_cutoff = min_cutoff;
  settings.beta = beta;
  settings.d_cutoff = d_cutoff;
  return settings;
}

// Both functions take the same arguments and return an array shaped as their input.
template <class Job>
DoubleArray Filter(const ConstMatrixView& values, const std::string& kind, double fps, double cutoff, int order,
                   double sigma, int size, double min_cutoff, double beta, double d_cutoff) {
  const FilterSettings settings = Settings(kind, fps, cutoff, order, sigma, size, min_cutoff, beta, d_cutoff);
  Output<> filtered(values.rows(), values.cols());
  Job job(values, settings, filtered.view);
  RunWithoutGil(job);
  return filtered.array;
}

template <class Job>
void DefineFilter(py::module_& m, const char* name, const char* input, const char* doc) {
  m.def(name, &Filter<Job>, py::arg(input).noconvert(), "kind"_a, "fps"_a, py::kw_only(), "cutoff"_a = 7.0,
        "order"_a = 4, "sigma"_a = 1.0, "size"_a = 5, "min_cutoff"_a = 1.0, "beta"_a = 0.0, "d_cutoff"_a = 1.0,
        doc);
}

}  // namespace

void BindFilters(py::module_& m) {
  DefineFilter<FilterChannelsJob>(m, "filter_channels", "values", R"pbdoc(
        Filter scalar channels sampled once per frame at fps frames per second.

        values: float64 (frames, channels), C-contiguous; each column one channel.
        kind "butterworth": zero-phase low-pass in second-order sections,
        scipy.signal.butter(order, cutoff, fs=fps, output='sos') run by
        sosfiltfilt(padtype='odd', padlen=min(3 (order + 1), frames - 1));
        cutoff in Hz below fps / 2, order 1..8, frames >= 2.
        "gaussian": ndimage.gaussian_filter1d(sigma, mode='reflect'), sigma in
        frames. "median": running median of odd size (3 up to frames; larger is
        an error, not clamped), the ends extended by their values
        (ndimage.median_filter(mode='nearest')). "one_euro": the causal One-Euro
        filter with min_cutoff (Hz), beta and d_cutoff (Hz).
        Returns a new (frames, channels) array. Raises MotionKitError naming the
        kind and the numbers for bad parameters, the channel and frame for a
        value that is not finite. The GIL is released while it runs.
      )pbdoc");
  DefineFilter<FilterRotationsJob>(m, "filter_rotations", "quaternions", R"pbdoc(
        Filter rotations on the sphere: quaternions float64 (frames, 4 * bones),
        each bone's w x y z per frame, unit (within 1e-6), either sign.

        The scalar filter of filter_channels (same kind and parameters) runs on
        rotation vectors in the tangent space of a smooth reference (the
        integral of the filtered angular velocities, corrected three times by
        the filtered deviation), never on Euler angles or components; a
        constant-speed rotation comes back unchanged. "median" takes each
        frame's window in the tangent space at that frame. "one_euro" slerps
        towards each sample by the One-Euro filter's adaptive factor (causal).
        Returns (frames, 4 * bones) unit quaternions, each bone's signs
        continuous, the first frame's sign the input's. Raises MotionKitError
        naming the bone and frame of a quaternion that is not unit or not
        finite. The GIL is released while it runs.
      )pbdoc");
}

}  // namespace motionkit::python
