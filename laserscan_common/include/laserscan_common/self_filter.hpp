// The self filter: the robot's own parts (arm links, a gripper, a carried load) as padded solids
// fixed to tf frames, and the test whether a point lies inside one of them. ROS-free (C++17 +
// Eigen); the shapes come from a URDF's collision elements (robot_shapes.hpp) and/or a node's
// YAML, their poses from tf, looked up by the ROS glue at each message's stamp.
// Shared by the depth converters (points inside are not projected) and the merger (returns
// inside are dropped). Lengths in metres.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "laserscan_common/parameter_table.hpp"

namespace laserscan_common
{

enum class ShapeKind : std::uint8_t
{
  kBox,       ///< half_extents: half sizes along the shape's x, y, z
  kCylinder,  ///< axis along the shape's z; half_extents = (radius, radius, half length)
  kSphere     ///< half_extents = (radius, radius, radius)
};

/// "box", "cylinder", "sphere".
const char* shapeKindName(ShapeKind kind);

/// One solid part of the robot, fixed to a tf frame.
struct RobotShape
{
  std::string name;   ///< for messages: the URDF link (and collision index) or "shapes[i]"
  std::string frame;  ///< tf frame the shape moves with
  ShapeKind kind = ShapeKind::kBox;
  Eigen::Vector3d half_extents = Eigen::Vector3d::Zero();    ///< m, see ShapeKind
  Eigen::Isometry3d origin = Eigen::Isometry3d::Identity();  ///< the shape's centre and axes in `frame`
  double padding = 0.0;  ///< m added to every half extent (and radius): the margin kept around the part

  /// Throws ParameterError naming `parameter` (e.g. "self_filter/shapes[1]") if unusable.
  void validate(const std::string& parameter) const;
};

/// An axis-aligned box (reference frame); empty when lo > hi.
struct Bounds
{
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = Eigen::Vector3f::Constant(-std::numeric_limits<float>::max());

  bool empty() const { return (lo.array() > hi.array()).any(); }
  bool contains(float x, float y, float z) const
  {
    return (x >= lo.x()) & (x <= hi.x()) & (y >= lo.y()) & (y <= hi.y()) & (z >= lo.z()) & (z <= hi.z());
  }
  void extend(const Bounds& other)
  {
    lo = lo.cwiseMin(other.lo);
    hi = hi.cwiseMax(other.hi);
  }
};

/// A float as an int32 that orders as the floats do (-0 taken as +0; not for NaN): min/max
/// reductions over these vectorize, float ones do not without -ffinite-math-only (which the
/// converters' NaN tests forbid).
__attribute__((always_inline)) inline std::int32_t orderedKey(float v)
{
  const float normalized = v + 0.0f;  // -0 -> +0: equal floats get equal keys
  std::int32_t bits;
  std::memcpy(&bits, &normalized, sizeof bits);
  return bits ^ ((bits >> 31) & 0x7fffffff);
}

/// One shape at its current pose, in the form the point test needs (float, reference -> shape).
/// Every kind is one formula: |q| <= h per axis and radial_weight * (qx^2 + qy^2) +
/// axial_weight * qz^2 <= radius2, where q is the point in the shape's frame; a box has both
/// weights 0, a cylinder radial 1, a sphere both 1. One branch-free loop then vectorizes.
struct PosedShape
{
  float r[9];  ///< rotation reference -> shape, row-major
  float t[3];  ///< translation reference -> shape
  float h[3];  ///< padded half extents
  float radius2, radial_weight, axial_weight;
  Bounds bounds;  ///< of the padded shape, in the reference frame
  /// bounds.lo and bounds.hi as orderedKey (x, y, z), for markBlock's integer box test.
  std::int32_t key_lo[3], key_hi[3];
};

/// The test of one point against one posed shape (the whole filter is the OR over shapes).
inline bool insidePosed(const PosedShape& s, float x, float y, float z)
{
  const float qx = s.r[0] * x + s.r[1] * y + s.r[2] * z + s.t[0];
  const float qy = s.r[3] * x + s.r[4] * y + s.r[5] * z + s.t[1];
  const float qz = s.r[6] * x + s.r[7] * y + s.r[8] * z + s.t[2];
  const float round = s.radial_weight * (qx * qx + qy * qy) + s.axial_weight * (qz * qz);
  return (std::abs(qx) <= s.h[0]) & (std::abs(qy) <= s.h[1]) & (std::abs(qz) <= s.h[2]) & (round <= s.radius2);
}

/// The shapes of one robot, their frames, and their poses for the message being filtered.
/// Not thread-safe: each user (converter, merger source) keeps its own copy and sets the poses
/// before each message.
class SelfFilter
{
public:
  SelfFilter() = default;
  /// Validates every shape (ParameterError naming `parameter`[i]).
  SelfFilter(std::vector<RobotShape> shapes, const std::string& parameter);

