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

/// Eight floats or ints in one value (GCC/Clang vector extensions): the self filter's block
/// test is written with them, so that it compiles to the instruction set of the function that
/// inlines it (AVX2 or AVX-512 in a target_clones kernel, SSE2 in the default clone) without
/// relying on the auto-vectorizer for min/max and horizontal reductions (float min/max
/// reductions do not auto-vectorize without -ffinite-math-only, which the converters' NaN tests
/// forbid; `a < b ? a : b` on these types is one minps, exact for the non-NaN values used here).
// Only inlined, never passed between translation units: the ABI note (-Wpsabi) on vector
// arguments and results does not apply.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"
namespace lanes
{
constexpr std::size_t kLanes = 8;
typedef float Floats __attribute__((vector_size(32)));
typedef std::int32_t Ints __attribute__((vector_size(32)));

__attribute__((always_inline)) inline void load(Floats& v, const float* p)
{
  std::memcpy(&v, p, sizeof v);
}
__attribute__((always_inline)) inline void load(Ints& v, const std::int32_t* p)
{
  std::memcpy(&v, p, sizeof v);
}
/// |q| <= h per lane, as std::abs(q) <= h (false for NaN).
__attribute__((always_inline)) inline void andAbsAtMost(Ints& mask, const Floats& q, float h)
{
  mask &= reinterpret_cast<Floats>(reinterpret_cast<Ints>(q) & 0x7fffffff) <= h;
}
/// The smallest and the largest lane.
__attribute__((always_inline)) inline float minLane(const Floats& x)
{
  Floats v = x, w = __builtin_shufflevector(v, v, 4, 5, 6, 7, 0, 1, 2, 3);
  v = v < w ? v : w;
  w = __builtin_shufflevector(v, v, 2, 3, 0, 1, 6, 7, 4, 5);
  v = v < w ? v : w;
  w = __builtin_shufflevector(v, v, 1, 0, 3, 2, 5, 4, 7, 6);
  v = v < w ? v : w;
  return v[0];
}
__attribute__((always_inline)) inline float maxLane(const Floats& x)
{
  Floats v = x, w = __builtin_shufflevector(v, v, 4, 5, 6, 7, 0, 1, 2, 3);
  v = v > w ? v : w;
  w = __builtin_shufflevector(v, v, 2, 3, 0, 1, 6, 7, 4, 5);
  v = v > w ? v : w;
  w = __builtin_shufflevector(v, v, 1, 0, 3, 2, 5, 4, 7, 6);
  v = v > w ? v : w;
  return v[0];
}
/// OR of the lanes.
__attribute__((always_inline)) inline std::int32_t orLanes(const Ints& x)
{
  Ints v = x;
  v |= __builtin_shufflevector(v, v, 4, 5, 6, 7, 0, 1, 2, 3);
  v |= __builtin_shufflevector(v, v, 2, 3, 0, 1, 6, 7, 4, 5);
  v |= __builtin_shufflevector(v, v, 1, 0, 3, 2, 5, 4, 7, 6);
  return v[0];
}
}  // namespace lanes

/// One shape at its current pose, in the form the point test needs (float, reference -> shape).
/// Every kind is one formula: |q| <= h per axis and radial_weight * (qx^2 + qy^2) +
/// axial_weight * qz^2 <= radius2, where q is the point in the shape's frame; a box has both
/// weights 0, a cylinder radial 1, a sphere both 1.
struct PosedShape
{
  float r[9];  ///< rotation reference -> shape, row-major
  float t[3];  ///< translation reference -> shape
  float h[3];  ///< padded half extents
  float radius2, radial_weight, axial_weight;
  bool round;     ///< a cylinder or a sphere (for a box the round term is 0 <= 0 whenever |q| <= h)
  Bounds bounds;  ///< of the padded shape, in the reference frame
  /// A box aligned with the block frame's axes (SelfFilter::setFramePoses) inside the padded
  /// shape, by more than the rounding of insidePosed: every point in it is inside (thin for a
  /// shape turned against those axes, empty only for one thinner than that margin).
  Bounds inner;
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

/// The shapes' boxes of up to lanes::kLanes shapes, one lane each (unused lanes NaN: they meet
/// no box), for the block test: one vector comparison tests a block's box against 8 shapes.
struct alignas(32) ShapeBoxLanes
{
  float lo[3][lanes::kLanes];  ///< culling box (the shape's box in the block frame, grown against rounding)
  float hi[3][lanes::kLanes];
  float inner_lo[3][lanes::kLanes];  ///< PosedShape::inner (NaN when empty)
  float inner_hi[3][lanes::kLanes];
};

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
  /// `row_yaw` (rad) turns the block frame of forEachInside about the reference z axis: the
  /// direction along which the points it is given lie in runs (a camera's image rows,
  /// imageRowYaw), so that the box around a block of a row is thin. Any value gives the same
  /// result; only the speed differs. Taken modulo 90 degrees (a box turned by a right angle is
  /// the same box).
  void setFramePoses(const std::vector<Eigen::Isometry3d>& reference_T_frame, double row_yaw = 0.0);

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

