#include "reactive_navigator/navigator_core.hpp"
#include "reactive_navigator/global_planner.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include <mrpt/config/CConfigFileMemory.h>
#include <mrpt/kinematics/CVehicleVelCmd_Holo.h>
#include <mrpt/maps/CSimplePointsMap.h>
#include <mrpt/nav/holonomic/CHolonomicFullEval.h>
#include <mrpt/math/wrap2pi.h>
#include <mrpt/nav/reactive/CReactiveNavigationSystem.h>
#include <mrpt/nav/reactive/CReactiveNavigationSystem3D.h>
#include <mrpt/nav/reactive/CRobot2NavInterface.h>
#include <mrpt/system/datetime.h>

#include "laserscan_common/scan_geometry.hpp"

namespace reactive_navigator
{

const char* stateName(NavigationState state)
{
  switch (state)
  {
    case NavigationState::Idle:
      return "idle";
    case NavigationState::Navigating:
      return "navigating";
    case NavigationState::Reached:
      return "reached";
    case NavigationState::Blocked:
      return "blocked";
  }
  return "unknown";
}

namespace
{

constexpr double kRadToDeg = 180.0 / laserscan_common::kPi;
constexpr double kProgress = 0.1;  // m closer to the goal that counts as progress
// m: a plan this much longer than the step before's is a new way (round what closed the former):
// progress is counted along it from where the robot is.
constexpr double kDetour = 1.0;
// The obstacle memory's cell (m): fine against the robot's 0.05 m secure distance, and coarse
// enough that raw 3D at 300k points per camera keeps tens of thousands of cells, not millions.
constexpr double kMemoryCell = 0.05;

// A cell's key: 21 bits per axis (+-52 km at 5 cm), the height 0 in 2d mode (a floor plan).
std::int64_t memoryKey(const Eigen::Vector3f& odom_point, bool volumetric)
{
  const auto index = [](float v) {
    return (static_cast<std::int64_t>(std::floor(v / kMemoryCell)) + (1 << 20)) & ((1 << 21) - 1);
  };
  const std::int64_t z = volumetric ? index(odom_point.z()) : 0;
  return (index(odom_point.x()) << 42) | (index(odom_point.y()) << 21) | z;
}

double circumradius(const Polygon& polygon)
{
  double r = 0.0;
  for (const auto& v : polygon)
    r = std::max(r, v.norm());
  return r;
}

// The robot's circle as MRPT's CPTG_Holo_Blend takes it: around the footprint (2d), around every
// level of the shape (3d).
double robotRadius(const NavigatorParameters& p)
{
  if (!p.volumetric())
    return circumradius(p.footprint);
  double r = 0.0;
  for (const auto& level : p.shape_3d)
    r = std::max(r, circumradius(level.polygon));
  return r;
}

PlannerSettings plannerSettings(const NavigatorParameters& p)
{
  PlannerSettings s;
  s.resolution = p.planner_resolution;
  s.memory = p.planner_memory;
  s.robot_radius = robotRadius(p);
  s.inflation = p.planner_inflation;
  s.clearance = p.planner_clearance;
  s.margin = p.planner_margin;
  s.clearing_range = p.planner_clearing_range;
  return s;
}

std::string joined(const Polygon& polygon, int axis)
{
  std::ostringstream out;
  for (const auto& v : polygon)
    out << v[axis] << ' ';
  return out.str();
}

// MRPT reads its navigators' settings from an INI text; ours is generated from the parameters so
// that a user sets ROS parameters only. Sections and keys are MRPT 2.5's
// (/usr/share/mrpt/config_files/navigation-ptgs/reactive2d_config.ini documents them).
std::string mrptConfig(const NavigatorParameters& p)
{
  std::ostringstream ini;
  ini.precision(17);
  ini << "[CAbstractNavigator]\n"
      << "dist_to_target_for_sending_event = 0\n"
      // "No progress" is decided by NavigatorCore itself (one rule, on the caller's clock).
      << "alarm_seems_not_approaching_target_timeout = 1e9\n"
      << "dist_check_target_is_blocked = " << std::max(p.goal_tolerance, 0.5) << "\n"
      << "hysteresis_check_target_is_blocked = 5\n"
      << "enable_time_profiler = false\n"
      << "[CAbstractPTGBasedReactive]\n"
      << "robotMax_V_mps = " << p.max_linear_speed << "\n"
      << "robotMax_W_degps = " << p.max_angular_speed * kRadToDeg << "\n"
      << "holonomic_method = CHolonomicFullEval\n"
      << "motion_decider_method = CMultiObjMotionOpt_Scalarization\n"
      << "ref_distance = " << p.lookahead << "\n"
      << "speedfilter_tau = 0\n"
      << "secure_distance_start = 0.05\n"
      << "secure_distance_end = 0.20\n"
      // Poses and obstacles are those of the step's own time: nothing to inter/extrapolate,
      // and MRPT's delay model would measure wall-clock delays (a run would depend on the load).
      << "use_delays_model = false\n"
      << "max_distance_predicted_actual_path = 0.15\n"
      << "min_normalized_free_space_for_ptg_continuation = 0.2\n"
      // The filter compares clouds across keyframes by wall-clock age: off for repeatable runs.
      << "enable_obstacle_filtering = false\n"
      << "evaluate_clearance = false\n"
      // How candidate motions are scored (MRPT's exprtk formulas over its documented variables):
      // getting near the goal weighs most, then a free path, then the goal's path being free
      // right up to it, then keeping the former choice (against dithering).
      << "[CMultiObjectiveMotionOptimizerBase]\n"
      << "score1_name = nearness\n"
      << "score1_formula = 1/(1+dist_eucl_min)\n"
      << "score2_name = free_distance\n"
      << "score2_formula = min(collision_free_distance, 1.0)\n"
      << "score3_name = goal_path_free\n"
      << "score3_formula = if(collision_free_distance>target_d_norm, 1.0, 0.0)\n"
      << "score4_name = keep_choice\n"
      << "score4_formula = hysteresis\n"
      << "scores_to_normalize =\n"
      << "[CMultiObjMotionOpt_Scalarization]\n"
      << "scalar_score_formula = 4.0*nearness + 0.5*free_distance + 1.0*goal_path_free + "
         "0.1*keep_choice\n";
  const std::string section = p.volumetric() ? "CReactiveNavigationSystem3D" : "CReactiveNavigationSystem";
  // MRPT numbers the 2D navigator's PTGs from 0 and the 3D navigator's from 1.
  const std::string ptg = p.volumetric() ? "PTG1_" : "PTG0_";
  ini << "[" << section << "]\n"
      << "PTG_COUNT = 1\n"
      << ptg << "Type = CPTG_Holo_Blend\n"
      << ptg << "refDistance = " << p.lookahead << "\n"
      << ptg << "num_paths = " << p.path_count << "\n"
      << ptg << "v_max_mps = " << p.max_linear_speed << "\n"
      << ptg << "w_max_dps = " << p.max_angular_speed * kRadToDeg << "\n"
      << ptg << "T_ramp_max = " << p.max_linear_speed / p.linear_acceleration << "\n"
      << ptg << "score_priority = 1.0\n";
  if (p.volumetric())
  {
    ini << "HEIGHT_LEVELS = " << p.shape_3d.size() << "\n";
    for (std::size_t i = 0; i < p.shape_3d.size(); ++i)
      ini << "LEVEL" << i + 1 << "_HEIGHT = " << p.shape_3d[i].height << "\n"
          << "LEVEL" << i + 1 << "_VECTORX = " << joined(p.shape_3d[i].polygon, 0) << "\n"
          << "LEVEL" << i + 1 << "_VECTORY = " << joined(p.shape_3d[i].polygon, 1)
          << "\n"
          // CPTG_Holo_Blend takes each level as a circle: its polygon's circumscribed one (MRPT's
          // default, 0.5 m, would judge the robot wider than it is).
          << "LEVEL" << i + 1 << "_RADIUS = " << circumradius(p.shape_3d[i].polygon) << "\n";
  }
  else
  {
    // The caller keeps the height band: MRPT's own band is opened wide.
    ini << "min_obstacles_height = -1000\nmax_obstacles_height = 1000\n"
        << "RobotModel_shape2D_xs = " << joined(p.footprint, 0) << "\n"
        << "RobotModel_shape2D_ys = " << joined(p.footprint, 1)
        << "\n"
        // CPTG_Holo_Blend models the robot as a circle: the footprint's circumscribed one.
        << "RobotModel_circular_shape_radius = " << circumradius(p.footprint) << "\n";
  }
  return ini.str();
}

bool insideGrown(const Polygon& polygon, double x, double y, double padding)
{
  bool inside = false;  // even-odd rule
  double nearest = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++)
  {
    const Eigen::Vector2d& a = polygon[i];
    const Eigen::Vector2d& b = polygon[j];
    if ((a.y() > y) != (b.y() > y) && x < (b.x() - a.x()) * (y - a.y()) / (b.y() - a.y()) + a.x())
      inside = !inside;
    const Eigen::Vector2d ab = b - a, ap = Eigen::Vector2d(x, y) - a;
    const double u = std::clamp(ap.dot(ab) / std::max(ab.squaredNorm(), 1e-12), 0.0, 1.0);
    nearest = std::min(nearest, (ap - u * ab).norm());
  }
  return inside || nearest <= padding;
}

// The shape at height z: the footprint in 2d, the level holding z in 3d (the lowest below the
// floor; none above the top, where nothing is the robot).
const Polygon* shapeAt(const NavigatorParameters& p, float z)
{
  if (!p.volumetric())
    return &p.footprint;
  double top = 0.0;
  for (const auto& level : p.shape_3d)
  {
    top += level.height;
    if (z <= top)
      return &level.polygon;
  }
  return nullptr;
}

// MRPT's navigator reads its clock (mrpt::Clock::now()) to time its commands, e.g. where the robot
// should be along the path of the last command when it decides to keep it: on the wall clock a
// run would depend on the machine's load (identical inputs gave different commands in closed
// loop). So its clock is the caller's: MRPT's simulated clock, set to the step's time. (A process
// setting: the navigator is the only user of MRPT's clock in its process.)
void useCallersClock(double time)
{
  mrpt::Clock::setSimulatedTime(mrpt::Clock::fromDouble(time));
  mrpt::Clock::setActiveClock(mrpt::Clock::Simulated);
}

}  // namespace

