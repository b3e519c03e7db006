#include "multi_laserscan_merger/merger_core.hpp"

#include <algorithm>
#include <cmath>

#include "beam_kernel.hpp"

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

// Output limits: kInvalidMark (only invalid readings there) becomes `invalid` (NaN), beyond
// range_max is no return (+Inf or range_max + inf_epsilon), below range_min is `too_close`
// (-Inf, REP 117). Vectorised like projectBeams.
// The fusion bins are reset to +Inf on the way, ready for the next merge.
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void applyOutputLimits(
  float* __restrict in, float* __restrict r, std::size_t n, float rmin, float rmax, float no_return, float invalid,
  float too_close)
{
  for (std::size_t k = 0; k < n; ++k)
  {
    float v = in[k];
    in[k] = kFInf;
    v = v == kInvalidMark ? invalid : v > rmax ? no_return : v < rmin ? too_close : v;
    r[k] = v;
  }
}
}  // namespace

bool insidePolygon(const std::vector<std::array<double, 2>>& polygon, double x, double y)
{
  bool inside = false;
  for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++)
  {
    const double xi = polygon[i][0], yi = polygon[i][1], xj = polygon[j][0], yj = polygon[j][1];
    // Edge (j, i) crosses the horizontal ray from (x, y) towards +x.
    if ((yi > y) != (yj > y) && x < xj + (y - yj) * (xi - xj) / (yi - yj))
      inside = !inside;
  }
  return inside;
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
  for (const auto& p : o.footprint)
    footprint_radius_ = std::max(footprint_radius_, std::hypot(p[0], p[1]));
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
    c.in_fov[i] = sp.inFieldOfView(a) ? 1.0f : 0.0f;
  }
  c.first_in = 0;
  while (c.first_in < c.n && c.in_fov[c.first_in] == 0.0f)
    ++c.first_in;
  c.end_in = c.n;
  while (c.end_in > c.first_in && c.in_fov[c.end_in - 1] == 0.0f)
    --c.end_in;
  c.span_all_in =
    std::all_of(c.in_fov.begin() + static_cast<std::ptrdiff_t>(c.first_in),
                c.in_fov.begin() + static_cast<std::ptrdiff_t>(c.end_in), [](float f) { return f > 0.5f; });
}

