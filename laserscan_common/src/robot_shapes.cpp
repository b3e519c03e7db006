#include "laserscan_common/robot_shapes.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

#include <urdf_parser/urdf_parser.h>

#include "laserscan_common/parameter_error.hpp"

namespace laserscan_common
{
namespace
{
constexpr char kDescription[] = "robot_description";
constexpr char kLinks[] = "self_filter/links";

Eigen::Isometry3d toEigen(const urdf::Pose& pose)
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  t.linear() = Eigen::Quaterniond(pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z)
                 .normalized()
                 .toRotationMatrix();
  return t;
}

void extend(Eigen::Vector3d& lo, Eigen::Vector3d& hi, const Eigen::Vector3d& v)
{
  lo = lo.cwiseMin(v);
  hi = hi.cwiseMax(v);
}

// Binary STL: 80-byte header, uint32 count, then 50 bytes per triangle (normal, 3 vertices, 2).
bool binaryStlBounds(const std::string& bytes, Eigen::Vector3d& lo, Eigen::Vector3d& hi)
{
  if (bytes.size() < 84)
    return false;
  std::uint32_t count;
  std::memcpy(&count, bytes.data() + 80, sizeof count);
  if (count == 0 || bytes.size() != 84 + 50 * static_cast<std::size_t>(count))
    return false;
  for (std::size_t t = 0; t < count; ++t)
    for (int v = 0; v < 3; ++v)
    {
      float xyz[3];
      std::memcpy(xyz, bytes.data() + 84 + 50 * t + 12 + 12 * v, sizeof xyz);
      extend(lo, hi, Eigen::Vector3d(xyz[0], xyz[1], xyz[2]));
    }
  return true;
}

// ASCII STL ("vertex x y z" lines) and OBJ ("v x y z" lines): the vertices are all a box needs.
bool textBounds(const std::string& bytes, const char* keyword, Eigen::Vector3d& lo, Eigen::Vector3d& hi)
{
  std::istringstream in(bytes);
  std::string line;
  bool any = false;
  while (std::getline(in, line))
  {
    std::istringstream words(line);
    std::string first;
    double x, y, z;
    if (words >> first && first == keyword && words >> x >> y >> z)
    {
      extend(lo, hi, Eigen::Vector3d(x, y, z));
      any = true;
    }
  }
  return any;
}

std::string lower(std::string s)
{
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool endsWith(const std::string& s, const std::string& tail)
{
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}
}  // namespace

std::string resolveFileUri(const std::string& uri)
{
  const std::string scheme = "file://";
  if (uri.compare(0, scheme.size(), scheme) == 0)
    return uri.substr(scheme.size());
  return uri.find("://") == std::string::npos ? uri : std::string();
}

std::string meshBounds(const std::string& path, Eigen::Vector3d& lo, Eigen::Vector3d& hi)
{
  std::ifstream file(path, std::ios::binary);
  if (!file)
    return "cannot open '" + path + "'";
  const std::string bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  hi = -lo;
  const std::string name = lower(path);
  bool ok = false;
  if (endsWith(name, ".stl"))
    ok = binaryStlBounds(bytes, lo, hi) || textBounds(bytes, "vertex", lo, hi);
  else if (endsWith(name, ".obj"))
    ok = textBounds(bytes, "v", lo, hi);
  else
    return "'" + path + "' is neither STL nor OBJ";
  if (!ok || !lo.allFinite() || !hi.allFinite())
    return "'" + path + "' has no readable vertex";
  return {};
}

std::vector<RobotShape> shapesFromUrdf(const std::string& urdf_xml, const std::vector<std::string>& links,
                                       double padding, const MeshResolver& resolve, std::vector<std::string>& warnings)
{
  if (urdf_xml.find_first_not_of(" \t\r\n") == std::string::npos)
    throw ParameterError(kDescription, "is empty or not set (the self filter reads the robot's URDF from it)");
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(urdf_xml);
  if (!model)
    throw ParameterError(kDescription, "is not a valid URDF (urdfdom could not parse it)");

  std::vector<urdf::LinkConstSharedPtr> chosen;
  if (links.empty())
  {
    std::vector<urdf::LinkSharedPtr> all;
    model->getLinks(all);
    std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a->name < b->name; });
    for (const auto& link : all)
      if (!link->collision_array.empty())
        chosen.push_back(link);
  }
  else
    for (const std::string& name : links)
    {
      const urdf::LinkConstSharedPtr link = model->getLink(name);
      if (!link)
        throw ParameterError(kLinks, "link '" + name + "' is not in the robot description");
      if (link->collision_array.empty())
        throw ParameterError(kLinks, "link '" + name + "' has no collision element");
      chosen.push_back(link);
    }
  if (chosen.empty())
    throw ParameterError(kDescription, "has no link with a collision element: nothing to filter");

  std::vector<RobotShape> shapes;
  for (const auto& link : chosen)
    for (std::size_t c = 0; c < link->collision_array.size(); ++c)
    {
      const urdf::Collision& collision = *link->collision_array[c];
      if (!collision.geometry)
        continue;
      RobotShape shape;
      shape.name = link->collision_array.size() == 1 ? link->name : link->name + "#" + std::to_string(c);
      shape.frame = link->name;
      shape.origin = toEigen(collision.origin);
      shape.padding = padding;
      const urdf::Geometry& g = *collision.geometry;
      switch (g.type)
      {
        case urdf::Geometry::BOX:
        {
          const urdf::Vector3& d = static_cast<const urdf::Box&>(g).dim;
          shape.kind = ShapeKind::kBox;
          shape.half_extents = 0.5 * Eigen::Vector3d(d.x, d.y, d.z);
          break;
        }
        case urdf::Geometry::CYLINDER:
        {
          const auto& cyl = static_cast<const urdf::Cylinder&>(g);
          shape.kind = ShapeKind::kCylinder;
          shape.half_extents = Eigen::Vector3d(cyl.radius, cyl.radius, 0.5 * cyl.length);
          break;
        }
        case urdf::Geometry::SPHERE:
        {
          const double r = static_cast<const urdf::Sphere&>(g).radius;
          shape.kind = ShapeKind::kSphere;
          shape.half_extents = Eigen::Vector3d(r, r, r);
          break;
        }
        case urdf::Geometry::MESH:
        {
          const auto& mesh = static_cast<const urdf::Mesh&>(g);
          const Eigen::Vector3d scale(mesh.scale.x, mesh.scale.y, mesh.scale.z);
          shape.kind = ShapeKind::kBox;
          Eigen::Vector3d lo, hi;
          const std::string path = resolve ? resolve(mesh.filename) : resolveFileUri(mesh.filename);
          const std::string why = path.empty() ? "cannot resolve '" + mesh.filename + "'" : meshBounds(path, lo, hi);
          if (why.empty())
          {
            // The box of the scaled vertices (a negative scale mirrors; the box stays a box).
            const Eigen::Vector3d a = lo.cwiseProduct(scale), b = hi.cwiseProduct(scale);
            shape.half_extents = 0.5 * (a - b).cwiseAbs();
            shape.origin = shape.origin * Eigen::Translation3d(0.5 * (a + b));
          }
          else
          {
            shape.half_extents = 0.5 * scale.cwiseAbs();
            warnings.push_back("link '" + link->name + "': mesh " + why + "; using a box of its scale (" +
                               std::to_string(scale.x()) + " x " + std::to_string(scale.y()) + " x " +
                               std::to_string(scale.z()) + " m) instead");
          }
          break;
        }
      }
      shape.validate(std::string(kDescription) + ": link '" + link->name + "'");
      shapes.push_back(shape);
    }
  return shapes;
}

}  // namespace laserscan_common