// The robot side of MRPT's navigator: answers its questions with the data of the current step
// and keeps the command it sends.
struct NavigatorCore::Impl : public mrpt::nav::CRobot2NavInterface
{
  NavigatorParameters parameters;
  std::unique_ptr<mrpt::nav::CAbstractPTGBasedReactive> navigator;

  double time = 0.0;         // the current step's time
  double timer_start = 0.0;  // for getNavigationTime()
  Pose2 pose;
  Pose2 previous_pose;
  double previous_time = std::nan("");
  mrpt::math::TTwist2D velocity{ 0.0, 0.0, 0.0 };  // odometry frame, from successive poses
  ObstaclePoints obstacles;                        // the step's points without the robot's own body
  std::size_t self_points = 0;
  std::size_t remembered_points = 0;

  // obstacle_memory: per cell, the newest point seen in it (odometry frame) and when.
  struct Remembered
  {
    Eigen::Vector3f point;
    double time;
  };
  std::unordered_map<std::int64_t, Remembered> memory;

  // The global layer (parameters.planner): the path MRPT's target is taken from.
  std::unique_ptr<GlobalPlanner> planner;
  long plan_index = -1;  // the planner_rate period of the last plan
  bool has_path = false;
  double remaining_path = std::nan("");  // m along the path from the robot to the goal
  // MRPT's current target: the goal (final) or a carrot on the path.
  bool final_target = true;
  Eigen::Vector2d target{ 0.0, 0.0 };

