// The self filter's core: every shape kind against analytic points (inside, outside, on the
// padded border, in rotated and moved frames), the bounding-box prefilter, the chunk test the
// converters' hot loop uses, and the shapes read from URDF strings (box, cylinder, sphere,
// meshes from STL/OBJ files, errors for missing or unusable descriptions).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "laserscan_common/parameter_error.hpp"
#include "laserscan_common/robot_shapes.hpp"
#include "laserscan_common/self_filter.hpp"
#include "laserscan_common/scan_geometry.hpp"

namespace lc = laserscan_common;
using Eigen::Isometry3d;
using Eigen::Vector3d;

namespace
{
using laserscan_common::kPi;
// Border tests: a millimetre inside / outside the padded surface (the test runs in float).
constexpr double kEps = 1e-3;

lc::RobotShape shape(lc::ShapeKind kind, const Vector3d& half, double padding, const std::string& frame = "link")
{
  lc::RobotShape s;
  s.name = "test";
  s.frame = frame;
  s.kind = kind;
  s.half_extents = half;
  s.padding = padding;
  return s;
}

lc::SelfFilter posed(const lc::RobotShape& s, const Isometry3d& reference_T_frame)
{
  lc::SelfFilter f({ s }, "shapes");
  f.setFramePoses({ reference_T_frame });
  return f;
}

bool has(const lc::SelfFilter& f, const Vector3d& p)
{
  return f.contains(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
}

Isometry3d pose(const Vector3d& t, double roll, double pitch, double yaw)
{
  Isometry3d m = Isometry3d::Identity();
  m.translation() = t;
  m.linear() = (Eigen::AngleAxisd(yaw, Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Vector3d::UnitX()))
                 .toRotationMatrix();
  return m;
}
// markInside() on the points against the brute-force point test of every posed shape, point by
// point (inactive points are never marked); counts the points inside and those outside every
// shape but within the shapes' bounding box (the sample must exercise both answers).
void expectMarksEqualTheBruteForceTest(const lc::SelfFilter& f, const std::vector<float>& xs,
                                       const std::vector<float>& ys, const std::vector<float>& zs,
                                       const std::vector<std::int32_t>& active, int trial, std::size_t& inside_total,
                                       std::size_t& outside_near_total)
{
  const std::size_t n = xs.size();
  std::vector<std::int32_t> inside(n, 0);
  f.markInside(n, xs.data(), ys.data(), zs.data(), active.data(), inside.data());
  for (std::size_t i = 0; i < n; ++i)
  {
    bool want = false;
    for (const lc::PosedShape& s : f.posed())
      want = want || lc::insidePosed(s, xs[i], ys[i], zs[i]);
    outside_near_total += !want && f.bounds().contains(xs[i], ys[i], zs[i]) ? 1 : 0;
    want = want && active[i] != 0;
    inside_total += want ? 1 : 0;
    ASSERT_EQ(inside[i] != 0, want) << "trial " << trial << ", point " << i << " of " << n << ": " << xs[i] << " "
                                    << ys[i] << " " << zs[i];
  }
}

}  // namespace

TEST(SelfFilterShapes, BoxInsideOutsideAndOnThePaddedBorder)
{
  // A 0.4 x 0.2 x 0.1 box, padding 0.05: padded half extents 0.25, 0.15, 0.1.
  const auto f = posed(shape(lc::ShapeKind::kBox, { 0.2, 0.1, 0.05 }, 0.05), Isometry3d::Identity());
  EXPECT_TRUE(has(f, { 0, 0, 0 }));
  EXPECT_TRUE(has(f, { 0.22, 0.0, 0.0 }));  // in the padding only
  for (int axis = 0; axis < 3; ++axis)
  {
    const double h[3] = { 0.25, 0.15, 0.1 };
    for (double sign : { -1.0, 1.0 })
    {
      Vector3d in = Vector3d::Zero(), out = Vector3d::Zero();
      in(axis) = sign * (h[axis] - kEps);
      out(axis) = sign * (h[axis] + kEps);
      EXPECT_TRUE(has(f, in)) << "axis " << axis << " sign " << sign;
      EXPECT_FALSE(has(f, out)) << "axis " << axis << " sign " << sign;
    }
  }
  // A corner of the padded box is inside (padding enlarges the box, it does not round it).
  EXPECT_TRUE(has(f, { 0.25 - kEps, 0.15 - kEps, 0.1 - kEps }));
  EXPECT_FALSE(has(f, { 0.25 + kEps, 0.15 - kEps, 0.1 - kEps }));
}

TEST(SelfFilterShapes, BoxInARotatedMovedFrameWithARotatedOrigin)
{
  // Frame at (1, 2, 0.5) turned 90 degrees about z; the box's origin within it is 0.3 along the
  // frame's x and turned 90 degrees about x (its y along the frame's z).
  lc::RobotShape s = shape(lc::ShapeKind::kBox, { 0.2, 0.1, 0.05 }, 0.0);
  s.origin = pose({ 0.3, 0, 0 }, kPi / 2, 0, 0);
  const auto f = posed(s, pose({ 1, 2, 0.5 }, 0, 0, kPi / 2));
  // Centre: the frame's x is the reference's y.
  const Vector3d c(1.0, 2.3, 0.5);
  EXPECT_TRUE(has(f, c));
  // The box's x (half 0.2) lies along reference y, its y (half 0.1) along reference z, its z
  // (half 0.05) along reference -x.
  EXPECT_TRUE(has(f, c + Vector3d(0, 0.2 - kEps, 0)));
  EXPECT_FALSE(has(f, c + Vector3d(0, 0.2 + kEps, 0)));
  EXPECT_TRUE(has(f, c + Vector3d(0, 0, 0.1 - kEps)));
  EXPECT_FALSE(has(f, c + Vector3d(0, 0, 0.1 + kEps)));
  EXPECT_TRUE(has(f, c + Vector3d(0.05 - kEps, 0, 0)));
  EXPECT_FALSE(has(f, c + Vector3d(0.05 + kEps, 0, 0)));
  // Unrotated, (0.15, 0, 0) from the centre would be inside; here it is not.
  EXPECT_FALSE(has(f, c + Vector3d(0.15, 0, 0)));
  // The bounding box is exact for a box turned by right angles.
  EXPECT_NEAR(f.bounds().lo.x(), 1.0 - 0.05, 1e-6);
  EXPECT_NEAR(f.bounds().hi.y(), 2.3 + 0.2, 1e-6);
  EXPECT_NEAR(f.bounds().hi.z(), 0.5 + 0.1, 1e-6);
}

TEST(SelfFilterShapes, CylinderRadiusAndLengthWithPadding)
{
  // Radius 0.05, length 0.4, padding 0.02; axis along the frame's x (pitch 90 degrees).
  lc::RobotShape s = shape(lc::ShapeKind::kCylinder, { 0.05, 0.05, 0.2 }, 0.02);
  s.origin = pose({ 0, 0, 0 }, 0, kPi / 2, 0);
  const auto f = posed(s, pose({ 0.5, 0, 1.0 }, 0, 0, 0));
  const Vector3d c(0.5, 0, 1.0);
  EXPECT_TRUE(has(f, c + Vector3d(0.22 - kEps, 0, 0)));  // along the axis
  EXPECT_FALSE(has(f, c + Vector3d(0.22 + kEps, 0, 0)));
  EXPECT_TRUE(has(f, c + Vector3d(0, 0.07 - kEps, 0)));  // radially
  EXPECT_FALSE(has(f, c + Vector3d(0, 0.07 + kEps, 0)));
  const double d = 0.07 / std::sqrt(2.0);  // radially, at 45 degrees
  EXPECT_TRUE(has(f, c + Vector3d(0.1, d - kEps, d - kEps)));
  EXPECT_FALSE(has(f, c + Vector3d(0.1, d + kEps, d + kEps)));  // inside its bounding box, outside the round
}

TEST(SelfFilterShapes, SphereRadiusWithPadding)
{
  const auto f = posed(shape(lc::ShapeKind::kSphere, { 0.1, 0.1, 0.1 }, 0.03), pose({ 0, 0, 1 }, 0.3, 0.2, 0.1));
  const Vector3d dir = Vector3d(1, -2, 0.5).normalized();
  EXPECT_TRUE(has(f, Vector3d(0, 0, 1) + (0.13 - kEps) * dir));
  EXPECT_FALSE(has(f, Vector3d(0, 0, 1) + (0.13 + kEps) * dir));
  EXPECT_FALSE(has(f, { 0.12, 0.12, 1.0 }));  // a corner of its bounding box
}

TEST(SelfFilterShapes, PosesFollowTheFrameAndFramesAreSharedByShapes)
{
  lc::SelfFilter f({ shape(lc::ShapeKind::kSphere, { 0.1, 0.1, 0.1 }, 0.0, "arm"),
                     shape(lc::ShapeKind::kBox, { 0.1, 0.1, 0.1 }, 0.0, "base"),
                     shape(lc::ShapeKind::kSphere, { 0.05, 0.05, 0.05 }, 0.0, "arm") },
                   "shapes");
  ASSERT_EQ(f.frames(), (std::vector<std::string>{ "arm", "base" }));
  f.setFramePoses({ pose({ 1, 0, 0 }, 0, 0, 0), Isometry3d::Identity() });
  EXPECT_TRUE(has(f, { 1.0, 0, 0 }));
  EXPECT_FALSE(has(f, { 0.0, 1.0, 0 }));
  f.setFramePoses({ pose({ 0, 1, 0 }, 0, 0, 0), Isometry3d::Identity() });  // the arm moved
  EXPECT_FALSE(has(f, { 1.0, 0, 0 }));
  EXPECT_TRUE(has(f, { 0.0, 1.0, 0 }));
  EXPECT_TRUE(has(f, { 0.0, 0.0, 0 }));  // the base stayed
  EXPECT_THROW(f.setFramePoses({ Isometry3d::Identity() }), std::invalid_argument);
}

TEST(SelfFilterShapes, ChunkTestAgreesWithThePointTestAndSkipsInactivePoints)
{
  // Six links of an arm at arbitrary poses; random points around them.
  std::vector<lc::RobotShape> shapes;
  for (int i = 0; i < 6; ++i)
  {
    auto kind = static_cast<lc::ShapeKind>(i % 3);
    shapes.push_back(shape(kind, { 0.05 + 0.01 * i, 0.06, 0.15 }, 0.02, "link" + std::to_string(i)));
  }
  lc::SelfFilter f(shapes, "shapes");
  std::vector<Isometry3d> poses;
  for (int i = 0; i < 6; ++i)
    poses.push_back(pose({ 0.4 + 0.1 * i, 0.05 * i, 0.5 + 0.1 * i }, 0.3 * i, 0.5 - 0.2 * i, 0.7 * i));
  f.setFramePoses(poses);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-0.2f, 1.4f);
  const std::size_t n = 4096;
  std::vector<float> xs(n), ys(n), zs(n);
  std::vector<std::int32_t> active(n), inside(n, 0);
  std::size_t expected_inside = 0;
  for (std::size_t i = 0; i < n; ++i)
  {
    xs[i] = u(rng), ys[i] = u(rng) * 0.5f, zs[i] = u(rng);
    active[i] = i % 5 != 0;
  }
  EXPECT_TRUE(f.markInside(n, xs.data(), ys.data(), zs.data(), active.data(), inside.data()));
  for (std::size_t i = 0; i < n; ++i)
  {
    const bool want = active[i] && f.contains(xs[i], ys[i], zs[i]);
    expected_inside += want ? 1 : 0;
    EXPECT_EQ(inside[i] != 0, want) << i;
    if (f.contains(xs[i], ys[i], zs[i]))
    {
      EXPECT_TRUE(f.bounds().contains(xs[i], ys[i], zs[i]));
    }
  }
  EXPECT_GT(expected_inside, 20u);  // the sample does hit the shapes
  EXPECT_LT(expected_inside, n / 2);
}

