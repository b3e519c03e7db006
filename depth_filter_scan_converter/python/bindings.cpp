// Python access to the ROS-free core, for differential tests against numpy.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <tuple>

#include "depth_filter_scan_converter/projector.hpp"
#include "laserscan_common/fast_math.hpp"
#include "laserscan_common/parameter_table_python.hpp"
#include "laserscan_common/self_filter.hpp"

namespace py = pybind11;
namespace dfsc = depth_filter_scan_converter;

namespace
{
// A zero-copy view over a (N, C) or (H, W, C) float32/float64 array, C >= 3: channels 0..2 are
// x, y, z; `intensity_channel` (if >= 0) names the channel used as intensity. Any positive
// strides work, so slices give odd point_step / row_step layouts.
dfsc::CloudView viewOf(const py::array& a, int intensity_channel)
{
  dfsc::FieldType type;
  if (a.dtype().is(py::dtype::of<float>()))
    type = dfsc::FieldType::Float32;
  else if (a.dtype().is(py::dtype::of<double>()))
    type = dfsc::FieldType::Float64;
  else
    throw py::type_error("points must be float32 or float64");
  if (a.ndim() != 2 && a.ndim() != 3)
    throw py::value_error("points must have shape (N, C) or (H, W, C)");
  const py::ssize_t channels = a.shape(a.ndim() - 1);
  if (channels < 3 || intensity_channel >= channels)
    throw py::value_error("points need at least 3 channels (and the intensity channel)");
  dfsc::CloudView v;
  v.xyz_type = type;
  if (a.size() == 0)
    return v;  // an empty cloud: width = height = 0
  for (py::ssize_t i = 0; i < a.ndim(); ++i)
    if (a.strides(i) <= 0)
      throw py::value_error("points must have positive strides");
  v.data = static_cast<const std::uint8_t*>(a.data());
  const auto cs = static_cast<std::uint32_t>(a.strides(a.ndim() - 1));
  v.point_step = static_cast<std::uint32_t>(a.strides(a.ndim() - 2));
  if (a.ndim() == 3)
  {
    v.height = static_cast<std::uint32_t>(a.shape(0));
    v.width = static_cast<std::uint32_t>(a.shape(1));
    v.row_step = static_cast<std::uint32_t>(a.strides(0));
  }
  else
  {
    v.height = 1;
    v.width = static_cast<std::uint32_t>(a.shape(0));
    v.row_step = v.width * v.point_step;
  }
  v.x_offset = 0;
  v.y_offset = cs;
  v.z_offset = 2 * cs;
  v.xyz_type = type;
  if (intensity_channel >= 0)
  {
    v.has_intensity = true;
    v.intensity_offset = static_cast<std::uint32_t>(intensity_channel) * cs;
    v.intensity_type = type;
  }
  return v;
}

Eigen::Isometry3d isometryOf(const Eigen::Matrix4d& m)
{
  Eigen::Isometry3d t;
  t.matrix() = m;
  return t;
}

py::array_t<float> toArray(const std::vector<float>& v)
{
  return py::array_t<float>(static_cast<py::ssize_t>(v.size()), v.data());
}
}  // namespace