  bool empty() const { return shapes_.empty(); }
  const std::vector<RobotShape>& shapes() const { return shapes_; }
  /// The distinct frames of the shapes, in first-use order: one tf lookup each per message.
  const std::vector<std::string>& frames() const { return frames_; }

  /// Where each frame of frames() is: reference <- frame, same order (std::invalid_argument if the
  /// count differs). Computes the posed shapes and their bounding box.
  void setFramePoses(const std::vector<Eigen::Isometry3d>& reference_T_frame);

  /// The padded shapes' bounding box in the reference frame at the poses last set: a point
  /// outside it is outside every shape (the prefilter of the hot loops).
  const Bounds& bounds() const { return bounds_; }
  const std::vector<PosedShape>& posed() const { return posed_; }

  /// True when the point (reference frame) lies inside or on a padded shape at the poses last set.
  bool contains(float x, float y, float z) const
  {
    if (!bounds_.contains(x, y, z))
      return false;
    for (const PosedShape& s : posed_)
      if (insidePosed(s, x, y, z))
        return true;
    return false;
  }

  /// For n points (structure of arrays): inside[i] = 1 if point i is inside a padded shape,
  /// else left as it is; points with active[i] == 0 are not tested (active[i] is 0 or 1). Returns whether any point was
  /// inside. Inline, so that a caller's vectorized (target_clones) function inlines it with its
  /// own instruction set; per block of kMarkBlock points, a shape is tested only when its
  /// bounding box meets the box around the block's active points.
  inline bool markInside(std::size_t n, const float* xs, const float* ys, const float* zs, const std::int32_t* active,
                         std::int32_t* inside) const;

  /// Points per block of markInside.
  static constexpr std::size_t kMarkBlock = 32;

private:
  std::vector<RobotShape> shapes_;
  std::vector<std::string> frames_;
  std::vector<std::size_t> frame_of_shape_;
  std::vector<PosedShape> posed_;
  Bounds bounds_;
};

/// markInside on one block of m points (m = kMarkBlock known at compile time for full blocks:
/// the loops then have no remainder). The box around the block's active points (one vectorized
/// pass, integer min/max reductions) is compared with each shape's box in scalar code, and the
/// exact test runs only for the shapes whose box it meets: a per-shape test over the block's
/// points would cost a horizontal reduction and a branch per shape and block.
__attribute__((always_inline)) inline std::int32_t markBlock(const std::vector<PosedShape>& shapes, std::size_t m,
                                                             const float* bx, const float* by, const float* bz,
                                                             const std::int32_t* ba, std::int32_t* bi)
{
  constexpr std::int32_t kMax = std::numeric_limits<std::int32_t>::max();
  constexpr std::int32_t kMin = std::numeric_limits<std::int32_t>::min();
  std::int32_t lx = kMax, ly = kMax, lz = kMax, hx = kMin, hy = kMin, hz = kMin;
  for (std::size_t i = 0; i < m; ++i)
  {
    // Inactive points (maybe NaN) give keys that change neither minimum nor maximum.
    const std::int32_t on = -ba[i];  // all bits set when active
    const std::int32_t kx = orderedKey(bx[i]), ky = orderedKey(by[i]), kz = orderedKey(bz[i]);
    lx = std::min(lx, (kx & on) | (kMax & ~on));
    ly = std::min(ly, (ky & on) | (kMax & ~on));
    lz = std::min(lz, (kz & on) | (kMax & ~on));
    hx = std::max(hx, (kx & on) | (kMin & ~on));
    hy = std::max(hy, (ky & on) | (kMin & ~on));
    hz = std::max(hz, (kz & on) | (kMin & ~on));
  }
  if (lx > hx)
    return 0;  // no active point
  std::int32_t any = 0;
  for (const PosedShape& s : shapes)
  {
    if ((s.key_lo[0] > hx) | (s.key_hi[0] < lx) | (s.key_lo[1] > hy) | (s.key_hi[1] < ly) | (s.key_lo[2] > hz) |
        (s.key_hi[2] < lz))
      continue;
    // Locals, so that the compiler keeps them in registers across the vectorized loop.
    const float r0 = s.r[0], r1 = s.r[1], r2 = s.r[2], r3 = s.r[3], r4 = s.r[4], r5 = s.r[5];
    const float r6 = s.r[6], r7 = s.r[7], r8 = s.r[8], t0 = s.t[0], t1 = s.t[1], t2 = s.t[2];
    const float h0 = s.h[0], h1 = s.h[1], h2 = s.h[2];
    const float radius2 = s.radius2, wr = s.radial_weight, wa = s.axial_weight;
    for (std::size_t i = 0; i < m; ++i)
    {
      const float x = bx[i], y = by[i], z = bz[i];
      const float qx = r0 * x + r1 * y + r2 * z + t0;
      const float qy = r3 * x + r4 * y + r5 * z + t1;
      const float qz = r6 * x + r7 * y + r8 * z + t2;
      const float round = wr * (qx * qx + qy * qy) + wa * (qz * qz);
      const std::int32_t h =
        ba[i] & (std::abs(qx) <= h0) & (std::abs(qy) <= h1) & (std::abs(qz) <= h2) & (round <= radius2);
      bi[i] |= h;
      any |= h;
    }
  }
  return any;
}

__attribute__((always_inline)) inline bool SelfFilter::markInside(std::size_t n, const float* xs, const float* ys,
                                                                  const float* zs, const std::int32_t* active,
                                                                  std::int32_t* inside) const
{
  // Points come in runs that lie close together (a row of a depth image): per block of
  // kMarkBlock points, a shape is tested only when its bounding box meets the box around the
  // block's active points, so that a point near one link is tested against that link, not all
  // of them. Every loop is branch-free and vectorizes (integer reductions only).
  std::int32_t any = 0;
  std::size_t b0 = 0;
  for (; b0 + kMarkBlock <= n; b0 += kMarkBlock)
    any |= markBlock(posed_, kMarkBlock, xs + b0, ys + b0, zs + b0, active + b0, inside + b0);
  if (b0 < n)
    any |= markBlock(posed_, n - b0, xs + b0, ys + b0, zs + b0, active + b0, inside + b0);
  return any != 0;
}

/// The `self_filter` block of a node's private parameters (every key optional), as the
/// converters and the merger read it (self_filter_parameters.hpp).
struct SelfFilterParams
{
  bool use_robot_description = false;  ///< shapes from the URDF in the `robot_description` parameter
  std::vector<std::string> links;      ///< links of the description to take; empty: every link with a collision
  double padding = 0.02;  ///< m, margin around every shape of the description (and listed shapes without their own)
  std::vector<RobotShape> shapes;  ///< listed shapes (parts the description lacks, e.g. a carried load)

