#include "laserscan_common/self_filter_parameters.hpp"

#include <algorithm>
#include <cmath>

#include <ros/package.h>
#include <tf2/exceptions.h>

#include "laserscan_common/message_checks.hpp"
#include "laserscan_common/parameter_error.hpp"
#include "laserscan_common/parameter_reader.hpp"
#include "laserscan_common/robot_shapes.hpp"

namespace laserscan_common
{
namespace
{
using XmlRpc::XmlRpcValue;

double number(XmlRpcValue& v, const std::string& name)
{
  double out = 0.0;
  fromXmlRpc(v, name, out);
  return out;
}

std::string text(XmlRpcValue& v, const std::string& name)
{
  std::string out;
  fromXmlRpc(v, name, out);
  return out;
}

std::vector<double> numbers(XmlRpcValue& v, const std::string& name, int count)
{
  if (v.getType() != XmlRpcValue::TypeArray || v.size() != count)
    throw ParameterError(name, "must be a list of " + std::to_string(count) + " numbers");
  std::vector<double> out;
  for (int i = 0; i < count; ++i)
    out.push_back(number(v[i], name));
  return out;
}

// {name, frame, type: box|cylinder|sphere, its sizes (shapeTypeKeys), origin: [x, y, z, roll,
//  pitch, yaw], padding}
RobotShape readShape(XmlRpcValue& v, const std::string& name, double default_padding)
{
  if (v.getType() != XmlRpcValue::TypeStruct)
    throw ParameterError(name, "must be a dictionary (frame, type, sizes, origin, padding)");
  std::vector<std::string> sizes;  // every type's, in the table's order
  for (const auto& type : shapeTypeKeys())
    for (const auto& key : type.sizes)
      if (std::find(sizes.begin(), sizes.end(), key) == sizes.end())
        sizes.push_back(key);
  for (auto it = v.begin(); it != v.end(); ++it)
    if (std::count(shapeCommonKeys().begin(), shapeCommonKeys().end(), it->first) == 0 &&
        std::count(sizes.begin(), sizes.end(), it->first) == 0)
      throw ParameterError(name + "/" + it->first, "unknown key");
  RobotShape s;
  s.name = v.hasMember("name") ? text(v["name"], name + "/name") : name;
  if (!v.hasMember("frame"))
    throw ParameterError(name + "/frame", "is required (the tf frame the shape moves with)");
  s.frame = text(v["frame"], name + "/frame");
  const std::string type = v.hasMember("type") ? text(v["type"], name + "/type") : "";
  const auto keys = std::find_if(shapeTypeKeys().begin(), shapeTypeKeys().end(),
                                 [&](const ShapeTypeKeys& k) { return type == k.type; });
  if (keys == shapeTypeKeys().end())
    throw ParameterError(name + "/type", "must be box, cylinder or sphere");
  // A type's sizes are required, the other types' refused (in the table's key order).
  for (const std::string& key : sizes)
  {
    const bool wanted = std::count(keys->sizes.begin(), keys->sizes.end(), key) > 0;
    if (v.hasMember(key) != wanted)
      throw ParameterError(name + "/" + key, std::string(wanted ? "is required" : "is not used") + " for a " + type);
  }
  if (type == "box")
  {
    s.kind = ShapeKind::kBox;
    const std::vector<double> d = numbers(v["size"], name + "/size", 3);
    s.half_extents = 0.5 * Eigen::Vector3d(d[0], d[1], d[2]);
  }
  else if (type == "cylinder")
  {
    s.kind = ShapeKind::kCylinder;
    const double r = number(v["radius"], name + "/radius");
    s.half_extents = Eigen::Vector3d(r, r, 0.5 * number(v["length"], name + "/length"));
  }
  else
  {
    s.kind = ShapeKind::kSphere;
    const double r = number(v["radius"], name + "/radius");
    s.half_extents = Eigen::Vector3d(r, r, r);
  }
  if (v.hasMember("origin"))
  {
    const std::vector<double> o = numbers(v["origin"], name + "/origin", 6);
    s.origin = Eigen::Translation3d(o[0], o[1], o[2]) * Eigen::AngleAxisd(o[5], Eigen::Vector3d::UnitZ()) *
               Eigen::AngleAxisd(o[4], Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(o[3], Eigen::Vector3d::UnitX());
  }
  s.padding = v.hasMember("padding") ? number(v["padding"], name + "/padding") : default_padding;
  s.validate(name);
  return s;
}

std::string resolveMesh(const std::string& uri)
{
  const std::string scheme = "package://";
  if (uri.compare(0, scheme.size(), scheme) != 0)
    return resolveFileUri(uri);
  const std::size_t slash = uri.find('/', scheme.size());
  if (slash == std::string::npos)
    return "";
  const std::string package = ros::package::getPath(uri.substr(scheme.size(), slash - scheme.size()));
  return package.empty() ? "" : package + uri.substr(slash);
}
}  // namespace

SelfFilterParams readSelfFilterParams(ParameterReader& reader, const std::string& key)
{
  SelfFilterParams p;
  XmlRpcValue block;
  if (!reader.readRaw(key, block))
    return p;
  if (block.getType() != XmlRpcValue::TypeStruct)
    throw ParameterError(key, "must be a dictionary (use_robot_description, links, padding, shapes)");
  const std::string prefix = key + "/";
  refuseUnknownKeys(block, prefix, p);
  // In the table's order: padding before shapes, whose default padding it is.
  visitFields(p, [&](auto& field, const ParamInfo& info) {
    if (!block.hasMember(info.name))
      return;
    if constexpr (std::is_same_v<std::decay_t<decltype(field)>, std::vector<RobotShape>>)
    {
      XmlRpcValue& shapes = block[info.name];
      if (shapes.getType() != XmlRpcValue::TypeArray)
        throw ParameterError(prefix + info.name, "must be a list of shapes");
      for (int i = 0; i < shapes.size(); ++i)
        field.push_back(readShape(shapes[i], prefix + info.name + "[" + std::to_string(i) + "]", p.padding));
    }
    else
      fromXmlRpc(block[info.name], prefix + info.name, field);
  });
  p.validate();
  return p;
}

SelfFilter makeSelfFilter(const SelfFilterParams& params, const ros::NodeHandle& nh, std::vector<std::string>& warnings)
{
  std::vector<RobotShape> shapes;
  if (params.use_robot_description)
  {
    std::string urdf;
    if (nh.hasParam("robot_description") && !nh.getParam("robot_description", urdf))
      throw ParameterError("robot_description", "must be a string (the robot's URDF)");
    shapes = shapesFromUrdf(urdf, params.links, params.padding, resolveMesh, warnings);
  }
  shapes.insert(shapes.end(), params.shapes.begin(), params.shapes.end());
  return SelfFilter(std::move(shapes), "self_filter");
}

void setFramePosesAt(const tf2::BufferCore& buffer, const std::string& target, const ros::Time& stamp,
                     SelfFilter& filter, double row_yaw)
{
  std::vector<Eigen::Isometry3d> poses;
  for (const std::string& frame : filter.frames())
  {
    const geometry_msgs::TransformStamped t = buffer.lookupTransform(target, frame, stamp);
    if (!transformIsFinite(t.transform))
      throw tf2::TransformException("self filter: the transform '" + frame + "' -> '" + target + "' is not finite");
    const auto& q = t.transform.rotation;
    const auto& p = t.transform.translation;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::Quaterniond(q.w, q.x, q.y, q.z).normalized().toRotationMatrix();
    pose.translation() = Eigen::Vector3d(p.x, p.y, p.z);
    poses.push_back(pose);
  }
  filter.setFramePoses(poses, row_yaw);
}

}  // namespace laserscan_common
