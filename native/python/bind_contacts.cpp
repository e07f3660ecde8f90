// Foot contacts: the footskate cleanup's IK targets.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <vector>

#include "bindings.hpp"
#include "motionkit/foot_targets.hpp"
#include "motionkit/types.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace motionkit::python {
namespace {

py::tuple FootTargets(const ConstMatrixView& points, const BoolArray& contacts, int blend_frames,
                      std::vector<std::array<int, 2>> rigid_pairs) {
  if (contacts.ndim() != 2) throw Error("foot targets: contacts must be (frames, P)");
  const Eigen::Index frames = points.rows(), count = contacts.shape(1);
  const Eigen::Map<const Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> contact_view(
      contacts.data(), contacts.shape(0), count);
  Output<> targets(frames, points.cols()), weights(frames, count);
  FootTargetsJob job(points, contact_view, blend_frames, std::move(rigid_pairs), targets.view, weights.view);
  RunWithoutGil(job);
  return py::make_tuple(targets.array, weights.array);
}

}  // namespace

void BindContacts(py::module_& m) {
  m.def("foot_targets", &FootTargets, "points"_a.noconvert(), "contacts"_a, "blend_frames"_a,
        "rigid_pairs"_a = std::vector<std::array<int, 2>>{},
        R"pbdoc(
        The footskate cleanup's IK targets for a clip (docs/contacts.md).

        points: float64 (frames, 3P) foot points, P of them; contacts: bool
        (frames, P); blend_frames: the ramp's length either side of a
        contact; rigid_pairs: (a, b) points a bone's length apart (ankle and
        ball of one foot). Returns (targets (frames, 3P), weights (frames, P)):
        each point blended to its nearest contact's plant (its mean over that
        contact) by weight, carried with its foot's other point, and each
        foot's two targets kept the distance apart its points keep. The GIL is
        released while it runs.
      )pbdoc");
}

}  // namespace motionkit::python