  /// For n points (structure of arrays): inside[i] = 1 if point i is active and inside a padded
  /// shape (insidePosed), else left as it is; points with active[i] == 0 are not tested. For
  /// active points inside bounds() this is contains(). Returns whether any point was inside.
  /// Inline, so that a caller's vectorized (target_clones) function inlines it with its own
  /// instruction set; per block of kMarkBlock points, a shape is tested only when its bounding
  /// box meets the box around the block's active points.
  inline bool markInside(std::size_t n, const float* xs, const float* ys, const float* zs, const std::int32_t* active,
                         std::int32_t* inside) const;

  /// The same test for active[i] 0 or -1 (all bits set: a vector comparison's mask, as the
  /// converters' kernels write it; an active point must be finite, as theirs are), handing the
  /// result to `hit(first, mask)` for the vectors of lanes::kLanes points (all within n) of each
  /// block that holds an inside point: lane j of mask is -1 when point first + j is active and
  /// inside, else 0; and to `hit_point(i)` for each inside point of the tail (the last
  /// n % kMarkBlock points, tested one by one).
  template <class Hit, class HitPoint>
  inline bool forEachInside(std::size_t n, const float* xs, const float* ys, const float* zs,
                            const std::int32_t* active, Hit&& hit, HitPoint&& hit_point) const;

  /// Points per block of markInside.
  static constexpr std::size_t kMarkBlock = 32;

private:
  template <bool kTurned, class Hit>
  inline std::int32_t markBlock(const float* bx, const float* by, const float* bz, const std::int32_t* ba,
                                std::size_t first, Hit& hit) const;

  std::vector<RobotShape> shapes_;
  std::vector<std::string> frames_;
  std::vector<std::size_t> frame_of_shape_;
  std::vector<PosedShape> posed_;
  std::vector<ShapeBoxLanes> box_lanes_;  ///< the shapes' culling boxes, 8 shapes per entry
  Bounds bounds_;
  /// The block frame's turn (row_yaw modulo 90 degrees); row_sin_ is 0 exactly when not turned.
  float row_cos_ = 1.0f, row_sin_ = 0.0f;
};

/// The yaw of a camera's image rows in a reference frame whose z axis is vertical, for
/// SelfFilter::setFramePoses: the direction of the more horizontal of the camera's x and y axes
/// (its x axis in an optical frame, y in a body frame; the same block frame modulo 90 degrees).
double imageRowYaw(const Eigen::Matrix3d& reference_R_camera);

