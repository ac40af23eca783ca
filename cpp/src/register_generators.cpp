// Bindings for the recursive noise generators used by simulation (AR(1) banks, random walks).
#include "bindings.hpp"

namespace allanite::bind {

void register_generators(pybind11::module_& /*m*/) {}

}  // namespace allanite::bind