TEST(SelfFilterShapes, ChunkTestHoldsOnBothSidesOfZeroAndBesideNaNPoints)
{
  // markBlock compares the box of a block's active points (float min/max) with the shapes' boxes:
  // negative coordinates, -0 on a shape's bound at 0 and NaN (inactive) neighbours must not
  // make it skip a shape. Runs of points along x, as in a row of a depth image.
  lc::SelfFilter f({ shape(lc::ShapeKind::kBox, { 0.1, 0.1, 0.1 }, 0.0, "at_zero"),
                     shape(lc::ShapeKind::kBox, { 0.1, 0.2, 0.2 }, 0.0, "negative"),
                     shape(lc::ShapeKind::kSphere, { 0.15, 0.15, 0.15 }, 0.0, "ball") },
                   "shapes");
  // "at_zero" spans x in [0, 0.2] exactly: its lower bound is 0.
  f.setFramePoses(
    { pose({ 0.1, 0.0, 0.0 }, 0, 0, 0), pose({ -0.6, -0.1, -0.1 }, 0, 0, 0.2), pose({ -0.3, 0.05, 0.0 }, 0, 0, 0) });
  const std::size_t block = lc::SelfFilter::kMarkBlock;
  std::vector<float> xs, ys, zs;
  std::vector<std::int32_t> active;
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> start(-1.0f, 0.4f), lateral(-0.12f, 0.12f);
  for (int run = 0; run < 200; ++run)
  {
    const float x0 = start(rng), y = lateral(rng), z = lateral(rng);
    for (std::size_t i = 0; i < block; ++i)
    {
      const bool nan = i % 7 == 3;
      xs.push_back(nan ? std::numeric_limits<float>::quiet_NaN() : x0 + 0.004f * static_cast<float>(i));
      ys.push_back(y), zs.push_back(z);
      active.push_back(nan ? 0 : 1);
    }
  }
  // A block whose one active point is -0, on "at_zero"'s lower bound (inside it).
  for (std::size_t i = 0; i < block; ++i)
  {
    xs.push_back(i == 5 ? -0.0f : 5.0f), ys.push_back(0.0f), zs.push_back(0.0f);
    active.push_back(i == 5 ? 1 : 0);
  }
  ASSERT_TRUE(f.contains(-0.0f, 0.0f, 0.0f));
  const std::size_t n = xs.size();
  std::vector<std::int32_t> inside(n, 0);
  f.markInside(n, xs.data(), ys.data(), zs.data(), active.data(), inside.data());
  std::size_t expected_inside = 0, negative_inside = 0;
  for (std::size_t i = 0; i < n; ++i)
  {
    const bool want = active[i] && f.contains(xs[i], ys[i], zs[i]);
    expected_inside += want ? 1 : 0;
    negative_inside += want && xs[i] < -0.2f ? 1 : 0;
    EXPECT_EQ(inside[i] != 0, want) << i << ": " << xs[i] << " " << ys[i] << " " << zs[i];
  }
  EXPECT_NE(inside[n - block + 5], 0);
  EXPECT_GT(negative_inside, 100u);  // the runs do reach the shapes on the negative side
  EXPECT_LT(expected_inside, n / 2);
}