/// One full block of kMarkBlock points: the box around its active points in the block frame
/// (kTurned: the reference frame turned by row_yaw; vector min/max over its 4 vectors, then
/// across lanes), compared with 8 shapes' boxes at once. A block whose box lies in a shape's
/// inner box is inside without a point test (the robot's points come in runs on its parts: most
/// blocks of an arm's points in a camera's view); otherwise the exact test
/// runs only for the shapes whose culling box it meets (a box without the round term). Inactive
/// points (maybe NaN) are left out of the box and never marked; active points must be finite.
template <bool kTurned, class Hit>
__attribute__((always_inline)) inline std::int32_t SelfFilter::markBlock(const float* bx, const float* by,
                                                                         const float* bz, const std::int32_t* ba,
                                                                         std::size_t first, Hit& hit) const
{
  using lanes::Floats;
  using lanes::Ints;
  constexpr std::size_t kL = lanes::kLanes;
  constexpr std::size_t kV = kMarkBlock / kL;
  Ints act[kV];
  Ints any_active = Ints{};
#pragma GCC unroll 4
  for (std::size_t v = 0; v < kV; ++v)
  {
    lanes::load(act[v], ba + v * kL);
    any_active |= act[v];
  }
  if (!lanes::orLanes(any_active))
    return 0;
  const float inf = std::numeric_limits<float>::infinity();
  Floats lx = Floats{} + inf, ly = lx, lz = lx, hx = -lx, hy = hx, hz = hx;
#pragma GCC unroll 4
  for (std::size_t v = 0; v < kV; ++v)
  {
    // Inactive points become NaN (all bits set), which `a < b ? a : b` (one minps) passes over:
    // one OR per coordinate instead of a select per bound.
    const Ints off = ~act[v];
    Ints xi, yi, zi;
    std::memcpy(&xi, bx + v * kL, sizeof xi), std::memcpy(&yi, by + v * kL, sizeof yi);
    std::memcpy(&zi, bz + v * kL, sizeof zi);
    Floats x = reinterpret_cast<Floats>(xi | off), y = reinterpret_cast<Floats>(yi | off),
           z = reinterpret_cast<Floats>(zi | off);
    if (kTurned)
    {
      // Into the block frame (NaN stays NaN).
      const Floats u = row_cos_ * x + row_sin_ * y;
      y = row_cos_ * y - row_sin_ * x;
      x = u;
    }
    lx = x < lx ? x : lx, ly = y < ly ? y : ly, lz = z < lz ? z : lz;
    hx = x > hx ? x : hx, hy = y > hy ? y : hy, hz = z > hz ? z : hz;
  }
  // The shape tests below load the points again rather than keep the 12 vectors of the box
  // pass live (they would be spilled to the stack and reloaded, at twice the instructions).
  __asm__ volatile("" ::: "memory");
  const float blx = lanes::minLane(lx), bly = lanes::minLane(ly), blz = lanes::minLane(lz);
  const float bhx = lanes::maxLane(hx), bhy = lanes::maxLane(hy), bhz = lanes::maxLane(hz);
  for (std::size_t g = 0; g < box_lanes_.size(); ++g)
  {
    const ShapeBoxLanes& b = box_lanes_[g];
    Floats lo0, lo1, lo2, hi0, hi1, hi2;
    lanes::load(lo0, b.inner_lo[0]), lanes::load(lo1, b.inner_lo[1]), lanes::load(lo2, b.inner_lo[2]);
    lanes::load(hi0, b.inner_hi[0]), lanes::load(hi1, b.inner_hi[1]), lanes::load(hi2, b.inner_hi[2]);
    const Ints within = (lo0 <= blx) & (hi0 >= bhx) & (lo1 <= bly) & (hi1 >= bhy) & (lo2 <= blz) & (hi2 >= bhz);
    if (lanes::orLanes(within))
    {
#pragma GCC unroll 4
      for (std::size_t v = 0; v < kV; ++v)
        hit(first + v * kL, act[v]);
      return 1;
    }
  }
  const Ints lane_bit = { 1, 2, 4, 8, 16, 32, 64, 128 };
  Ints inside[kV];
#pragma GCC unroll 4
  for (std::size_t v = 0; v < kV; ++v)
    inside[v] = Ints{};
  for (std::size_t g = 0; g < box_lanes_.size(); ++g)
  {
    const ShapeBoxLanes& b = box_lanes_[g];
    Floats lo0, lo1, lo2, hi0, hi1, hi2;
    lanes::load(lo0, b.lo[0]), lanes::load(lo1, b.lo[1]), lanes::load(lo2, b.lo[2]);
    lanes::load(hi0, b.hi[0]), lanes::load(hi1, b.hi[1]), lanes::load(hi2, b.hi[2]);
    const Ints meets = (lo0 <= bhx) & (hi0 >= blx) & (lo1 <= bhy) & (hi1 >= bly) & (lo2 <= bhz) & (hi2 >= blz);
    for (std::uint32_t bits = static_cast<std::uint32_t>(lanes::orLanes(meets & lane_bit)); bits != 0; bits &= bits - 1)
    {
      const PosedShape& s = posed_[g * kL + static_cast<std::size_t>(__builtin_ctz(bits))];
      const float r0 = s.r[0], r1 = s.r[1], r2 = s.r[2], r3 = s.r[3], r4 = s.r[4], r5 = s.r[5];
      const float r6 = s.r[6], r7 = s.r[7], r8 = s.r[8], t0 = s.t[0], t1 = s.t[1], t2 = s.t[2];
      const float h0 = s.h[0], h1 = s.h[1], h2 = s.h[2];
      if (!s.round)
      {
#pragma GCC unroll 4
        for (std::size_t v = 0; v < kV; ++v)
        {
          Floats x, y, z;
          lanes::load(x, bx + v * kL), lanes::load(y, by + v * kL), lanes::load(z, bz + v * kL);
          const Floats qx = r0 * x + r1 * y + r2 * z + t0;
          const Floats qy = r3 * x + r4 * y + r5 * z + t1;
          const Floats qz = r6 * x + r7 * y + r8 * z + t2;
          Ints in = act[v];
          lanes::andAbsAtMost(in, qx, h0), lanes::andAbsAtMost(in, qy, h1), lanes::andAbsAtMost(in, qz, h2);
          inside[v] |= in;
        }
      }
      else
      {
        const float radius2 = s.radius2, wr = s.radial_weight, wa = s.axial_weight;
#pragma GCC unroll 4
        for (std::size_t v = 0; v < kV; ++v)
        {
          Floats x, y, z;
          lanes::load(x, bx + v * kL), lanes::load(y, by + v * kL), lanes::load(z, bz + v * kL);
          const Floats qx = r0 * x + r1 * y + r2 * z + t0;
          const Floats qy = r3 * x + r4 * y + r5 * z + t1;
          const Floats qz = r6 * x + r7 * y + r8 * z + t2;
          const Floats round = wr * (qx * qx + qy * qy) + wa * (qz * qz);
          Ints in = act[v] & (round <= radius2);
          lanes::andAbsAtMost(in, qx, h0), lanes::andAbsAtMost(in, qy, h1), lanes::andAbsAtMost(in, qz, h2);
          inside[v] |= in;
        }
      }
    }
  }
  Ints any_inside = Ints{};
#pragma GCC unroll 4
  for (std::size_t v = 0; v < kV; ++v)
    any_inside |= inside[v];
  if (!lanes::orLanes(any_inside))
    return 0;
#pragma GCC unroll 4
  for (std::size_t v = 0; v < kV; ++v)
    hit(first + v * kL, inside[v]);
  return 1;
}

