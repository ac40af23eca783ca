// Shared declarations for the pybind11 bindings of allanite._core (bindings only: the
// numerics live in cpp/include/allanite).
#pragma once

#include <pybind11/pybind11.h>

namespace allanite::bind {

void register_variances(pybind11::module_& m);
void register_generators(pybind11::module_& m);
void register_streaming(pybind11::module_& m);

}  // namespace allanite::bind
