// Each area of the core binds itself into motionkit._native.
#pragma once

#include <pybind11/pybind11.h>

namespace motionkit::python {

void BindBvh(pybind11::module_& m);
void BindRotation(pybind11::module_& m);
void BindFCurve(pybind11::module_& m);
void BindRotationInterpolation(pybind11::module_& m);
void BindKeyReduction(pybind11::module_& m);
void BindInterpolation(pybind11::module_& m);
void BindRetarget(pybind11::module_& m);
void BindIk(pybind11::module_& m);
void BindContacts(pybind11::module_& m);

}  // namespace motionkit::python