TEST(SelfFilterShapes, BlockTestEqualsTheBruteForcePointTestOnRandomCloudsAndShapes)
{
  // Differential test of the block culling (the box of a block's active points against 8
  // shapes' boxes at once, the exact test only for the shapes it meets): random robots of 1 to
  // 19 shapes (more than one group of 8) of every kind at random poses, in a block frame turned
  // by a random yaw every other trial, random point counts
  // (blocks and a tail), points in runs along random lines (as rows of a depth image: blocks
  // then meet few shapes) and scattered ones, random inactive points, some NaN. Every point must
  // come out as the brute-force test says: active and inside one of the shapes.
  std::mt19937 rng(2026);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::size_t inside_total = 0, outside_near_total = 0;
  for (int trial = 0; trial < 60; ++trial)
  {
    const int count = 1 + static_cast<int>(unit(rng) * 19);
    std::vector<lc::RobotShape> shapes;
    std::vector<Isometry3d> poses;
    for (int i = 0; i < count; ++i)
    {
      const auto kind = static_cast<lc::ShapeKind>(static_cast<int>(unit(rng) * 3) % 3);
      const double a = 0.02 + 0.2 * unit(rng), c = 0.02 + 0.3 * unit(rng);
      const Vector3d half = kind == lc::ShapeKind::kBox      ? Vector3d(a, 0.02 + 0.2 * unit(rng), c)
                            : kind == lc::ShapeKind::kSphere ? Vector3d(a, a, a)
                                                             : Vector3d(a, a, c);
      shapes.push_back(shape(kind, half, 0.03 * unit(rng), "link" + std::to_string(i)));
      poses.push_back(pose({ 2.0 * unit(rng) - 0.5, 2.0 * unit(rng) - 1.0, 1.5 * unit(rng) - 0.3 }, 6.0 * unit(rng),
                           6.0 * unit(rng), 6.0 * unit(rng)));
    }
    lc::SelfFilter f(shapes, "shapes");
    // Every other trial with the block frame turned (a camera's rows at a random yaw).
    f.setFramePoses(poses, trial % 2 ? 8.0 * unit(rng) - 4.0 : 0.0);
    const std::size_t n = 200 + static_cast<std::size_t>(unit(rng) * 3000);
    std::vector<float> xs(n), ys(n), zs(n);
    std::vector<std::int32_t> active(n);
    Vector3d p(0, 0, 0), step(0, 0, 0);
    for (std::size_t i = 0; i < n; ++i)
    {
      if (i % 97 == 0)
      {
        // A new run: from a random point (near a random shape half of the time) along a line.
        const std::size_t s = static_cast<std::size_t>(unit(rng) * count) % static_cast<std::size_t>(count);
        p = unit(rng) < 0.5 ? poses[s].translation() + Vector3d(0.3 * unit(rng) - 0.15, -0.3, 0.2 * unit(rng) - 0.1)
                            : Vector3d(2.5 * unit(rng) - 0.8, 2.5 * unit(rng) - 1.3, 2.0 * unit(rng) - 0.5);
        step = Vector3d(0.004 * unit(rng) - 0.002, 0.006, 0.004 * unit(rng) - 0.002);
      }
      p += step;
      const bool scattered = unit(rng) < 0.1;
      const Vector3d q = scattered ? Vector3d(2.5 * unit(rng) - 0.8, 2.5 * unit(rng) - 1.3, 2.0 * unit(rng) - 0.5) : p;
      const bool nan = unit(rng) < 0.03;
      xs[i] = nan ? std::numeric_limits<float>::quiet_NaN() : static_cast<float>(q.x());
      ys[i] = static_cast<float>(q.y()), zs[i] = static_cast<float>(q.z());
      active[i] = !nan && unit(rng) < 0.9 ? 1 : 0;
    }
    expectMarksEqualTheBruteForceTest(f, xs, ys, zs, active, trial, inside_total, outside_near_total);
    if (::testing::Test::HasFatalFailure())
      return;
  }
  // The sample does exercise both answers near the shapes.
  EXPECT_GT(inside_total, 5000u);
  EXPECT_GT(outside_near_total, 5000u);
}

