// Python access to the range converter's core (tests drive it together with the merger core).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>

#include "depth_filter_scan_converter/range_to_scan.hpp"
#include "laserscan_common/parameter_table_python.hpp"

namespace py = pybind11;
namespace dfsc = depth_filter_scan_converter;

PYBIND11_MODULE(depth_filter_scan_converter_range_core, m)
{
  m.doc() = "sensor_msgs/Range -> LaserScan arc (the core of RangeScanConverterNodelet)";
  // Local: every module of the toolbox registers the same C++ type, each as its own Python class.
  py::register_local_exception<dfsc::ParameterError>(m, "ParameterError", PyExc_ValueError);

  py::class_<dfsc::RangeScanParameters> params(m, "RangeScanParameters");
  params.def(py::init<>()).def("validate", &dfsc::RangeScanParameters::validate);
  laserscan_common::python::bindFields(params);
  m.def("parameter_table", &laserscan_common::python::table<dfsc::RangeScanParameters>,
        "The field table of RangeScanParameters (the export)");

  py::class_<dfsc::RangeToScan>(m, "RangeToScan")
    .def(py::init<const dfsc::RangeScanParameters&>(), py::arg("params"))
    .def("reset", &dfsc::RangeToScan::reset)
    .def(
      "convert",
      [](dfsc::RangeToScan& c, double range, double field_of_view, double min_range, double max_range, double stamp,
         const std::string& frame_id, int radiation_type) -> py::object {
        dfsc::RangeReading r;
        r.range = range;
        r.field_of_view = field_of_view;
        r.min_range = min_range;
        r.max_range = max_range;
        r.stamp = stamp;
        r.frame_id = frame_id;
        r.radiation_type = static_cast<std::uint8_t>(radiation_type);
        dfsc::ArcScan scan;
        const std::string reason = c.convert(r, scan);
        if (!reason.empty())
          return py::str(reason);
        py::dict d;
        d["angle_min"] = scan.angle_min;
        d["angle_max"] = scan.angle_max;
        d["angle_increment"] = scan.angle_increment;
        d["range_min"] = scan.range_min;
        d["range_max"] = scan.range_max;
        d["ranges"] = py::array_t<float>(static_cast<py::ssize_t>(scan.ranges.size()), scan.ranges.data());
        d["kind"] = dfsc::readingKindName(scan.kind);
        return std::move(d);
      },
      py::arg("range"), py::arg("field_of_view"), py::arg("min_range"), py::arg("max_range"), py::arg("stamp") = 0.0,
      py::arg("frame_id") = "sonar", py::arg("radiation_type") = 0,
      "A dict (angle_min, angle_max, angle_increment, range_min, range_max, ranges, kind), or the reason "
      "(str) why the reading cannot be converted");
}
