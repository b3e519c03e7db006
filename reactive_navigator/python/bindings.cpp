// Python access to the navigator's parameter tables (the export check_config's schema and the
// README table come from, scripts/export_parameters) and its parameter checks (check_config's
// agreement test): reactive_navigator_core.
#include <pybind11/pybind11.h>

#include "laserscan_common/parameter_table_python.hpp"
#include "reactive_navigator/parameters.hpp"

namespace py = pybind11;
using namespace reactive_navigator;

PYBIND11_MODULE(reactive_navigator_core, m)
{
  m.doc() = "The reactive navigator's parameters (ROS-free core; times in seconds, lengths in metres)";
  // Local: every module of the toolbox registers the same C++ type, each as its own Python class.
  py::register_local_exception<ParameterError>(m, "ParameterError", PyExc_ValueError);

  // Under the ROS parameter names; footprint, shape_3d and height_band are read outside the tables.
  py::class_<NavigatorParameters> navigator(m, "NavigatorParameters");
  navigator.def(py::init<>());
  laserscan_common::python::bindFields(navigator);
  navigator.def("validate", &NavigatorParameters::validate,
                "Raises ParameterError (a ValueError) naming the bad parameter");
  py::class_<NodeParameters> node(m, "NodeParameters");
  node.def(py::init<>());
  laserscan_common::python::bindFields(node);
  node.def("validate", &NodeParameters::validate, "Raises ParameterError (a ValueError) naming the bad parameter");

  m.def("parameter_table", &laserscan_common::python::table<NavigatorParameters>,
        "The field table of the navigation core's parameters (the export)");
  m.def("node_parameter_table", &laserscan_common::python::table<NodeParameters>,
        "The field table of the ROS node's own parameters (the export)");
}