  // Gives MRPT the target (odometry frame) unless it is navigating to it already. A carrot is an
  // intermediate waypoint: MRPT neither slows down for it nor ends the navigation there.
  void aim(const Eigen::Vector2d& point, bool final)
  {
    if (final == final_target && (point - target).norm() < 1e-3 &&
        navigator->getCurrentState() == mrpt::nav::CAbstractNavigator::NAVIGATING)
      return;
    if (navigator->getCurrentState() == mrpt::nav::CAbstractNavigator::NAV_ERROR)
      navigator->resetNavError();
    mrpt::nav::CAbstractPTGBasedReactive::TNavigationParamsPTG request;
    request.target.target_coords = mrpt::math::TPose2D(point.x(), point.y(), 0.0);
    request.target.target_frame_id = "map";
    request.target.targetAllowedDistance = static_cast<float>(parameters.goal_tolerance);
    request.target.targetIsRelative = false;
    if (!final)
    {
      request.target.targetDesiredRelSpeed = 1.0;
      request.target.targetIsIntermediaryWaypoint = true;
    }
    navigator->navigate(&request);
    final_target = final;
    target = point;
  }

  // One sensor's points of the step, d.obstacles[begin, end), into the planner's grid (odometry
  // frame): in 3d those the robot's shape reaches (MRPT ignores the points above its top). With
  // an origin, its rays clear the cells it marked before (global_planner.hpp).
  std::vector<Eigen::Vector2d> marked, free_ends;
  void markObstacles(double now, std::size_t begin, std::size_t end, const Observation* observation)
  {
    const double c = std::cos(pose.yaw), s = std::sin(pose.yaw);
    const auto odom = [&](const Eigen::Vector3f& p) {
      return Eigen::Vector2d(pose.x + c * p.x() - s * p.y(), pose.y + s * p.x() + c * p.y());
    };
    marked.clear();
    for (std::size_t i = begin; i < end; ++i)
      if (!parameters.volumetric() || shapeAt(parameters, obstacles[i].z()) != nullptr)
        marked.push_back(odom(obstacles[i]));
    if (observation == nullptr)
    {
      for (const auto& p : marked)
        planner->mark(p.x(), p.y(), now);
      return;
    }
    free_ends.clear();
    for (const auto& p : observation->free_ends)
      free_ends.push_back(odom(p));
    planner->observe(observation->source, odom(observation->origin), marked, free_ends, now);
  }

