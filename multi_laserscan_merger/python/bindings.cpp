// Python access to the ROS-free core (tests and tools): multi_laserscan_merger_core.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "laserscan_common/fast_math.hpp"
#include "laserscan_common/message_checks.hpp"
#include "laserscan_common/parameter_table_python.hpp"
#include "multi_laserscan_merger/merger_core.hpp"

namespace py = pybind11;
using namespace multi_laserscan_merger;

namespace
{
template <typename T>
void get(const py::dict& d, const char* key, T& value)
{
  if (d.contains(key))
    value = d[key].cast<T>();
}

OutputParams outputFromDict(const py::dict& d)
{
  return laserscan_common::python::fromDict<OutputParams>(d);
}

SourceParams sourceFromDict(const py::dict& d)
{
  return laserscan_common::python::fromDict<SourceParams>(d);
}

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

// Keeps the numpy arrays alive while the views point into them.
struct ScanHolder
{
  FloatArray ranges, intensities;
  SourceInput input;
};

void scanFromDict(const py::dict& d, ScanHolder& h)
{
  ScanView& v = h.input.scan;
  get(d, "stamp", v.stamp);
  get(d, "angle_min", v.angle_min);
  get(d, "angle_max", v.angle_max);
  get(d, "angle_increment", v.angle_increment);
  get(d, "time_increment", v.time_increment);
  get(d, "range_min", v.range_min);
  get(d, "range_max", v.range_max);
  h.ranges = d["ranges"].cast<FloatArray>();
  v.ranges = h.ranges.data();
  v.n_ranges = static_cast<std::size_t>(h.ranges.size());
  if (d.contains("intensities") && !d["intensities"].is_none())
  {
    h.intensities = d["intensities"].cast<FloatArray>();
    v.intensities = h.intensities.data();
    v.n_intensities = static_cast<std::size_t>(h.intensities.size());
  }
  if (d.contains("transform"))
    h.input.output_T_sensor.matrix() = d["transform"].cast<Eigen::Matrix4d>();
  h.input.present = true;
}

const char* statusName(SourceStatus s)
{
  switch (s)
  {
    case SourceStatus::kMissing:
      return "missing";
    case SourceStatus::kUsed:
      return "used";
    case SourceStatus::kTimedOut:
      return "timed_out";
    case SourceStatus::kInvalid:
      return "invalid";
  }
  return "?";
}

Eigen::Quaterniond quatFromXyzw(const Eigen::Vector4d& q)
{
  return Eigen::Quaterniond(q[3], q[0], q[1], q[2]);
}
}  // namespace