TEST(SelfFilterShapes, InnerBoxLiesInsideItsShapeAndIsTightAlongTheAxes)
{
  // The inner box (a block inside it is inside without a point test) must lie inside the padded
  // shape for the float point test: its corners and random points in it, for every kind at
  // random poses. Along the axes it is the padded box itself (less a few micrometres); a sphere's
  // is the cube inscribed in it; a box turned by 45 degrees about z still has one.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::size_t non_empty = 0;
  for (int trial = 0; trial < 300; ++trial)
  {
    const auto kind = static_cast<lc::ShapeKind>(trial % 3);
    const double a = 0.01 + 0.3 * unit(rng);
    const Vector3d half = kind == lc::ShapeKind::kBox      ? Vector3d(a, 0.01 + 0.3 * unit(rng), 0.01 + 0.3 * unit(rng))
                          : kind == lc::ShapeKind::kSphere ? Vector3d(a, a, a)
                                                           : Vector3d(a, a, 0.01 + 0.3 * unit(rng));
    // A third along the axes (turned by right angles), the others at random angles, far from
    // the origin too (rounding grows with the coordinates).
    const double turn = trial % 9 < 3 ? kPi / 2 * static_cast<int>(unit(rng) * 4) : 6.0 * unit(rng);
    const Vector3d at = Vector3d(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5) * (trial % 2 ? 2.0 : 60.0);
    const auto f = posed(shape(kind, half, 0.02 * unit(rng), "link"),
                         pose(at, trial % 9 < 3 ? 0.0 : turn, trial % 9 < 3 ? kPi : 0.5 * turn, turn));
    const lc::Bounds& inner = f.posed()[0].inner;
    if (inner.empty())
      continue;
    ++non_empty;
    for (int k = 0; k < 208; ++k)
    {
      // The 8 corners, then random points.
      Eigen::Vector3f q;
      for (int axis = 0; axis < 3; ++axis)
        q(axis) = k < 8 ? ((k >> axis) & 1 ? inner.hi(axis) : inner.lo(axis))
                        : inner.lo(axis) + static_cast<float>(unit(rng)) * (inner.hi(axis) - inner.lo(axis));
      ASSERT_TRUE(f.contains(q.x(), q.y(), q.z()))
        << "trial " << trial << ", " << lc::shapeKindName(kind) << ": inner point " << q.transpose() << " outside";
    }
  }
  EXPECT_GT(non_empty, 250u);

  const auto box = posed(shape(lc::ShapeKind::kBox, { 0.2, 0.1, 0.3 }, 0.05), pose({ 1, 2, 0.5 }, 0, 0, kPi / 2));
  EXPECT_NEAR(box.posed()[0].inner.lo.x(), 1.0 - 0.15, 1e-4);  // x of the box turned by 90 degrees: its y
  EXPECT_NEAR(box.posed()[0].inner.hi.y(), 2.0 + 0.25, 1e-4);
  EXPECT_NEAR(box.posed()[0].inner.hi.z(), 0.5 + 0.35, 1e-4);
  const auto sphere = posed(shape(lc::ShapeKind::kSphere, { 0.3, 0.3, 0.3 }, 0.0), Isometry3d::Identity());
  EXPECT_NEAR(sphere.posed()[0].inner.hi.x(), 0.3 / std::sqrt(3.0), 1e-4);
  const auto turned = posed(shape(lc::ShapeKind::kBox, { 0.1, 0.1, 0.1 }, 0.0), pose({ 0, 0, 0 }, 0, 0, kPi / 4));
  EXPECT_FALSE(turned.posed()[0].inner.empty());
  EXPECT_NEAR(turned.posed()[0].inner.hi.x(), 0.1 / std::sqrt(2.0), 1e-4);  // the square inscribed in the turned one
  EXPECT_NEAR(turned.posed()[0].inner.hi.z(), 0.1, 1e-4);
}