  // Replans at planner_rate and aims MRPT at the carrot; returns the path's length left to the
  // goal (m), or NaN without a path (MRPT is then aimed at the goal itself).
  double followPath(double now)
  {
    const Eigen::Vector2d here(pose.x, pose.y), goal(goal_x, goal_y);
    const long period = static_cast<long>(std::floor(now * parameters.planner_rate + 1e-6));
    if (period != plan_index)
    {
      has_path = planner->plan(now, here, goal);
      plan_index = period;
    }
    if (!has_path)
    {
      aim(goal, true);
      return std::nan("");
    }
    double remaining = 0.0;
    const Eigen::Vector2d carrot = planner->carrot(here, parameters.carrot_distance, remaining);
    if (remaining <= parameters.carrot_distance)
      aim(goal, true);
    else
      aim(carrot, false);
    return remaining;
  }

  bool isOwnBody(const Eigen::Vector3f& point) const
  {
    const Polygon* shape = shapeAt(parameters, point.z());
    return shape != nullptr && insideGrown(*shape, point.x(), point.y(), parameters.self_padding);
  }

  // Stores the step's points (robot frame, own body dropped) and appends the remembered ones not
  // seen again this step, brought into the robot frame at `pose`; forgets what is too old or
  // beyond the look-ahead. A remembered point now inside the robot's shape (the robot drove
  // where a person stood) is not handed on: MRPT would take it for a collision.
  void remember(double now)
  {
    const double c = std::cos(pose.yaw), s = std::sin(pose.yaw);
    const bool volumetric = parameters.volumetric();
    for (const auto& p : obstacles)
    {
      const Eigen::Vector3f odom(static_cast<float>(pose.x + c * p.x() - s * p.y()),
                                 static_cast<float>(pose.y + s * p.x() + c * p.y()), p.z());
      memory[memoryKey(odom, volumetric)] = Remembered{ odom, now };
    }
    const std::size_t seen = obstacles.size();
    const double reach2 = parameters.lookahead * parameters.lookahead;
    for (auto it = memory.begin(); it != memory.end();)
    {
      const double dx = it->second.point.x() - pose.x, dy = it->second.point.y() - pose.y;
      if (now - it->second.time > parameters.obstacle_memory || dx * dx + dy * dy > reach2)
      {
        it = memory.erase(it);
        continue;
      }
      if (it->second.time < now)
      {
        const Eigen::Vector3f robot(static_cast<float>(c * dx + s * dy), static_cast<float>(-s * dx + c * dy),
                                    it->second.point.z());
        if (!isOwnBody(robot))
          obstacles.push_back(robot);
      }
      ++it;
    }
    remembered_points = obstacles.size() - seen;
  }

