// The private extension module motionkit._native. Arrays cross without copies:
// inputs bind as Eigen::Ref<const RowMajor> with noconvert(), so a wrong dtype
// or layout is a TypeError rather than a silent copy, and every output is a
// numpy array the function allocates and returns (docs/architecture.md).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>

#include "bindings.hpp"
#include "motionkit/error.hpp"
#include "motionkit/keyframes.hpp"
#include "motionkit/types.hpp"
#include "motionkit/version.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace {

// Where C++ sees the array's first element; equal to numpy's data pointer
// exactly when nothing was copied on the way in.
std::uintptr_t DataAddress(const motionkit::ConstMatrixView& a) {
  return reinterpret_cast<std::uintptr_t>(a.data());
}

py::array_t<float, py::array::c_style> KeyframeCo(const motionkit::ConstVectorView& frames,
                                                  const motionkit::ConstMatrixView& values) {
  motionkit::python::Output<float> co(values.rows(), 2 * frames.size());
  motionkit::KeyframeCoJob job(frames, values, co.view);
  motionkit::python::RunWithoutGil(job);
  return co.array;
}

}  // namespace

PYBIND11_MODULE(_native, m) {
  m.doc() = R"pbdoc(
    MotionKit's native core (private module; use the motionkit package).

    Arrays are float64 C-contiguous inputs, taken without a copy; every output
    is an array the function returns, allocated once, natively. Failures raise
    MotionKitError.
  )pbdoc";

  py::register_exception<motionkit::Error>(m, "MotionKitError", PyExc_ValueError);

  m.attr("__version__") = motionkit::Version();

  m.def(
      "build_info",
      []() {
        py::dict info;
        info["version"] = motionkit::Version();
        info["eigen"] = motionkit::EigenVersion();
        info["pybind11"] = std::to_string(PYBIND11_VERSION_MAJOR) + "." +
                           std::to_string(PYBIND11_VERSION_MINOR) + "." +
                           std::to_string(PYBIND11_VERSION_PATCH);
        info["compiler"] = __VERSION__;
        info["python"] = std::to_string(PY_MAJOR_VERSION) + "." + std::to_string(PY_MINOR_VERSION);
        return info;
      },
      R"pbdoc(
        The versions this module was built with: MotionKit, Eigen, pybind11,
        the C++ compiler and the Python it targets.
      )pbdoc");

  // Functions only the tests use live apart, so that the module's own surface is what the add-on calls.
  py::module_ testing = m.def_submodule("_testing", R"pbdoc(
    Functions the test suites use to look inside the core (zero-copy checks, the
    BVH text round trip, single interpolants); the add-on never calls them.
  )pbdoc");

  testing.def("data_address", &DataAddress, "array"_a.noconvert(),
        py::call_guard<py::gil_scoped_release>(),
        R"pbdoc(
        Address of the first element of a 2-D float64 C-contiguous array as the
        native code sees it. Equals array.ctypes.data: proof that no copy was
        made. Any other dtype or layout raises TypeError instead of copying.
      )pbdoc");

  m.def("keyframe_co", &KeyframeCo, "frames"_a.noconvert(), "values"_a.noconvert(),
        R"pbdoc(
        Interleave key times and values into F-curve "co" layout.

        frames: float64 (n,), strictly increasing.
        values: float64 (c, n), C-contiguous; row k is curve k.
        Returns co, float32 (c, 2n):
                co[k] = [frames[0], values[k,0], frames[1], values[k,1], ...].
        Raises MotionKitError naming the curve and key on NaN or infinity.
      )pbdoc");

  motionkit::python::BindBody(m);
  motionkit::python::BindBvh(m);
  motionkit::python::BindRotation(m);
  motionkit::python::BindFCurve(m);
  motionkit::python::BindRotationInterpolation(m);
  motionkit::python::BindKeyReduction(m);
  motionkit::python::BindInterpolation(m);
  motionkit::python::BindRig(m);
  motionkit::python::BindRetarget(m);
  motionkit::python::BindIk(m);
  motionkit::python::BindContacts(m);
  motionkit::python::BindFilters(m);
  motionkit::python::BindMirror(m);
}
