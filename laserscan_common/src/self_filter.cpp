#include "laserscan_common/self_filter.hpp"

#include <algorithm>
#include <cmath>
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
  std::fill(&unused.inner_lo[0][0], &unused.inner_lo[0][0] + 3 * lanes::kLanes,
            std::numeric_limits<float>::quiet_NaN());
  std::fill(&unused.inner_hi[0][0], &unused.inner_hi[0][0] + 3 * lanes::kLanes,
            std::numeric_limits<float>::quiet_NaN());
  box_lanes_.assign((shapes_.size() + lanes::kLanes - 1) / lanes::kLanes, unused);
}

double imageRowYaw(const Eigen::Matrix3d& reference_R_camera)
{
  const Eigen::Vector3d x = reference_R_camera.col(0), y = reference_R_camera.col(1);
  const Eigen::Vector3d& row = x.head<2>().squaredNorm() >= y.head<2>().squaredNorm() ? x : y;
  return std::atan2(row.y(), row.x());
}

void SelfFilter::setFramePoses(const std::vector<Eigen::Isometry3d>& reference_T_frame, double row_yaw)
{
  if (reference_T_frame.size() != frames_.size())
    throw std::invalid_argument("SelfFilter::setFramePoses: " + std::to_string(reference_T_frame.size()) +
                                " poses for " + std::to_string(frames_.size()) + " frames");
  // The block frame, turned by row_yaw modulo 90 degrees into [-45, 45]; not turned within a
  // micro-radian of the axes (the turn costs four vector operations per block).
  const double quarter = kPi / 2.0;
  double yaw = std::isfinite(row_yaw) ? row_yaw - quarter * std::round(row_yaw / quarter) : 0.0;
  yaw = std::abs(yaw) > 1e-6 ? yaw : 0.0;
  row_cos_ = static_cast<float>(std::cos(yaw));
  row_sin_ = static_cast<float>(std::sin(yaw));
  // reference <- block, from the float cosine and sine markBlock uses, so that the boxes below
  // are in the frame the points are turned into.
  Eigen::Matrix3d reference_R_block;
  reference_R_block << row_cos_, -row_sin_, 0.0, row_sin_, row_cos_, 0.0, 0.0, 0.0, 1.0;
  const Eigen::Matrix3d block_R_reference = reference_R_block.transpose();
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
    const Eigen::Vector3d reference_extent = reference_T_shape.linear().cwiseAbs() * h;
    p.bounds.lo = (reference_T_shape.translation() - reference_extent).cast<float>();
    p.bounds.hi = (reference_T_shape.translation() + reference_extent).cast<float>();
    p.round = shape.kind != ShapeKind::kBox;
    // The block test's boxes, in the block frame (the reference frame when not turned).
    const Eigen::Matrix3d block_R_shape = block_R_reference * reference_T_shape.linear();
    const Eigen::Vector3d centre = block_R_reference * reference_T_shape.translation();
    const Eigen::Vector3d extent = block_R_shape.cwiseAbs() * h;
    // The culling box of the block test, a little larger than the shape's box: the exact test
    // runs in float with a rounded transform, so a point it finds inside may lie a rounding
    // error outside the box; with the margin, culling never drops a shape contains() would find.
    const Eigen::Vector3d margin = Eigen::Vector3d::Constant(1e-5) + 1e-5 * (centre.cwiseAbs() + extent);
    // The inner box: a box b of the shape's frame inside the padded solid shrunk by twice that
    // margin (for a cylinder or sphere the box inscribed in it), then a box a aligned with the
    // reference axes inside it, i.e. with its extent in the shape's frame |R|^T a <= b: b's
    // bounding box |R| b scaled down until it fits, then grown along each axis while it fits.
    // Turned by right angles it is the shrunk box itself; turned about one axis, a box thinner
    // across that axis only.
    const double shrink = 2.0 * margin.maxCoeff();
    Eigen::Vector3d b = h.array() - shrink;
    if (shape.kind == ShapeKind::kCylinder)
      b.x() = b.y() = (radius - shrink) / std::sqrt(2.0);
    else if (shape.kind == ShapeKind::kSphere)
      b.setConstant((radius - shrink) / std::sqrt(3.0));
    p.inner = Bounds();
    if ((b.array() > 0.0).all())
    {
      const Eigen::Matrix3d abs_r = block_R_shape.cwiseAbs();
      const Eigen::Vector3d inner_extent = abs_r * b;
      Eigen::Vector3d a = inner_extent * (b.array() / (abs_r.transpose() * inner_extent).array()).minCoeff();
      for (int axis = 0; axis < 3; ++axis)
      {
        const Eigen::Vector3d slack = b - abs_r.transpose() * a;
        double grow = std::numeric_limits<double>::infinity();
        for (int k = 0; k < 3; ++k)
          if (abs_r(axis, k) > 0.0)
            grow = std::min(grow, std::max(0.0, slack(k)) / abs_r(axis, k));
        a(axis) += grow;
      }
      p.inner.lo = (centre - a).cast<float>();
      p.inner.hi = (centre + a).cast<float>();
    }
    const bool inner = !p.inner.empty();
    const float nan = std::numeric_limits<float>::quiet_NaN();
    ShapeBoxLanes& boxes = box_lanes_[i / lanes::kLanes];
    for (int axis = 0; axis < 3; ++axis)
    {
      boxes.lo[axis][i % lanes::kLanes] = static_cast<float>(centre(axis) - extent(axis) - margin(axis));
      boxes.hi[axis][i % lanes::kLanes] = static_cast<float>(centre(axis) + extent(axis) + margin(axis));
      boxes.inner_lo[axis][i % lanes::kLanes] = inner ? p.inner.lo(axis) : nan;
      boxes.inner_hi[axis][i % lanes::kLanes] = inner ? p.inner.hi(axis) : nan;
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