TEST(SelfFilterShapes, BlocksInsideAShapeEqualTheBruteForcePointTest)
{
  // Differential test of the block test's shortcut (a block whose active points' box lies in a
  // shape's inner box is inside without a point test) and of the exact test beside it: robots
  // of 1 to 10 shapes turned by right angles (their inner box is the padded shape) or slightly
  // or strongly tilted, every other trial all turned by a random yaw with the block frame
  // (a camera at that yaw: setFramePoses's row_yaw), runs of points inside them, along their
  // faces, across their padded surface a few micrometres apart and beside them, some inactive.
  // Every point must come out as the brute-force test says, and many blocks must lie in an
  // inner box, in either block frame.
  std::mt19937 rng(2121);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const std::size_t block = lc::SelfFilter::kMarkBlock;
  std::size_t blocks_within = 0, blocks_within_turned = 0, inside_total = 0, outside_near_total = 0;
  for (int trial = 0; trial < 80; ++trial)
  {
    const double row_yaw = trial % 2 ? 2.0 * kPi * unit(rng) : 0.0;
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(row_yaw, Vector3d::UnitZ()).toRotationMatrix();
    // The block frame: turned by row_yaw modulo 90 degrees, so `turn` up to a right angle.
    const Eigen::Matrix3d block_R_reference =
      Eigen::AngleAxisd(-(row_yaw - kPi / 2 * std::round(row_yaw / (kPi / 2))), Vector3d::UnitZ()).toRotationMatrix();
    const int count = 1 + static_cast<int>(unit(rng) * 10);
    std::vector<lc::RobotShape> shapes;
    std::vector<Isometry3d> poses, turned_poses;
    for (int i = 0; i < count; ++i)
    {
      const auto kind = static_cast<lc::ShapeKind>(static_cast<int>(unit(rng) * 3) % 3);
      const double a = 0.03 + 0.15 * unit(rng);
      const Vector3d half = kind == lc::ShapeKind::kBox ? Vector3d(a, 0.03 + 0.15 * unit(rng), 0.03 + 0.2 * unit(rng))
                            : kind == lc::ShapeKind::kSphere ? Vector3d(a, a, a)
                                                             : Vector3d(a, a, 0.03 + 0.2 * unit(rng));
      shapes.push_back(shape(kind, half, 0.03 * unit(rng), "link" + std::to_string(i)));
      const double tilt = unit(rng) < 0.6 ? 0.0 : unit(rng) < 0.5 ? 1e-4 * unit(rng) : 0.5 * unit(rng);
      poses.push_back(pose({ 0.4 + 1.2 * unit(rng), 1.2 * unit(rng) - 0.6, 1.0 * unit(rng) },
                           kPi / 2 * static_cast<int>(unit(rng) * 4) + tilt, kPi / 2 * static_cast<int>(unit(rng) * 4),
                           kPi / 2 * static_cast<int>(unit(rng) * 4) - tilt));
      turned_poses.push_back(Isometry3d(turn) * poses.back());
    }
    // The runs are made around the robot as it stands in `unturned` (f's block frame up to a
    // right angle); f sees them turned.
    lc::SelfFilter unturned(shapes, "shapes"), f(shapes, "shapes");
    unturned.setFramePoses(poses);
    f.setFramePoses(turned_poses, row_yaw);
    const std::size_t n =
      block * (20 + static_cast<std::size_t>(unit(rng) * 60)) + static_cast<std::size_t>(unit(rng) * 40);
    std::vector<float> xs(n), ys(n), zs(n);
    std::vector<std::int32_t> active(n);
    for (std::size_t b0 = 0; b0 < n; b0 += block)
    {
      // One run per block, in or along a random shape's padded box (its bounds): from a random
      // point inside it, or from a face, a corner or a point just across it, with steps from
      // micrometres to centimetres.
      const lc::PosedShape& s =
        unturned.posed()[static_cast<std::size_t>(unit(rng) * count) % static_cast<std::size_t>(count)];
      const Eigen::Vector3d lo = s.bounds.lo.cast<double>(), hi = s.bounds.hi.cast<double>();
      Vector3d p = lo + (hi - lo).cwiseProduct(Vector3d(unit(rng), unit(rng), unit(rng)));
      const double where = unit(rng);
      const int axis = static_cast<int>(unit(rng) * 3) % 3;
      if (where < 0.3)
        p(axis) = (unit(rng) < 0.5 ? lo(axis) : hi(axis)) + (unit(rng) - 0.5) * 2e-5;  // across a face
      const double size = where < 0.6 ? 1e-3 : 0.02;
      const Vector3d step = size * Vector3d(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5);
      lc::Bounds box;  // of the block's active points, in the block frame
      for (std::size_t i = b0; i < std::min(n, b0 + block); ++i, p += step)
      {
        const Eigen::Vector3f q = (turn * p).cast<float>();
        xs[i] = q.x(), ys[i] = q.y(), zs[i] = q.z();
        active[i] = unit(rng) < 0.95 ? 1 : 0;
        const Eigen::Vector3f b = (block_R_reference * q.cast<double>()).cast<float>();
        if (active[i])
          box.extend({ b, b });
      }
      // Count the blocks the shortcut takes: active points' box in a shape's inner box.
      for (const lc::PosedShape& t : f.posed())
        if (b0 + block <= n && !box.empty() && !t.inner.empty() && (box.lo.array() >= t.inner.lo.array()).all() &&
            (box.hi.array() <= t.inner.hi.array()).all())
        {
          ++blocks_within;
          blocks_within_turned += row_yaw != 0.0 ? 1 : 0;
          break;
        }
    }
    expectMarksEqualTheBruteForceTest(f, xs, ys, zs, active, trial, inside_total, outside_near_total);
    if (::testing::Test::HasFatalFailure())
      return;
  }
  EXPECT_GT(blocks_within, 500u);
  EXPECT_GT(blocks_within_turned, 250u);
  EXPECT_GT(inside_total, 40000u);
  EXPECT_GT(outside_near_total, 5000u);
}