  // The held command: speed along a direction fixed in the odometry frame (CPTG_Holo_Blend's
  // paths keep their heading while the robot turns) and the turn rate.
  double speed = 0.0;
  double direction = 0.0;
  double turn_rate = 0.0;

  NavigationState state = NavigationState::Idle;
  double goal_x = 0.0;
  double goal_y = 0.0;
  double best_distance = 0.0;  // closest to the goal so far
  double progress_time = 0.0;  // when it last got kProgress closer

  explicit Impl(const NavigatorParameters& p) : parameters(p)
  {
    setMinLoggingLevel(mrpt::system::LVL_ERROR);
    if (p.volumetric())
      navigator = std::make_unique<mrpt::nav::CReactiveNavigationSystem3D>(*this, false, false);
    else
      navigator = std::make_unique<mrpt::nav::CReactiveNavigationSystem>(*this, false, false);
    navigator->setMinLoggingLevel(mrpt::system::LVL_ERROR);
    mrpt::config::CConfigFileMemory config(mrptConfig(p));
    // The holonomic method's own tuning: MRPT's defaults. (What is written into a
    // CConfigFileMemory is not read back from it: the text goes through a fresh one.)
    mrpt::nav::CHolonomicFullEval::TOptions().saveToConfigFile(config, "CHolonomicFullEval");
    std::string text;
    config.getContent(text);
    navigator->loadConfigFile(mrpt::config::CConfigFileMemory(text));
    navigator->initialize();
    if (p.planner)
      planner = std::make_unique<GlobalPlanner>(plannerSettings(p));
    // Its delay statistics would be printed at every destruction (the object is not const).
    const_cast<mrpt::system::CTimeLogger&>(navigator->getDelaysTimeLogger()).enable(false);
  }

  bool getCurrentPoseAndSpeeds(mrpt::math::TPose2D& cur_pose, mrpt::math::TTwist2D& cur_velocity,
                               mrpt::system::TTimeStamp& timestamp, mrpt::math::TPose2D& odometry,
                               std::string& frame_id) override
  {
    cur_pose = mrpt::math::TPose2D(pose.x, pose.y, pose.yaw);
    odometry = cur_pose;
    cur_velocity = velocity;
    // Pose and obstacles are of one instant, the step's: MRPT's clock (see useCallersClock).
    timestamp = mrpt::Clock::now();
    frame_id = "map";
    return true;
  }

