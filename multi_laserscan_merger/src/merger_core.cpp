#include "multi_laserscan_merger/merger_core.hpp"

#include <algorithm>
#include <cmath>

#include "multi_laserscan_merger/fast_math.hpp"

namespace multi_laserscan_merger
{

namespace
{
constexpr float kFInf = std::numeric_limits<float>::infinity();
constexpr float kFNaN = std::numeric_limits<float>::quiet_NaN();

// The beams lie in the sensor's x-y plane (z = 0), and the output keeps only x and y:
// the two rows and three useful columns of the 3D transform are all the hot loop needs.
// z of the transformed point is dropped (projection on the output plane), so a tilted
// or upside-down sensor is handled exactly, not just by its yaw.
Eigen::Matrix<float, 2, 3> planarPart(const Eigen::Isometry3d& t)
{
  Eigen::Matrix<float, 2, 3> m;
  m << static_cast<float>(t(0, 0)), static_cast<float>(t(0, 1)), static_cast<float>(t(0, 3)),
      static_cast<float>(t(1, 0)), static_cast<float>(t(1, 1)), static_cast<float>(t(1, 3));
  return m;
}

}  // namespace

std::size_t expectedBeamCount(const ScanView& s)
{
  if (!std::isfinite(s.angle_min) || !std::isfinite(s.angle_max) || !std::isfinite(s.angle_increment) ||
      s.angle_increment <= 0.0 || s.angle_max < s.angle_min)
    return 0;
  const double steps = (s.angle_max - s.angle_min) / s.angle_increment;
  if (steps > 1e7)
    return 0;
  return static_cast<std::size_t>(std::lround(steps)) + 1;
}

const char* scanFault(const ScanView& s)
{
  if (!std::isfinite(s.stamp))
    return "non-finite stamp";
  if (!std::isfinite(s.angle_min) || !std::isfinite(s.angle_max) || !std::isfinite(s.angle_increment))
    return "non-finite angle_min, angle_max or angle_increment";
  if (s.angle_increment <= 0.0)
    return "angle_increment <= 0";
  if (s.angle_max < s.angle_min)
    return "angle_max < angle_min";
  if (!std::isfinite(s.time_increment))
    return "non-finite time_increment";
  if (std::isnan(s.range_min) || std::isnan(s.range_max) || s.range_min > s.range_max)
    return "range_min/range_max NaN or range_min > range_max";
  if (s.n_ranges == 0 || s.ranges == nullptr)
    return "empty ranges";
  const std::size_t expected = expectedBeamCount(s);
  if (expected == 0)
    return "angles give too many beams";
  // Drivers round angle_max in different ways; beam i is placed at angle_min + i * increment,
  // so a disagreement of one beam is harmless. More means the message is inconsistent.
  const std::size_t diff = expected > s.n_ranges ? expected - s.n_ranges : s.n_ranges - expected;
  if (diff > 1)
    return "ranges length does not match round((angle_max - angle_min) / angle_increment) + 1";
  if (s.n_intensities != 0 && (s.intensities == nullptr || s.n_intensities != s.n_ranges))
    return "intensities length is neither 0 nor the ranges length";
  return nullptr;
}

void remapResolution(const std::vector<float>& in, std::size_t n_new, std::vector<float>& out)
{
  out.assign(n_new, kFInf);
  if (in.empty() || n_new == 0)
    return;
  const double ratio = static_cast<double>(n_new) / static_cast<double>(in.size());
  for (std::size_t i = 0; i < in.size(); ++i)
  {
    std::size_t k = static_cast<std::size_t>(std::lround(ratio * static_cast<double>(i)));
    if (k >= n_new)
      k -= n_new;  // the layout is a full turn: n_new is the same direction as 0
    if (k < n_new)
      fuse(out[k], in[i]);
  }
}

MergerCore::MergerCore(const MergerParams& params) : params_(params)
{
  params_.validate();
  const OutputParams& o = params_.output;
  n_out_ = o.beamCount();
  const double turns = 2.0 * kPi / o.angle_increment;
  const double rounded = std::round(turns);
  n_circle_ = std::abs(turns - rounded) < 1e-6 * std::max(1.0, turns) ? static_cast<std::size_t>(rounded) : 0;
  out_angle_min_ = static_cast<float>(o.angle_min);
  out_inv_increment_ = static_cast<float>(1.0 / o.angle_increment);
  caches_.resize(params_.sources.size());
}

void MergerCore::updateCache(std::size_t source, const ScanView& scan)
{
  SourceCache& c = caches_[source];
  if (c.n == scan.n_ranges && c.angle_min == scan.angle_min && c.angle_increment == scan.angle_increment)
    return;
  c.n = scan.n_ranges;
  c.angle_min = scan.angle_min;
  c.angle_increment = scan.angle_increment;
  c.cos_a.resize(c.n);
  c.sin_a.resize(c.n);
  c.in_fov.resize(c.n);
  const SourceParams& sp = params_.sources[source];
  for (std::size_t i = 0; i < c.n; ++i)
  {
    const double a = scan.angle_min + static_cast<double>(i) * scan.angle_increment;
    c.cos_a[i] = static_cast<float>(std::cos(a));
    c.sin_a[i] = static_cast<float>(std::sin(a));
    c.in_fov[i] = sp.inFieldOfView(a) ? 1 : 0;
  }
}

void MergerCore::merge(const std::vector<SourceInput>& inputs, double t_out, const OdometryBuffer* odom,
                       const Eigen::Isometry3d& output_T_robot, MergedScan& out,
                       std::vector<SourceStatus>& status)
{
  const std::size_t n_src = params_.sources.size();
  status.assign(n_src, SourceStatus::kMissing);
  out.stamp = t_out;
  out.ranges.assign(n_out_, kFInf);
  ranges_ = &out.ranges;
  intensities_ = &out.intensities;

  bool any_intensity = false;
  for (std::size_t s = 0; s < n_src && s < inputs.size(); ++s)
  {
    const SourceInput& in = inputs[s];
    if (!in.present)
      continue;
    if (scanFault(in.scan) != nullptr)
      status[s] = SourceStatus::kInvalid;
    else if (t_out - in.scan.stamp > params_.sources[s].timeout)
      status[s] = SourceStatus::kTimedOut;
    else
    {
      status[s] = SourceStatus::kUsed;
      any_intensity = any_intensity || in.scan.n_intensities == in.scan.n_ranges;
    }
  }
  if (any_intensity)
    out.intensities.assign(n_out_, 0.0f);
  else
    out.intensities.clear();

  const bool compensate = odom != nullptr && !odom->empty();
  Eigen::Isometry3d out_T_odom = Eigen::Isometry3d::Identity();  // P(t_out)^-1
  if (compensate)
  {
    Pose p;
    odom->poseAt(t_out, p);
    out_T_odom = p.toIsometry().inverse(Eigen::Isometry);
  }
  const Eigen::Isometry3d robot_T_output = output_T_robot.inverse(Eigen::Isometry);
  // Robot motion between a beam's time t and t_out, in the robot (odometry child) frame
  // at t_out: P(t_out)^-1 * P(t). It is conjugated into the output frame around the
  // sensor's mount: output_T_robot * motion * robot_T_output * output_T_sensor.
  auto motion_to = [&](double t) {
    Pose p;
    odom->poseAt(t, p);
    return Eigen::Isometry3d(out_T_odom * p.toIsometry());
  };

  for (std::size_t s = 0; s < n_src; ++s)
  {
    if (status[s] != SourceStatus::kUsed)
      continue;
    const SourceInput& in = inputs[s];
    const ScanView& scan = in.scan;
    updateCache(s, scan);
    const std::size_t n = scan.n_ranges;
    const bool with_intensity = any_intensity && scan.n_intensities == n;
    if (compensate && params_.sources[s].deskew && scan.time_increment != 0.0 && n > 1)
    {
      // Beam i was measured at stamp + i * time_increment. The robot motion of the first
      // and the last beam come from the odometry (two look-ups per scan) and are
      // interpolated (lerp + nlerp on the short arc; within one scan the rotation is
      // small, so nlerp is slerp to 1e-5 rad) at the borders of every kDeskewGroup beams.
      // Between two borders the planar transform is interpolated per beam, whose error is
      // second order in the tiny rotation of one group.
      const double t_last = scan.stamp + static_cast<double>(n - 1) * scan.time_increment;
      const Eigen::Isometry3d d0 = motion_to(scan.stamp);
      const Eigen::Isometry3d d1 = motion_to(t_last);
      const Eigen::Quaterniond q0(d0.linear());
      Eigen::Quaterniond q1(d1.linear());
      if (q0.coeffs().dot(q1.coeffs()) < 0.0)
        q1.coeffs() = -q1.coeffs();
      const Eigen::Isometry3d right = robot_T_output * in.output_T_sensor;
      const std::size_t groups = (n - 1 + kDeskewGroup - 1) / kDeskewGroup;
      if (group_transforms_.size() < groups + 1)
        group_transforms_.resize(groups + 1);
      for (std::size_t g = 0; g <= groups; ++g)
      {
        const std::size_t b = std::min(g * kDeskewGroup, n - 1);
        const double u = static_cast<double>(b) / static_cast<double>(n - 1);
        Eigen::Quaterniond q;
        q.coeffs() = (1.0 - u) * q0.coeffs() + u * q1.coeffs();
        q.normalize();
        Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
        d.linear() = q.toRotationMatrix();
        d.translation() = (1.0 - u) * d0.translation() + u * d1.translation();
        group_transforms_[g] = planarPart(output_T_robot * d * right);
      }
      addScan<true>(s, in, group_transforms_.data(), kDeskewGroup, with_intensity);
    }
    else
    {
      if (group_transforms_.empty())
        group_transforms_.resize(1);
      group_transforms_[0] = planarPart(
          compensate ? Eigen::Isometry3d(output_T_robot * motion_to(scan.stamp) * robot_T_output * in.output_T_sensor) :
                       in.output_T_sensor);
      addScan<false>(s, in, group_transforms_.data(), n, with_intensity);
    }
  }

  // Bins past one full turn are the same directions as the first ones (e.g. -pi and pi).
  std::vector<float>& r = out.ranges;
  if (n_circle_ != 0)
    for (std::size_t k = n_circle_; k < n_out_; ++k)
    {
      r[k] = r[k - n_circle_];
      if (any_intensity)
        out.intensities[k] = out.intensities[k - n_circle_];
    }

  const OutputParams& o = params_.output;
  const float rmin = static_cast<float>(o.range_min);
  const float rmax = static_cast<float>(o.range_max);
  const float no_return = o.use_inf ? kFInf : static_cast<float>(o.range_max + o.inf_epsilon);
  for (std::size_t k = 0; k < n_out_; ++k)
  {
    float v = r[k];
    if (v > rmax)
      v = kFInf;  // beyond the output's reach: no return
    else if (v < rmin)
      v = -kFInf;  // REP 117: too close
    if (v == kFInf)
    {
      v = no_return;
      if (any_intensity)
        out.intensities[k] = 0.0f;
    }
    r[k] = v;
  }
}

template <bool kInterpolate>
void MergerCore::addScan(std::size_t source, const SourceInput& in, const Eigen::Matrix<float, 2, 3>* transforms,
                         std::size_t group_size, bool with_intensity)
{
  const ScanView& scan = in.scan;
  const SourceParams& sp = params_.sources[source];
  const SourceCache& c = caches_[source];
  const std::size_t n = scan.n_ranges;
  // Source limits only tighten the message's own.
  const float rmin = static_cast<float>(std::max(scan.range_min, sp.range_min));
  const float rmax = static_cast<float>(std::min(scan.range_max, sp.range_max));
  // -Inf ("closer than the sensor can measure") is kept as an obstacle at the sensor's
  // range_min, unless the source's own range_min is tighter: then everything closer
  // than it (the robot's body, typically) is deliberately ignored.
  const bool keep_too_close = !(sp.range_min > scan.range_min);
  const float* ranges = scan.ranges;
  const float* intens = scan.intensities;
  float* bins = ranges_->data();
  float* ibins = with_intensity ? intensities_->data() : nullptr;
  const float amin = out_angle_min_;
  const float inv_inc = out_inv_increment_;
  const int n_circle = static_cast<int>(n_circle_);
  const int n_out = static_cast<int>(n_out_);
  constexpr float kTwoPi = static_cast<float>(2.0 * kPi);

  auto bin_of = [&](float x, float y) -> int {
    float rel = fastAtan2(y, x) - amin;
    if (rel < 0.0f)
      rel += kTwoPi;
    if (rel >= kTwoPi)
      rel -= kTwoPi;
    int k = static_cast<int>(rel * inv_inc + 0.5f);
    if (n_circle != 0 && k >= n_circle)
      k -= n_circle;
    return (k >= 0 && k < n_out) ? k : -1;
  };

  for (std::size_t b0 = 0, g = 0; b0 < n; b0 += group_size, ++g)
  {
    const Eigen::Matrix<float, 2, 3>& m = transforms[g];
    float m00 = m(0, 0), m01 = m(0, 1), m02 = m(0, 2);
    float m10 = m(1, 0), m11 = m(1, 1), m12 = m(1, 2);
    const std::size_t b1 = std::min(n, b0 + group_size);
    // Per-beam step of the transform towards the next border (kInterpolate only).
    Eigen::Matrix<float, 2, 3> step = Eigen::Matrix<float, 2, 3>::Zero();
    if (kInterpolate)
    {
      const std::size_t next = std::min(b0 + group_size, n - 1);
      if (next > b0)
        step = (transforms[g + 1] - m) / static_cast<float>(next - b0);
    }
    for (std::size_t i = b0; i < b1; ++i)
    {
      if (kInterpolate && i != b0)
      {
        m00 += step(0, 0), m01 += step(0, 1), m02 += step(0, 2);
        m10 += step(1, 0), m11 += step(1, 1), m12 += step(1, 2);
      }
      if (!c.in_fov[i])
        continue;
      float v = ranges[i];
      const float ca = c.cos_a[i], sa = c.sin_a[i];
      if (!(v >= rmin && v <= rmax))
      {
        if (v > rmax)
          continue;  // no return (+Inf) or beyond the limits: the bin stays +Inf
        if (v == -kFInf && keep_too_close)
          v = rmin;
        else
        {
          // Invalid (NaN, below range_min, or hidden by the source's range_min): the
          // direction (a ray to infinity: rotation only) is marked NaN unless something real is there.
          const int k = bin_of(m00 * ca + m01 * sa, m10 * ca + m11 * sa);
          if (k >= 0 && bins[k] == kFInf)
            bins[k] = kFNaN;
          continue;
        }
      }
      const float x = v * (m00 * ca + m01 * sa) + m02;
      const float y = v * (m10 * ca + m11 * sa) + m12;
      const int k = bin_of(x, y);
      if (k < 0)
        continue;
      const float rr = std::sqrt(x * x + y * y);
      const float bv = bins[k];
      if (rr < bv || bv != bv)
      {
        bins[k] = rr;
        if (ibins != nullptr)
          ibins[k] = intens[i];
      }
    }
  }
}

}  // namespace multi_laserscan_merger
