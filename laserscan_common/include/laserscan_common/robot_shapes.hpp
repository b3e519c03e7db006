// The robot's parts from its description: the collision elements of a URDF (box, cylinder,
// sphere; a mesh as the bounding box of its vertices) as self-filter shapes. ROS-free: the URDF
// comes as a string (the glue reads the robot_description parameter) and meshes through a
// resolver of their URIs (the glue resolves package://).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "laserscan_common/self_filter.hpp"

namespace laserscan_common
{

/// Maps a mesh URI of the URDF to a local file path; "" when it cannot. resolveFileUri handles
/// file:// and plain paths; the ROS glue adds package://.
using MeshResolver = std::function<std::string(const std::string& uri)>;
std::string resolveFileUri(const std::string& uri);

/// Bounding box of the vertices of a mesh file (binary or ASCII STL, Wavefront OBJ), in the
/// mesh's own units. Returns why not ("" when read) when the file is missing, unreadable, of
/// another format, or has no vertex.
std::string meshBounds(const std::string& path, Eigen::Vector3d& lo, Eigen::Vector3d& hi);

/// One shape per collision element of the links (every link that has one when `links` is
/// empty), each with `padding`. A mesh becomes the bounding box of its scaled vertices; a mesh
/// that cannot be read becomes a box of its scale's size centred on its origin, with a line in
/// `warnings` naming the link and the file. Throws ParameterError for an empty or malformed
/// description ("robot_description"), a listed link missing from it or without a collision
/// element ("self_filter/links"), or a shape that is unusable (zero size).
std::vector<RobotShape> shapesFromUrdf(const std::string& urdf_xml, const std::vector<std::string>& links,
                                       double padding, const MeshResolver& resolve, std::vector<std::string>& warnings);

}  // namespace laserscan_common
