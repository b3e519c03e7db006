#include "laserscan_common/self_filter.hpp"

#include <algorithm>
#include <stdexcept>

#include "laserscan_common/parameter_error.hpp"

namespace laserscan_common
{

const char* shapeKindName(ShapeKind kind)
{
  switch (kind)
  {
    case ShapeKind::kBox:
      return "box";
    case ShapeKind::kCylinder:
      return "cylinder";
    case ShapeKind::kSphere:
      return "sphere";
  }
  return "unknown";
}

void RobotShape::validate(const std::string& parameter) const
{
  if (frame.empty())
    throw ParameterError(parameter, "has no frame");
  if (frame.front() == '/')
    throw ParameterError(parameter,
                         "frame '" + frame + "' must not start with '/' (tf2 frame ids have no leading slash)");
  if (!half_extents.allFinite() || (half_extents.array() <= 0.0).any())
    throw ParameterError(parameter, std::string("the ") + shapeKindName(kind) + "'s sizes must be finite and > 0 (m)");
  if (!std::isfinite(padding) || padding < 0.0)
    throw ParameterError(parameter, "padding must be finite and >= 0 (m)");
  if (!origin.matrix().allFinite())
    throw ParameterError(parameter, "origin must be finite");
}

SelfFilter::SelfFilter(std::vector<RobotShape> shapes, const std::string& parameter) : shapes_(std::move(shapes))
{
  for (std::size_t i = 0; i < shapes_.size(); ++i)
  {
    shapes_[i].validate(parameter + "[" + std::to_string(i) + "] (" + shapes_[i].name + ")");
    const auto it = std::find(frames_.begin(), frames_.end(), shapes_[i].frame);
    frame_of_shape_.push_back(static_cast<std::size_t>(it - frames_.begin()));
    if (it == frames_.end())
      frames_.push_back(shapes_[i].frame);
  }
  posed_.resize(shapes_.size());
  // Lanes without a shape are NaN: every comparison with them is false.
  ShapeBoxLanes unused;
  std::fill(&unused.lo[0][0], &unused.lo[0][0] + 3 * lanes::kLanes, std::numeric_limits<float>::quiet_NaN());
  std::fill(&unused.hi[0][0], &unused.hi[0][0] + 3 * lanes::kLanes, std::numeric_limits<float>::quiet_NaN());
  box_lanes_.assign((shapes_.size() + lanes::kLanes - 1) / lanes::kLanes, unused);
}

void SelfFilter::setFramePoses(const std::vector<Eigen::Isometry3d>& reference_T_frame)
{
  if (reference_T_frame.size() != frames_.size())
    throw std::invalid_argument("SelfFilter::setFramePoses: " + std::to_string(reference_T_frame.size()) +
                                " poses for " + std::to_string(frames_.size()) + " frames");
  bounds_ = Bounds();
  for (std::size_t i = 0; i < shapes_.size(); ++i)
  {
    const RobotShape& shape = shapes_[i];
    const Eigen::Isometry3d reference_T_shape = reference_T_frame[frame_of_shape_[i]] * shape.origin;
    const Eigen::Isometry3d shape_T_reference = reference_T_shape.inverse(Eigen::Isometry);
    PosedShape& p = posed_[i];
    const Eigen::Vector3d h = shape.half_extents.array() + shape.padding;
    for (int row = 0; row < 3; ++row)
    {
      for (int col = 0; col < 3; ++col)
        p.r[row * 3 + col] = static_cast<float>(shape_T_reference.linear()(row, col));
      p.t[row] = static_cast<float>(shape_T_reference.translation()(row));
      p.h[row] = static_cast<float>(h(row));
    }
    const double radius = shape.half_extents.x() + shape.padding;
    p.radial_weight = shape.kind == ShapeKind::kBox ? 0.0f : 1.0f;
    p.axial_weight = shape.kind == ShapeKind::kSphere ? 1.0f : 0.0f;
    p.radius2 = shape.kind == ShapeKind::kBox ? 0.0f : static_cast<float>(radius * radius);
    // The box's extent along each reference axis: sum over the shape's axes of |R| * h. A
    // cylinder and a sphere lie inside their box of half extents h, so the same bound holds.
    const Eigen::Vector3d centre = reference_T_shape.translation();
    const Eigen::Vector3d extent = reference_T_shape.linear().cwiseAbs() * h;
    p.bounds.lo = (centre - extent).cast<float>();
    p.bounds.hi = (centre + extent).cast<float>();
    p.round = shape.kind != ShapeKind::kBox;
    // The culling box of the block test, a little larger than the shape's box: the exact test
    // runs in float with a rounded transform, so a point it finds inside may lie a rounding
    // error outside the box; with the margin, culling never drops a shape contains() would find.
    const Eigen::Vector3d margin = Eigen::Vector3d::Constant(1e-5) + 1e-5 * (centre.cwiseAbs() + extent);
    ShapeBoxLanes& boxes = box_lanes_[i / lanes::kLanes];
    for (int axis = 0; axis < 3; ++axis)
    {
      boxes.lo[axis][i % lanes::kLanes] = static_cast<float>(centre(axis) - extent(axis) - margin(axis));
      boxes.hi[axis][i % lanes::kLanes] = static_cast<float>(centre(axis) + extent(axis) + margin(axis));
    }
    bounds_.extend(p.bounds);
  }
}

void SelfFilterParams::validate() const
{
  checkLimits(*this, "self_filter/");
  if (!links.empty() && !use_robot_description)
    throw ParameterError("self_filter/links", "needs use_robot_description: true (the links are the description's)");
  for (std::size_t i = 0; i < shapes.size(); ++i)
    shapes[i].validate("self_filter/shapes[" + std::to_string(i) + "]");
}

}  // namespace laserscan_common