template <class Hit, class HitPoint>
__attribute__((always_inline)) inline bool SelfFilter::forEachInside(std::size_t n, const float* xs, const float* ys,
                                                                     const float* zs, const std::int32_t* active,
                                                                     Hit&& hit, HitPoint&& hit_point) const
{
  // Points come in runs that lie close together (a row of a depth image): per block of
  // kMarkBlock points, a shape is tested only when its box meets the box around the block's
  // active points, so that a point near one link is tested against that link, not all of them.
  std::int32_t any = 0;
  const std::size_t full = n - n % kMarkBlock;
  if (row_sin_ != 0.0f)
    for (std::size_t b0 = 0; b0 < full; b0 += kMarkBlock)
      any |= markBlock<true>(xs + b0, ys + b0, zs + b0, active + b0, b0, hit);
  else
    for (std::size_t b0 = 0; b0 < full; b0 += kMarkBlock)
      any |= markBlock<false>(xs + b0, ys + b0, zs + b0, active + b0, b0, hit);
  // The tail (fewer than kMarkBlock points): one point at a time, the same test.
  for (std::size_t i = full; i < n; ++i)
  {
    if (active[i] == 0)
      continue;
    for (const PosedShape& s : posed_)
    {
      if (insidePosed(s, xs[i], ys[i], zs[i]))
      {
        hit_point(i);
        any = 1;
        break;
      }
    }
  }
  return any != 0;
}

__attribute__((always_inline)) inline bool SelfFilter::markInside(std::size_t n, const float* xs, const float* ys,
                                                                  const float* zs, const std::int32_t* active,
                                                                  std::int32_t* inside) const
{
  // active 0/1 -> 0/-1 (a non-finite point, inside no shape, inactive), one block at a time.
  bool any = false;
  for (std::size_t b0 = 0; b0 < n; b0 += kMarkBlock)
  {
    const std::size_t m = std::min(kMarkBlock, n - b0);
    std::int32_t mask[kMarkBlock];
    for (std::size_t i = 0; i < m; ++i)
    {
      const std::size_t k = b0 + i;
      mask[i] = active[k] != 0 && std::isfinite(xs[k]) && std::isfinite(ys[k]) && std::isfinite(zs[k]) ? -1 : 0;
    }
    any |= forEachInside(
      m, xs + b0, ys + b0, zs + b0, mask,
      [&](std::size_t first, const lanes::Ints& in) {
        for (std::size_t j = 0; j < lanes::kLanes; ++j)
          inside[b0 + first + j] |= in[j] & 1;
      },
      [&](std::size_t i) { inside[b0 + i] = 1; });
  }
  return any;
}

#pragma GCC diagnostic pop

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