TEST(SelfFilterShapes, ImageRowYawIsTheDirectionOfACamerasRows)
{
  // An optical frame (x right, y down, z forward) and a body frame (x forward, y left), yawed by
  // 30 degrees and pitched down: their rows run along the same horizontal direction (modulo 90
  // degrees, which is the same block frame).
  const double yaw = 30.0 * kPi / 180.0, pitch = 20.0 * kPi / 180.0;
  const Eigen::Matrix3d body =
    (Eigen::AngleAxisd(yaw, Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Vector3d::UnitY())).toRotationMatrix();
  Eigen::Matrix3d optical_to_body;
  optical_to_body << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  const auto modQuarter = [](double a) { return a - kPi / 2 * std::round(a / (kPi / 2)); };
  EXPECT_NEAR(modQuarter(lc::imageRowYaw(body * optical_to_body)), modQuarter(yaw), 1e-9);
  EXPECT_NEAR(modQuarter(lc::imageRowYaw(body)), modQuarter(yaw), 1e-9);
  // A camera looking straight down: its rows are still horizontal.
  const Eigen::Matrix3d down = Eigen::AngleAxisd(yaw, Vector3d::UnitZ()).toRotationMatrix() *
                               Eigen::AngleAxisd(kPi / 2, Vector3d::UnitY()).toRotationMatrix();
  EXPECT_NEAR(modQuarter(lc::imageRowYaw(down)), modQuarter(yaw), 1e-9);
}