PYBIND11_MODULE(multi_laserscan_merger_core, m)
{
  m.doc() = "ROS-free core of multi_laserscan_merger (times in seconds, angles in radians, ranges in metres)";
  py::register_local_exception<ParameterError>(m, "ParameterError", PyExc_ValueError);
  // Defaults of the parameters the Merger constructor takes beside output and sources (s).
  m.attr("DEFAULT_SYNC_WINDOW") = MergerParams().sync_window;
  m.def("parameter_table", &laserscan_common::python::table<MergerParams>,
        "The field table of the merger's top level (the export; sources and self_filter apart)");
  m.def("source_parameter_table", &laserscan_common::python::table<SourceParams>,
        "The field table of one sources entry (the export)");

  m.def("fast_atan2", &laserscan_common::fastAtan2, py::arg("y"), py::arg("x"));
  m.def(
    "remap_resolution",
    [](const std::vector<float>& in, std::size_t n_new) {
      std::vector<float> out;
      remapResolution(in, n_new, out);
      return py::array_t<float>(out.size(), out.data());
    },
    py::arg("ranges"), py::arg("n_new"));
  m.def(
    "scan_fault",
    [](const py::dict& d) -> py::object {
      ScanHolder h;
      scanFromDict(d, h);
      const std::string f = scanFault(h.input.scan);
      return f.empty() ? py::object(py::none()) : py::object(py::str(f));
    },
    py::arg("scan"), "None when the scan is usable, else the fault");
  m.def(
    "stamp_fault",
    [](std::uint32_t sec, std::uint32_t nsec, std::int64_t now_ns, bool static_transform) -> py::object {
      const std::string f = laserscan_common::stampFault(
        sec, nsec, now_ns,
        static_transform ? laserscan_common::StampUse::kStaticTransform : laserscan_common::StampUse::kMeasurement);
      return f.empty() ? py::object(py::none()) : py::object(py::str(f));
    },
    py::arg("sec"), py::arg("nsec"), py::arg("now_ns"), py::arg("static_transform") = false,
    "None when the stamp is usable, else the fault");
  m.def("inside_polygon", &insidePolygon, py::arg("polygon"), py::arg("x"), py::arg("y"));
  m.def(
    "source_in_fov", [](const py::dict& source, double angle) { return sourceFromDict(source).inFieldOfView(angle); },
    py::arg("source"), py::arg("angle"));

  py::class_<OdometryBuffer>(m, "OdometryBuffer")
    .def(py::init<std::size_t, double>(), py::arg("capacity") = 100, py::arg("jump_back_threshold") = 1.0)
    .def(
      "add",
      [](OdometryBuffer& b, double t, const Eigen::Vector3d& p, const Eigen::Vector4d& q_xyzw) {
        switch (b.add(t, p, quatFromXyzw(q_xyzw)))
        {
          case OdometryBuffer::AddResult::kAdded:
            return "added";
          case OdometryBuffer::AddResult::kOutOfOrder:
            return "out_of_order";
          case OdometryBuffer::AddResult::kClearedBackwards:
            return "cleared_backwards";
          case OdometryBuffer::AddResult::kRejected:
            return "rejected";
        }
        return "?";
      },
      py::arg("t"), py::arg("position"), py::arg("orientation_xyzw"))
    .def(
      "pose_at",
      [](const OdometryBuffer& b, double t) -> py::object {
        Pose p;
        if (!b.poseAt(t, p))
          return py::none();
        const Eigen::Vector4d q(p.orientation.x(), p.orientation.y(), p.orientation.z(), p.orientation.w());
        return py::make_tuple(Eigen::Vector3d(p.position), q);
      },
      py::arg("t"), "(position, quaternion xyzw) or None when empty")
    .def(
      "motion", [](const OdometryBuffer& b, double t_from, double t_to) { return b.motion(t_from, t_to).matrix(); },
      py::arg("t_from"), py::arg("t_to"), "4x4 P(t_to)^-1 * P(t_from)")
    .def("clear", &OdometryBuffer::clear)
    .def("__len__", &OdometryBuffer::size);

  py::class_<MergerCore>(m, "Merger")
    .def(py::init([](const py::dict& output, const py::list& sources, int odom_queue_size, double publish_rate,
                     double sync_window) {
           MergerParams p;
           p.output = outputFromDict(output);
           p.odom_queue_size = odom_queue_size;
           p.publish_rate = publish_rate;
           p.sync_window = sync_window;
           for (const auto& s : sources)
             p.sources.push_back(sourceFromDict(s.cast<py::dict>()));
           return new MergerCore(p);
         }),
         py::arg("output"), py::arg("sources"), py::arg("odom_queue_size") = 100, py::arg("publish_rate") = 0.0,
         py::arg("sync_window") = MergerParams().sync_window)
    .def_property_readonly("beam_count", &MergerCore::beamCount)
    .def(
      "merge",
      [](MergerCore& core, const py::list& scans, double t_out, const OdometryBuffer* odom,
         const Eigen::Matrix4d& output_T_robot) {
        std::vector<ScanHolder> holders(scans.size());
        std::vector<SourceInput> inputs(scans.size());
        for (std::size_t i = 0; i < scans.size(); ++i)
        {
          if (scans[i].is_none())
            continue;
          scanFromDict(scans[i].cast<py::dict>(), holders[i]);
          inputs[i] = holders[i].input;
        }
        Eigen::Isometry3d o;
        o.matrix() = output_T_robot;
        MergedScan out;
        std::vector<SourceStatus> status;
        core.merge(inputs, t_out, odom, o, out, status);
        py::dict r;
        r["stamp"] = t_out;  // the output time it was merged at
        r["ranges"] = py::array_t<float>(out.ranges.size(), out.ranges.data());
        r["intensities"] = py::array_t<float>(out.intensities.size(), out.intensities.data());
        py::list st;
        for (auto s : status)
          st.append(statusName(s));
        r["status"] = st;
        return r;
      },
      py::arg("scans"), py::arg("t_out"), py::arg("odom") = nullptr,
      py::arg("output_T_robot") = Eigen::Matrix4d::Identity(),
      "scans: one dict (or None) per source: stamp, angle_min, angle_max, angle_increment, time_increment, "
      "range_min, range_max, ranges, [intensities], transform (4x4 output <- sensor)");
}