  bool changeSpeeds(const mrpt::kinematics::CVehicleVelCmd& command) override
  {
    const auto* holo = dynamic_cast<const mrpt::kinematics::CVehicleVelCmd_Holo*>(&command);
    if (holo == nullptr)
      return false;
    speed = holo->vel;
    direction = pose.yaw + holo->dir_local;
    turn_rate = holo->rot_speed;
    return true;
  }

  bool stop(bool /*is_emergency_stop*/) override
  {
    speed = 0.0;
    turn_rate = 0.0;
    return true;
  }

  mrpt::kinematics::CVehicleVelCmd::Ptr getEmergencyStopCmd() override { return getStopCmd(); }
  mrpt::kinematics::CVehicleVelCmd::Ptr getStopCmd() override
  {
    return std::make_shared<mrpt::kinematics::CVehicleVelCmd_Holo>(0.0, 0.0, 0.1, 0.0);
  }

  bool senseObstacles(mrpt::maps::CSimplePointsMap& map, mrpt::system::TTimeStamp& timestamp) override
  {
    map.clear();
    map.reserve(obstacles.size());
    const bool volumetric = parameters.volumetric();
    for (const auto& p : obstacles)
      map.insertPointFast(p.x(), p.y(), volumetric ? p.z() : 0.0f);
    timestamp = mrpt::Clock::now();
    return true;
  }

  // A carrot is only a step on the way: reaching it, or finding it inside an obstacle, is the
  // planner's business at its next plan; the goal's events end the navigation.
  void sendNavigationEndEvent() override
  {
    if (final_target)
      state = NavigationState::Reached;
  }
  void sendWaySeemsBlockedEvent() override { state = NavigationState::Blocked; }
  void sendCannotGetCloserToBlockedTargetEvent() override
  {
    if (final_target)
      state = NavigationState::Blocked;
  }
  void sendNavigationEndDueToErrorEvent() override
  {
    if (final_target)
      state = NavigationState::Blocked;
  }

  // MRPT's timers (the "not approaching the goal" alarm) run on the caller's clock.
  double getNavigationTime() override { return time - timer_start; }
  void resetNavigationTimer() override { timer_start = time; }
};

NavigatorCore::NavigatorCore(const NavigatorParameters& parameters)
{
  parameters.validate();
  impl_ = std::make_unique<Impl>(parameters);
}

NavigatorCore::~NavigatorCore() = default;

void NavigatorCore::setGoal(double x, double y)
{
  if (std::isfinite(impl_->previous_time))
    useCallersClock(impl_->previous_time);
  // MRPT's target is the goal until the first plan (at the next step).
  impl_->final_target = false;
  impl_->aim(Eigen::Vector2d(x, y), true);
  impl_->state = NavigationState::Navigating;
  impl_->goal_x = x;
  impl_->goal_y = y;
  impl_->best_distance = std::numeric_limits<double>::infinity();
  impl_->plan_index = -1;
  impl_->has_path = false;
  impl_->remaining_path = std::nan("");
}

