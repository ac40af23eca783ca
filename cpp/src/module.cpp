// allanite._core: the private compiled module. Each area registers itself here.
#include "bindings.hpp"

PYBIND11_MODULE(_core, m) {
  m.doc() = "allanite compiled core (private; use the allanite package API)";
  allanite::bind::register_variances(m);
  allanite::bind::register_generators(m);
  allanite::bind::register_streaming(m);
}
