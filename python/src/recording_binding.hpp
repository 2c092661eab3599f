#pragma once
// plexus.Recording: a recording made by `plexus record`, read from Python (docs/RECORDING.md).

#include <pybind11/pybind11.h>

namespace plexus::python {

void bind_recording(pybind11::module_& module);

}  // namespace plexus::python