TEST(SelfFilterShapes, BadShapesNameThemselves)
{
  auto error_of = [](const lc::RobotShape& s) {
    try
    {
      lc::SelfFilter f({ s }, "self_filter/shapes");
    }
    catch (const lc::ParameterError& e)
    {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error_of(shape(lc::ShapeKind::kBox, { 0.1, 0.0, 0.1 }, 0.0)).find("self_filter/shapes[0]"),
            std::string::npos);
  EXPECT_NE(error_of(shape(lc::ShapeKind::kBox, { 0.1, 0.1, 0.1 }, -0.01)).find("padding"), std::string::npos);
  EXPECT_NE(error_of(shape(lc::ShapeKind::kSphere, { 0.1, 0.1, 0.1 }, 0.0, "")).find("frame"), std::string::npos);
  EXPECT_NE(error_of(shape(lc::ShapeKind::kSphere, { 0.1, 0.1, 0.1 }, 0.0, "/arm")).find("leading slash"),
            std::string::npos);
  EXPECT_EQ(error_of(shape(lc::ShapeKind::kSphere, { 0.1, 0.1, 0.1 }, 0.0)), "");
}

// ---- URDF ----

namespace
{
std::string robot(const std::string& links)
{
  return "<?xml version=\"1.0\"?><robot name=\"r\">" + links + "</robot>";
}

std::string urdfLink(const std::string& name, const std::string& geometry, const std::string& origin = "")
{
  return "<link name=\"" + name + "\"><collision>" + origin + "<geometry>" + geometry +
         "</geometry></collision></link>";
}

std::string joint(const std::string& parent, const std::string& child)
{
  return "<joint name=\"" + child + "_joint\" type=\"fixed\"><parent link=\"" + parent + "\"/><child link=\"" + child +
         "\"/></joint>";
}

std::string parameterOf(const std::function<void()>& f)
{
  try
  {
    f();
  }
  catch (const lc::ParameterError& e)
  {
    return e.parameter() + ": " + e.reason();
  }
  return "";
}

std::string tempPath(const std::string& name)
{
  return ::testing::TempDir() + "/self_filter_test_" + name;
}

void writeBinaryStl(const std::string& path, const std::vector<Eigen::Vector3f>& vertices)
{
  std::ofstream out(path, std::ios::binary);
  const std::string header(80, ' ');
  out.write(header.data(), 80);
  const std::uint32_t count = static_cast<std::uint32_t>(vertices.size() / 3);
  out.write(reinterpret_cast<const char*>(&count), 4);
  for (std::size_t t = 0; t < count; ++t)
  {
    const float normal[3] = { 0, 0, 1 };
    out.write(reinterpret_cast<const char*>(normal), 12);
    for (int v = 0; v < 3; ++v)
      out.write(reinterpret_cast<const char*>(vertices[3 * t + v].data()), 12);
    const std::uint16_t attributes = 0;
    out.write(reinterpret_cast<const char*>(&attributes), 2);
  }
}
}  // namespace

TEST(SelfFilterUrdf, BoxCylinderSphereWithOriginsAndPadding)
{
  const std::string urdf = robot(urdfLink("base_link", "<box size=\"0.6 0.4 0.2\"/>", "<origin xyz=\"0 0 0.1\"/>") +
                                 joint("base_link", "upper_arm") +
                                 urdfLink("upper_arm", "<cylinder radius=\"0.05\" length=\"0.4\"/>",
                                          "<origin xyz=\"0.2 0 0\" rpy=\"0 1.5707963 0\"/>") +
                                 joint("upper_arm", "wrist") + urdfLink("wrist", "<sphere radius=\"0.04\"/>") +
                                 joint("wrist", "no_collision") + "<link name=\"no_collision\"/>");
  std::vector<std::string> warnings;
  const auto shapes = lc::shapesFromUrdf(urdf, {}, 0.01, lc::resolveFileUri, warnings);
  EXPECT_TRUE(warnings.empty());
  ASSERT_EQ(shapes.size(), 3u);  // sorted by link name; the link without collision is left out
  EXPECT_EQ(shapes[0].frame, "base_link");
  EXPECT_EQ(shapes[0].kind, lc::ShapeKind::kBox);
  EXPECT_TRUE(shapes[0].half_extents.isApprox(Vector3d(0.3, 0.2, 0.1)));
  EXPECT_NEAR(shapes[0].origin.translation().z(), 0.1, 1e-12);
  EXPECT_EQ(shapes[1].frame, "upper_arm");
  EXPECT_EQ(shapes[1].kind, lc::ShapeKind::kCylinder);
  EXPECT_TRUE(shapes[1].half_extents.isApprox(Vector3d(0.05, 0.05, 0.2)));
  EXPECT_EQ(shapes[2].kind, lc::ShapeKind::kSphere);
  EXPECT_DOUBLE_EQ(shapes[2].padding, 0.01);

  // The cylinder lies along the link's x (pitch 90 degrees), from 0 to 0.4 m, padded by 0.01.
  lc::SelfFilter f({ shapes[1] }, "self_filter");
  f.setFramePoses({ Isometry3d::Identity() });
  EXPECT_TRUE(has(f, { 0.41 - kEps, 0, 0 }));
  EXPECT_FALSE(has(f, { 0.41 + kEps, 0, 0 }));
  EXPECT_TRUE(has(f, { 0.2, 0, 0.06 - kEps }));
  EXPECT_FALSE(has(f, { 0.2, 0, 0.06 + kEps }));

  // Only the listed links.
  const auto some = lc::shapesFromUrdf(urdf, { "wrist" }, 0.0, lc::resolveFileUri, warnings);
  ASSERT_EQ(some.size(), 1u);
  EXPECT_EQ(some[0].frame, "wrist");
}

TEST(SelfFilterUrdf, MeshesBecomeTheBoxOfTheirScaledVertices)
{
  // A binary STL spanning x 0..0.2, y -0.05..0.05, z 0..0.1, scale 2 along x.
  const std::string stl = tempPath("part.stl");
  writeBinaryStl(stl, { { 0, -0.05f, 0 }, { 0.2f, 0.05f, 0 }, { 0.1f, 0, 0.1f } });
  // An ASCII STL and an OBJ of the same extent.
  const std::string ascii = tempPath("part_ascii.stl");
  std::ofstream(ascii) << "solid p\nfacet normal 0 0 1\nouter loop\nvertex 0 -0.05 0\nvertex 0.2 0.05 0\n"
                          "vertex 0.1 0 0.1\nendloop\nendfacet\nendsolid p\n";
  const std::string obj = tempPath("part.obj");
  std::ofstream(obj) << "# part\nv 0 -0.05 0\nv 0.2 0.05 0\nv 0.1 0 0.1\nf 1 2 3\n";
  for (const std::string& uri : { "file://" + stl, ascii, obj })
  {
    std::vector<std::string> warnings;
    const auto shapes = lc::shapesFromUrdf(robot(urdfLink("tool", "<mesh filename=\"" + uri + "\" scale=\"2 1 1\"/>")),
                                           {}, 0.0, lc::resolveFileUri, warnings);
    ASSERT_EQ(shapes.size(), 1u) << uri;
    EXPECT_TRUE(warnings.empty()) << uri;
    EXPECT_EQ(shapes[0].kind, lc::ShapeKind::kBox);
    EXPECT_TRUE(shapes[0].half_extents.isApprox(Vector3d(0.2, 0.05, 0.05), 1e-6)) << uri;
    EXPECT_TRUE(shapes[0].origin.translation().isApprox(Vector3d(0.2, 0, 0.05), 1e-6)) << uri;
  }
}

TEST(SelfFilterUrdf, AnUnreadableMeshIsABoxOfItsScaleWithAWarning)
{
  std::vector<std::string> warnings;
  const auto shapes = lc::shapesFromUrdf(
    robot(urdfLink("gripper", "<mesh filename=\"package://nowhere/meshes/gripper.dae\" scale=\"0.1 0.2 0.3\"/>")), {},
    0.0, lc::resolveFileUri, warnings);
  ASSERT_EQ(shapes.size(), 1u);
  EXPECT_TRUE(shapes[0].half_extents.isApprox(Vector3d(0.05, 0.1, 0.15)));
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("gripper"), std::string::npos);
  EXPECT_NE(warnings[0].find("package://nowhere/meshes/gripper.dae"), std::string::npos);

  Eigen::Vector3d lo, hi;
  EXPECT_NE(lc::meshBounds(tempPath("missing.stl"), lo, hi).find("cannot open"), std::string::npos);
  const std::string empty = tempPath("empty.obj");
  std::ofstream(empty) << "# nothing\n";
  EXPECT_NE(lc::meshBounds(empty, lo, hi).find("no readable vertex"), std::string::npos);
}