  bool enabled() const { return use_robot_description || !shapes.empty(); }
  /// Throws ParameterError ("self_filter/<key>").
  void validate() const;
};

/// The keys of one entry of the block's `shapes` list (a YAML dictionary): the reader refuses
/// any other, and check_config's schema is exported from here. `sizes`: what the type requires
/// (the other types' sizes it refuses); `size` is a list of 3 numbers, the others one number.
struct ShapeTypeKeys
{
  const char* type;
  std::vector<std::string> sizes;
};
inline const std::vector<ShapeTypeKeys>& shapeTypeKeys()
{
  static const std::vector<ShapeTypeKeys> keys{ { "box", { "size" } },
                                                { "cylinder", { "radius", "length" } },
                                                { "sphere", { "radius" } } };
  return keys;
}
/// The keys every type takes: `frame` and `type` required, the others optional.
inline const std::vector<std::string>& shapeCommonKeys()
{
  static const std::vector<std::string> keys{ "name", "frame", "type", "origin", "padding" };
  return keys;
}

inline const char* typeName(const std::vector<RobotShape>&)
{
  return "shape list";
}

/// The table of SelfFilterParams (parameter_table.hpp): the keys of the `self_filter` block.
/// `padding` comes before `shapes`: a listed shape without its own padding takes the block's.
template <class P, class V, std::enable_if_t<std::is_same_v<std::decay_t<P>, SelfFilterParams>, int> = 0>
void visitFields(P& p, V&& visit)
{
  visit(p.use_robot_description,
        ParamInfo("use_robot_description", "",
                  "take the collision elements of the URDF in the `robot_description` parameter (the node's "
                  "namespace); an empty, missing or unparsable description is an error at start-up"));
  visit(p.links, ParamInfo("links", "",
                           "the description's links to take (each must exist and have a collision element); empty: "
                           "every link that has one; needs `use_robot_description: true`"));
  visit(p.padding, ParamInfo("padding", "m",
                             "margin around every shape of the description, and of every listed shape without its own "
                             "`padding`; finite, >= 0")
                     .atLeast(0.0)
                     .finiteOnly());
  visit(p.shapes, ParamInfo("shapes", "",
                            "further shapes (a carried load, a part the URDF lacks): `{name, frame, type: "
                            "box\\|cylinder\\|sphere, size \\| radius [+ length], origin: [x, y, z, roll, pitch, yaw], "
                            "padding}`; `frame` and `type` required, `origin` (m, rad) in `frame`, default zero"));
}

}  // namespace laserscan_common