PYBIND11_MODULE(depth_filter_scan_converter_core, m)
{
  m.doc() = "ROS-free core of depth_filter_scan_converter";

  m.attr("RANGE_NOISE_CLUSTER_WIDTH") = dfsc::RangeNoiseParams::kClusterWidth;
  m.attr("RANGE_NOISE_CLUSTER_CAP") = dfsc::RangeNoiseParams::kClusterCap;

  // Local: every module of the toolbox registers the same C++ type, each as its own Python class.
  py::register_local_exception<dfsc::ParameterError>(m, "ParameterError", PyExc_ValueError);

  // Flat, under the ROS parameter names (as check_config and the YAML files spell them); the
  // C++ struct groups them by concern.
  py::class_<dfsc::Parameters> params(m, "Parameters");
  params.def(py::init<>());
  using P = dfsc::Parameters;
  laserscan_common::python::bindFields(params);
  m.def("parameter_table", &laserscan_common::python::table<P>, "The field table of Parameters (the export)");
  // laserscan_common has no Python module of its own: the block the converters and the merger
  // share is exported from here.
  m.def("self_filter_parameter_table", &laserscan_common::python::table<laserscan_common::SelfFilterParams>,
        "The field table of the self_filter block (the export)");
  m.def(
    "self_filter_shape_keys",
    [] {
      py::list out;
      out.append(py::dict(py::arg("type") = "*", py::arg("keys") = laserscan_common::shapeCommonKeys()));
      for (const auto& k : laserscan_common::shapeTypeKeys())
        out.append(py::dict(py::arg("type") = k.type, py::arg("keys") = k.sizes));
      return out;
    },
    "The keys of a listed shape (the export): type '*' the keys every type takes, then each type's sizes");
  params.def("validate", &P::validate, "Raises ParameterError (a ValueError) naming the bad parameter")
    .def("beam_count", [](const P& p) { return p.scan.beamCount(); })
    .def("no_return_value", [](const P& p) { return p.scan.noReturnValue(); })
    .def("too_close_value", [](const P& p) { return p.scan.tooCloseValue(); });

  py::class_<dfsc::Projector>(m, "Projector")
    .def(py::init<const dfsc::Parameters&>(), py::arg("params"))
    .def("set_parameters", &dfsc::Projector::setParameters)
    .def(
      "project",
      [](dfsc::Projector& self, const py::array& points, const Eigen::Matrix4d& camera_to_reference,
         int intensity_channel, bool keep_points) {
        const dfsc::CloudView v = viewOf(points, intensity_channel);
        std::vector<float> ranges, intensities, kept;
        self.project(v, isometryOf(camera_to_reference), ranges, &intensities, keep_points ? &kept : nullptr);
        py::array_t<float> kept_array = toArray(kept);
        kept_array.resize({ static_cast<py::ssize_t>(kept.size() / 3), static_cast<py::ssize_t>(3) });
        return std::make_tuple(toArray(ranges), toArray(intensities), kept_array);
      },
      py::arg("points"), py::arg("camera_to_reference"), py::arg("intensity_channel") = -1,
      py::arg("keep_points") = false, "Returns (ranges, intensities, kept_points (K, 3) in the reference frame)");

  m.def(
    "reference_project",
    [](const dfsc::Parameters& params, const py::array& points, const Eigen::Matrix4d& camera_to_reference,
       int intensity_channel) {
      const dfsc::CloudView v = viewOf(points, intensity_channel);
      std::vector<float> ranges, intensities;
      dfsc::referenceProject(params, v, isometryOf(camera_to_reference), ranges, &intensities);
      return std::make_tuple(toArray(ranges), toArray(intensities));
    },
    py::arg("params"), py::arg("points"), py::arg("camera_to_reference"), py::arg("intensity_channel") = -1);

  m.def(
    "validate_cloud",
    [](const std::vector<std::tuple<std::string, std::uint32_t, int, std::uint32_t>>& fields, std::uint32_t width,
       std::uint32_t height, std::uint32_t point_step, std::uint32_t row_step, bool is_bigendian,
       const py::bytes& data) {
      dfsc::CloudLayout layout;
      layout.width = width;
      layout.height = height;
      layout.point_step = point_step;
      layout.row_step = row_step;
      layout.is_bigendian = is_bigendian;
      for (const auto& f : fields)
        layout.fields.push_back(
          { std::get<0>(f), std::get<1>(f), static_cast<std::uint8_t>(std::get<2>(f)), std::get<3>(f) });
      const std::string bytes = data;
      dfsc::CloudView view;
      return dfsc::makeCloudView(layout, reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size(), "", view);
    },
    py::arg("fields"), py::arg("width"), py::arg("height"), py::arg("point_step"), py::arg("row_step"),
    py::arg("is_bigendian"), py::arg("data"),
    "Empty string when the layout is usable, else the reason it is not. fields: [(name, offset, datatype, count)]");

  m.def("fast_atan2", py::vectorize(&laserscan_common::fastAtan2), py::arg("y"), py::arg("x"));
  m.attr("FAST_ATAN2_MAX_ERROR") = laserscan_common::kFastAtan2MaxError;
}