TEST(SelfFilterUrdf, MissingOrUnusableDescriptionsAreClearErrors)
{
  std::vector<std::string> w;
  const std::string good =
    robot(urdfLink("arm", "<sphere radius=\"0.1\"/>") + joint("arm", "bare") + "<link name=\"bare\"/>");
  EXPECT_EQ(parameterOf([&] {
              lc::shapesFromUrdf("", {}, 0.0, lc::resolveFileUri, w);
            }).rfind("robot_description: is empty", 0),
            0u);
  EXPECT_EQ(parameterOf([&] {
              lc::shapesFromUrdf("<robot name=\"r\"><link", {}, 0.0, lc::resolveFileUri, w);
            }).rfind("robot_description: is not a valid URDF", 0),
            0u);
  EXPECT_EQ(parameterOf([&] { lc::shapesFromUrdf(good, { "elbow" }, 0.0, lc::resolveFileUri, w); }),
            "self_filter/links: link 'elbow' is not in the robot description");
  EXPECT_EQ(parameterOf([&] { lc::shapesFromUrdf(good, { "bare" }, 0.0, lc::resolveFileUri, w); }),
            "self_filter/links: link 'bare' has no collision element");
  EXPECT_EQ(parameterOf([&] {
              lc::shapesFromUrdf(robot("<link name=\"a\"/>"), {}, 0.0, lc::resolveFileUri, w);
            }).rfind("robot_description: has no link with a collision element", 0),
            0u);
  EXPECT_EQ(parameterOf([&] { lc::shapesFromUrdf(good, {}, 0.0, lc::resolveFileUri, w); }), "");
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