void MergerCore::merge(const std::vector<SourceInput>& inputs, double t_out, const OdometryBuffer* odom,
                       const Eigen::Isometry3d& output_T_robot, std::vector<float>& out_ranges,
                       std::vector<float>& out_intensities, std::vector<SourceStatus>& status)
{
  const std::size_t n_src = params_.sources.size();
  status.assign(n_src, SourceStatus::kMissing);
  // Scratch bins past the end take the beams left out (see projectBeams).
  // +Inf everywhere: filled once, reset by applyOutputLimits at the end of every merge (the
  // scratch bins after n_out are never read, they need no reset).
  bins_.resize(n_out_ + kScratch, kFInf);

  bool any_intensity = false;
  for (std::size_t s = 0; s < n_src && s < inputs.size(); ++s)
  {
    const SourceInput& in = inputs[s];
    if (!in.present)
      continue;
    if (!in.checked && !scanFault(in.scan).empty())
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
    ibins_.assign(n_out_ + kScratch, 0.0f);

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
  // sensor's mount: output_T_robot * P(t_out)^-1 * P(t) * robot_T_output * output_T_sensor,
  // computed as left * P(t) * right with the constant parts multiplied once.
  // The usual case (odometry child frame == output frame) skips the identity products.
  const bool robot_is_output = output_T_robot.matrix().isIdentity(0.0);
  const Eigen::Isometry3d left = robot_is_output ? out_T_odom : Eigen::Isometry3d(output_T_robot * out_T_odom);
  auto sensor_at = [&](double t, const Eigen::Isometry3d& right) {
    Pose p;
    odom->poseAt(t, p);
    // Only the first two rows of left * P(t) * right are needed (planarPart).
    const Eigen::Matrix<double, 2, 4> rows = left.matrix().topRows<2>() * p.toIsometry().matrix();
    const Eigen::Matrix<double, 2, 4> m = rows * right.matrix();
    Eigen::Matrix<float, 2, 3> out;
    out << static_cast<float>(m(0, 0)), static_cast<float>(m(0, 1)), static_cast<float>(m(0, 3)),
      static_cast<float>(m(1, 0)), static_cast<float>(m(1, 1)), static_cast<float>(m(1, 3));
    return out;
  };
  auto mount = [&](const Eigen::Isometry3d& output_T_sensor) {
    return robot_is_output ? output_T_sensor : Eigen::Isometry3d(robot_T_output * output_T_sensor);
  };

  auto add_source = [&](std::size_t s) {
    const SourceInput& in = withoutSelfReturns(s, inputs[s]);
    const ScanView& scan = in.scan;
    updateCache(s, scan);
    const std::size_t n = scan.n_ranges;
    const bool with_intensity = any_intensity && scan.n_intensities == n;
    if (compensate && params_.sources[s].deskew && scan.time_increment != 0.0 && n > 1)
    {
      // Beam i was measured at stamp + i * time_increment. The exact transform (robot
      // motion from the odometry) is computed at the borders of every kDeskewGroup beams;
      // between two borders the planar transform is interpolated per beam, whose error is
      // second order in the small rotation of one group.
      const Eigen::Isometry3d right = mount(in.output_T_sensor);
      const std::size_t groups = (n - 1 + kDeskewGroup - 1) / kDeskewGroup;
      if (group_transforms_.size() < groups + 1)
        group_transforms_.resize(groups + 1);
      for (std::size_t g = 0; g <= groups; ++g)
      {
        const std::size_t b = std::min(g * kDeskewGroup, n - 1);
        const double t = scan.stamp + static_cast<double>(b) * scan.time_increment;
        group_transforms_[g] = sensor_at(t, right);
      }
      addScan<true>(s, in, group_transforms_.data(), kDeskewGroup, with_intensity);
    }
    else
    {
      if (group_transforms_.empty())
        group_transforms_.resize(1);
      group_transforms_[0] =
        compensate ? sensor_at(scan.stamp, mount(in.output_T_sensor)) : planarPart(in.output_T_sensor);
      addScan<false>(s, in, group_transforms_.data(), n, with_intensity);
    }
  };
  auto explains_others = [&](std::size_t s) { return params_.sources[s].drop_explained_within > 0.0; };
  bool any_second_pass = false;
  for (std::size_t s = 0; s < n_src; ++s)
  {
    if (status[s] != SourceStatus::kUsed)
      continue;
    if (explains_others(s))
      any_second_pass = true;
    else
      add_source(s);
  }
  if (any_second_pass)
  {
    // Each such source is binned on its own (bins_ swapped with own_bins_, all +Inf), judged
    // against the first-pass bins (never against another second-pass source, so the order of
    // sources does not matter), then fused by the first pass's rule or dropped whole. Its
    // intensities go along exactly as in the first pass (own_ibins_ swapped with ibins_).
    first_pass_bins_.assign(bins_.begin(), bins_.begin() + static_cast<std::ptrdiff_t>(n_out_));
    own_bins_.resize(n_out_ + kScratch, kFInf);
    if (any_intensity)
      own_ibins_.resize(n_out_ + kScratch, 0.0f);
    for (std::size_t s = 0; s < n_src; ++s)
    {
      if (status[s] != SourceStatus::kUsed || !explains_others(s))
        continue;
      const bool with_intensity = any_intensity && inputs[s].scan.n_intensities == inputs[s].scan.n_ranges;
      bins_.swap(own_bins_);
      if (with_intensity)
        ibins_.swap(own_ibins_);
      add_source(s);
      bins_.swap(own_bins_);
      if (with_intensity)
        ibins_.swap(own_ibins_);
      if (!explainedByFirstPass(s))
        fuseOwnBins(with_intensity);
      std::fill(own_bins_.begin(), own_bins_.begin() + static_cast<std::ptrdiff_t>(n_out_), kFInf);
    }
  }

  // Bins past one full turn are the same directions as the first ones (e.g. -pi and pi).
  std::vector<float>& r = bins_;
  if (n_circle_ != 0)
    for (std::size_t k = n_circle_; k < n_out_; ++k)
    {
      r[k] = r[k - n_circle_];
      if (any_intensity)
        ibins_[k] = ibins_[k - n_circle_];
    }

  const OutputParams& o = params_.output;
  const float rmin = static_cast<float>(o.range_min);
  const float rmax = static_cast<float>(o.range_max);
  const float no_return = o.noReturnValue();
  // finite_only: 0 is below range_min (> 0, validated), which consumers discard.
  const float invalid = o.finite_only ? 0.0f : kFNaN;
  const float too_close = o.finite_only ? 0.0f : -kFInf;
  if (any_intensity)
  {
    out_intensities.assign(ibins_.begin(), ibins_.begin() + static_cast<std::ptrdiff_t>(n_out_));
    for (std::size_t k = 0; k < n_out_; ++k)
      if (!(r[k] <= rmax))
        out_intensities[k] = 0.0f;  // no return or invalid
  }
  else
    out_intensities.clear();
  out_ranges.resize(n_out_);
  applyOutputLimits(r.data(), out_ranges.data(), n_out_, rmin, rmax, no_return, invalid, too_close);
}

const SourceInput& MergerCore::withoutSelfReturns(std::size_t source, const SourceInput& in)
{
  if (!in.self_filter || in.self_filter->empty() || in.self_filter->bounds().empty())
    return in;
  // A return is the point (r cos a, r sin a, 0) of the sensor's frame, the frame the shapes are
  // posed in. Per beam, only when inside the shapes' bounding box: a few hundred beams per scan.
  updateCache(source, in.scan);
  const SourceCache& c = caches_[source];
  const ScanView& scan = in.scan;
  self_ranges_.assign(scan.ranges, scan.ranges + scan.n_ranges);
  for (std::size_t i = 0; i < scan.n_ranges; ++i)
  {
    const float r = self_ranges_[i];
    if (std::isfinite(r) && in.self_filter->contains(r * c.cos_a[i], r * c.sin_a[i], 0.0f))
      self_ranges_[i] = kFNaN;
  }
  self_input_ = in;
  self_input_.scan.ranges = self_ranges_.data();
  return self_input_;
}

// A real range in a bin: finite and not kInvalidMark (planar ranges, too-close kept as range_min).
static bool isReturn(float bin)
{
  return bin < kInvalidMark;
}

bool MergerCore::explainedByFirstPass(std::size_t source) const
{
  const float tol = static_cast<float>(params_.sources[source].drop_explained_within);
  for (std::size_t k = 0; k < n_out_; ++k)
    if (isReturn(own_bins_[k]) && isReturn(first_pass_bins_[k]) && std::abs(first_pass_bins_[k] - own_bins_[k]) <= tol)
      return true;
  return false;
}

void MergerCore::fuseOwnBins(bool with_intensity)
{
  // The rule of addScan's pass 2: the minimum (kInvalidMark loses against any real range and
  // replaces only +Inf); with intensities, a strictly closer range takes its intensity along.
  for (std::size_t k = 0; k < n_out_; ++k)
  {
    const float rr = own_bins_[k];
    if (rr < bins_[k])
    {
      bins_[k] = rr;
      if (with_intensity)
        ibins_[k] = own_ibins_[k];
    }
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
  const float rmax_msg = static_cast<float>(scan.range_max);
  const float amin = out_angle_min_;
  const float inv_inc = out_inv_increment_;
  // Bins from one full turn on are the first ones again; no wrap when the increment does not divide 2*pi.
  const int wrap = n_circle_ != 0 ? static_cast<int>(n_circle_) : std::numeric_limits<int>::max();
  const unsigned n_out = static_cast<unsigned>(n_out_);
  // -Inf ("closer than the sensor can measure") is kept as an obstacle at the sensor's
  // range_min, unless the source's own range_min is tighter: then everything closer
  // than it (the robot's body, typically) is deliberately ignored like an invalid reading.
  const bool keep_too_close = sp.too_close_is_obstacle && !(sp.range_min > scan.range_min);
  const bool footprint = sp.footprint_filter && !params_.output.footprint.empty();

  if (bin_buffer_.size() < n)
  {
    bin_buffer_.resize(n);
    range_buffer_.resize(n);
  }
  if (footprint && x_buffer_.size() < n)
  {
    x_buffer_.resize(n);
    y_buffer_.resize(n);
  }
  int* kb = bin_buffer_.data();
  float* rb = range_buffer_.data();
  const float* ranges = scan.ranges;
  const float* fov = c.in_fov.data();
  const float* cs = c.cos_a.data();
  const float* sn = c.sin_a.data();

  // Pass 1 (vectorised): output bin and range of every beam of the mask's span (the others
  // are never visited); without the mask's table when the whole span is inside it.
  // (The footprint variant of the kernel always reads the mask's table.)
  const float* fov_or_all = c.span_all_in && !footprint ? nullptr : fov;
  for (std::size_t b0 = 0, g = 0; b0 < n; b0 += group_size, ++g)
  {
    const std::size_t lo = std::max(b0, c.first_in), hi = std::min(b0 + group_size, c.end_in);
    if (lo >= hi)
      continue;
    const Eigen::Matrix<float, 2, 3>& m = transforms[g];
    const float m00 = m(0, 0), m01 = m(0, 1), m02 = m(0, 2);
    const float m10 = m(1, 0), m11 = m(1, 1), m12 = m(1, 2);
    float d00 = 0.0f, d01 = 0.0f, d02 = 0.0f, d10 = 0.0f, d11 = 0.0f, d12 = 0.0f;
    if (kInterpolate)
    {
      const std::size_t next = std::min(b0 + group_size, n - 1);
      if (next > b0)
      {
        const Eigen::Matrix<float, 2, 3> step = (transforms[g + 1] - m) / static_cast<float>(next - b0);
        d00 = step(0, 0), d01 = step(0, 1), d02 = step(0, 2);
        d10 = step(1, 0), d11 = step(1, 1), d12 = step(1, 2);
      }
    }
    // The transform at the first beam handled (lo), and its per-beam step.
    const float off = static_cast<float>(lo - b0);
    const float m_row[12] = { m00 + off * d00,
                              m01 + off * d01,
                              m02 + off * d02,
                              m10 + off * d10,
                              m11 + off * d11,
                              m12 + off * d12,
                              d00,
                              d01,
                              d02,
                              d10,
                              d11,
                              d12 };
    projectBeams(hi - lo, ranges + lo, fov_or_all ? fov_or_all + lo : nullptr, cs + lo, sn + lo, m_row, rmin, rmax,
                 rmax_msg, keep_too_close, amin, inv_inc, wrap, n_out, kb + lo, rb + lo,
                 footprint ? x_buffer_.data() + lo : nullptr, footprint ? y_buffer_.data() + lo : nullptr);
  }

  // Footprint: a return on the robot itself is no obstacle, and nothing behind it was seen:
  // its direction becomes invalid. Only points nearer than the farthest vertex are tested.
  if (footprint)
  {
    const float radius = static_cast<float>(footprint_radius_);
    for (std::size_t i = c.first_in; i < c.end_in; ++i)
      if (rb[i] <= radius && insidePolygon(params_.output.footprint, x_buffer_[i], y_buffer_[i]))
        rb[i] = kInvalidMark;
  }

  // Pass 2: keep the closest range per bin. Invalid beams carry kInvalidMark, which only
  // replaces +Inf and loses against any real range: REP 117 falls out of the minimum.
  // Beams before the first and after the last one inside the mask are not visited.
  float* bins = bins_.data();
  if (!with_intensity)
  {
    for (std::size_t i = c.first_in; i < c.end_in; ++i)
    {
      const int k = kb[i];
      const float bv = bins[k], rr = rb[i];
      bins[k] = bv < rr ? bv : rr;
    }
    return;
  }
  float* ibins = ibins_.data();
  const float* intens = scan.intensities;
  for (std::size_t i = c.first_in; i < c.end_in; ++i)
  {
    const int k = kb[i];
    const float rr = rb[i];
    if (rr < bins[k])
    {
      bins[k] = rr;
      ibins[k] = intens[i];
    }
  }
}

}  // namespace multi_laserscan_merger