Command NavigatorCore::step(double time, const Pose2& pose, const ObstaclePoints& obstacles,
                            const std::vector<Observation>& observations)
{
  Impl& d = *impl_;
  useCallersClock(time);
  const double dt = time - d.previous_time;
  if (std::isfinite(dt) && dt > 0.0)
    d.velocity = mrpt::math::TTwist2D((pose.x - d.previous_pose.x) / dt, (pose.y - d.previous_pose.y) / dt,
                                      mrpt::math::wrapToPi(pose.yaw - d.previous_pose.yaw) / dt);
  d.previous_pose = pose;
  d.previous_time = time;
  d.time = time;
  d.pose = pose;
  d.obstacles.clear();
  d.self_points = 0;
  d.remembered_points = 0;
  const auto keep = [&d](std::size_t begin, std::size_t end, const ObstaclePoints& points) {
    for (std::size_t i = begin; i < end; ++i)
    {
      if (d.isOwnBody(points[i]))
        ++d.self_points;
      else
        d.obstacles.push_back(points[i]);
    }
  };
  if (observations.empty())
  {
    keep(0, obstacles.size(), obstacles);
    if (d.planner)
      d.markObstacles(time, 0, d.obstacles.size(), nullptr);
  }
  std::size_t next = 0;
  for (const auto& o : observations)
  {
    if (o.begin != next || o.end < o.begin || o.end > obstacles.size())
      throw std::invalid_argument("NavigatorCore::step: observation points [" + std::to_string(o.begin) + ", " +
                                  std::to_string(o.end) + ") do not follow the one before (ending at " +
                                  std::to_string(next) + ") within the " + std::to_string(obstacles.size()) +
                                  " points");
    next = o.end;
  }
  if (!observations.empty() && next != obstacles.size())
    throw std::invalid_argument("NavigatorCore::step: the observations hold " + std::to_string(next) + " of the " +
                                std::to_string(obstacles.size()) + " points");
  for (const auto& o : observations)
  {
    const std::size_t kept = d.obstacles.size();
    keep(o.begin, o.end, obstacles);
    if (d.planner)
      d.markObstacles(time, kept, d.obstacles.size(), &o);
  }
  if (d.parameters.obstacle_memory > 0.0)
    d.remember(time);

  if (d.state == NavigationState::Navigating)
  {
    // Blocked: not kProgress closer to the goal for blocked_timeout; along the path when there is
    // one (going round a table takes the robot farther from the goal for a while), from the
    // newest detour on (a person's trail or a closed door make the planner's way kDetour longer).
    const double previous_path = d.remaining_path;
    d.remaining_path = d.planner ? d.followPath(time) : std::nan("");
    const double distance =
      std::isfinite(d.remaining_path) ? d.remaining_path : std::hypot(d.goal_x - pose.x, d.goal_y - pose.y);
    const bool detour = d.remaining_path > previous_path + kDetour;  // false while either is NaN
    if (distance < d.best_distance - kProgress || !std::isfinite(d.best_distance) || detour)
    {
      d.best_distance = distance;
      d.progress_time = time;
    }
    else if (time - d.progress_time > d.parameters.blocked_timeout)
      d.state = NavigationState::Blocked;
  }
  if (d.state == NavigationState::Navigating)
  {
    d.navigator->navigationStep();
    // An error on the way to a carrot: the next step aims again (blocked_timeout is the limit).
    if (d.navigator->getCurrentState() == mrpt::nav::CAbstractNavigator::NAV_ERROR && d.final_target)
      d.state = NavigationState::Blocked;
  }
  if (d.state != NavigationState::Navigating)
  {
    d.speed = 0.0;
    d.turn_rate = 0.0;
  }
  const double heading = d.direction - pose.yaw;  // the held direction, seen from the robot now
  return Command{ d.speed * std::cos(heading), d.speed * std::sin(heading), d.turn_rate };
}

NavigationState NavigatorCore::state() const
{
  return impl_->state;
}
std::size_t NavigatorCore::lastObstaclePoints() const
{
  return impl_->obstacles.size();
}
std::size_t NavigatorCore::lastSelfPoints() const
{
  return impl_->self_points;
}
std::size_t NavigatorCore::lastRememberedPoints() const
{
  return impl_->remembered_points;
}
double NavigatorCore::remainingPath() const
{
  return impl_->remaining_path;
}
std::size_t NavigatorCore::plannerCells() const
{
  return impl_->planner ? impl_->planner->occupiedCells() : 0;
}
const std::vector<Eigen::Vector2d>& NavigatorCore::plannedPath() const
{
  static const std::vector<Eigen::Vector2d> none;
  return impl_->planner && impl_->has_path ? impl_->planner->path() : none;
}
const NavigatorParameters& NavigatorCore::parameters() const
{
  return impl_->parameters;
}

}  // namespace reactive_navigator
