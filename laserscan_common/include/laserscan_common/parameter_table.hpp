// The one description of a node's parameters: each parameter struct has a function
// visitFields(params, visit) that calls visit(member, ParamInfo) once per field, in the order of
// the README table. The member gives the type and (in a default-constructed struct) the default;
// the ParamInfo gives the name the YAML spells, the unit, the limits and the meaning. The ROS
// readers, the pybind11 modules, the limit check every validate() starts with (checkLimits) and
// the export that check_config's schema and the README tables are generated from all walk these
// functions, so a parameter and its limits are declared once. ROS-free.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "laserscan_common/parameter_error.hpp"
#include "laserscan_common/scan_geometry.hpp"

namespace laserscan_common
{
/// A list of [x, y] points (a polygon parameter such as the merger's footprint).
using Polygon = std::vector<std::array<double, 2>>;

/// A parameter's table line beside its value. Its limits are the check (limitFault, checkLimits)
/// and check_config's schema (the export); validate() adds only the rules between fields.
struct ParamInfo
{
  ParamInfo(const char* name_, const char* unit_, const char* meaning_) : name(name_), unit(unit_), meaning(meaning_) {}

  const char* name;
  const char* unit;
  const char* meaning;
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;           ///< lo itself is refused
  bool finite = false;            ///< +-inf is refused too
  bool nonempty = false;          ///< a string: not ""; a polygon: not [] (else [] is allowed: none)
  bool frame_id = false;          ///< a string: a tf2 frame id (no leading '/')
  double angle = 0.0;             ///< > 0: an angle within [-angle, angle] (+ the nodes' 1e-6 tolerance)
  const char* default_text = "";  ///< the README's default when the value alone does not say it

  ParamInfo atLeast(double v) const
  {
    return with([v](ParamInfo& p) { p.lo = v; });
  }
  ParamInfo above(double v) const
  {
    return with([v](ParamInfo& p) { p.lo = v, p.lo_open = true; });
  }
  ParamInfo atMost(double v) const
  {
    return with([v](ParamInfo& p) { p.hi = v; });
  }
  ParamInfo finiteOnly() const
  {
    return with([](ParamInfo& p) { p.finite = true; });
  }
  ParamInfo nonEmpty() const
  {
    return with([](ParamInfo& p) { p.nonempty = true; });
  }
  ParamInfo frameId() const
  {
    return with([](ParamInfo& p) { p.frame_id = true; });
  }
  ParamInfo angleWithin(double a) const
  {
    return with([a](ParamInfo& p) { p.angle = a; });
  }
  ParamInfo shownAs(const char* text) const
  {
    return with([text](ParamInfo& p) { p.default_text = text; });
  }

private:
  template <class F>
  ParamInfo with(F f) const
  {
    ParamInfo p = *this;
    f(p);
    return p;
  }
};

/// The type names of the export and the README tables (a struct with a field of another type
/// declares its typeName beside it).
inline const char* typeName(const bool&)
{
  return "bool";
}
inline const char* typeName(const int&)
{
  return "int";
}
inline const char* typeName(const double&)
{
  return "double";
}
inline const char* typeName(const std::string&)
{
  return "string";
}
inline const char* typeName(const Polygon&)
{
  return "polygon";
}
inline const char* typeName(const std::vector<std::string>&)
{
  return "string list";
}

/// A limit as the reasons write it: %g, and pi or 2 pi for those (the nodes' 1e-6 above them).
inline std::string limitText(double v)
{
  for (const auto& [multiple, text] : { std::pair<double, const char*>{ 1.0, "pi" }, { 2.0, "2 pi" } })
    if (std::fabs(std::fabs(v) - multiple * kPi) <= 2e-6)
      return (v < 0.0 ? "-" : "") + std::string(text);
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", v);
  return buffer;
}

/// Why `value` breaks its table line's limits, "" when it does not. The one wording of the nodes
/// and check_config (config_check.py's check_value writes the same; the agreement test compares):
/// "must not be NaN", "must be finite, got inf", "must be within [-2 pi, 2 pi] rad, got 7",
/// "must be > 0 s, got 0", "must not be empty", ...
inline std::string limitFault(double value, const ParamInfo& info)
{
  const std::string unit = *info.unit ? std::string(" ") + info.unit : "";
  const std::string got = ", got " + limitText(value);
  if (std::isnan(value))
    return "must not be NaN";
  if ((info.finite || info.angle > 0.0) && !std::isfinite(value))
    return "must be finite" + got;
  if (info.angle > 0.0)
    return std::fabs(value) <= info.angle + 1e-6
             ? ""
             : "must be within [" + limitText(-info.angle) + ", " + limitText(info.angle) + "]" + unit + got;
  const bool has_lo = info.lo > -std::numeric_limits<double>::infinity();
  const bool has_hi = info.hi < std::numeric_limits<double>::infinity();
  const bool above_lo = info.lo_open ? value > info.lo : value >= info.lo;
  if (above_lo && value <= info.hi)
    return "";
  if (has_lo && has_hi)
    return "must be within " + std::string(info.lo_open ? "(" : "[") + limitText(info.lo) + ", " + limitText(info.hi) +
           "]" + unit + got;
  if (has_lo)
    return std::string(info.lo_open ? "must be > " : "must be >= ") + limitText(info.lo) + unit + got;
  return "must be <= " + limitText(info.hi) + unit + got;
}
inline std::string limitFault(int value, const ParamInfo& info)
{
  return limitFault(static_cast<double>(value), info);
}
inline std::string limitFault(const std::string& value, const ParamInfo& info)
{
  if (info.nonempty && value.empty())
    return "must not be empty";
  if (info.frame_id && !value.empty() && value.front() == '/')
    return "must not start with '/' (tf2 frame ids have none)";
  return "";
}
inline std::string limitFault(const Polygon& value, const ParamInfo& info)
{
  for (std::size_t i = 0; i < value.size(); ++i)
    if (!std::isfinite(value[i][0]) || !std::isfinite(value[i][1]))
      return "point " + std::to_string(i) + " is not finite";
  if (value.size() < 3 && (info.nonempty || !value.empty()))
    return std::string(info.nonempty ? "needs at least 3 [x, y] points" : "needs none or at least 3 [x, y] points") +
           ", got " + std::to_string(value.size());
  return "";
}
/// Fields without limits (bool, lists, a struct's own types).
template <class T>
std::string limitFault(const T&, const ParamInfo&)
{
  return "";
}

/// Throws ParameterError(prefix + name, reason) for the first field of the table whose value
/// breaks its limits: the start of every validate(), which then checks only the rules between
/// fields. `prefix` names a dictionary entry ("sources[1].", "self_filter/").
template <class P>
void checkLimits(const P& params, const std::string& prefix = "")
{
  visitFields(params, [&prefix](const auto& value, const ParamInfo& info) {
    const std::string fault = limitFault(value, info);
    if (!fault.empty())
      throw ParameterError(prefix + info.name, fault);
  });
}

/// The names a visitFields function lists, in order.
template <class P>
std::vector<std::string> fieldNames(const P& params)
{
  std::vector<std::string> names;
  visitFields(params, [&names](const auto&, const ParamInfo& info) { names.emplace_back(info.name); });
  return names;
}

/// How alike two names are: 2 * (longest common subsequence) / (sum of lengths), in [0, 1]
/// (close to Python's difflib ratio, which check_config uses).
inline double nameSimilarity(const std::string& a, const std::string& b)
{
  if (a.empty() && b.empty())
    return 1.0;
  std::vector<std::size_t> row(b.size() + 1, 0), previous(b.size() + 1, 0);
  for (char ca : a)
  {
    for (std::size_t j = 0; j < b.size(); ++j)
      row[j + 1] = ca == b[j] ? previous[j] + 1 : std::max(row[j], previous[j + 1]);
    std::swap(row, previous);
  }
  return 2.0 * static_cast<double>(previous[b.size()]) / static_cast<double>(a.size() + b.size());
}

/// The known name most like `name` ("" when none is alike enough: similarity < 0.6, difflib's
/// cutoff).
inline std::string closestName(const std::string& name, const std::vector<std::string>& known)
{
  std::string best;
  double best_score = 0.6;
  for (const std::string& candidate : known)
  {
    const double score = nameSimilarity(name, candidate);
    if (score >= best_score)
    {
      best = candidate;
      best_score = score + 1e-12;  // the first of equally close names
    }
  }
  return best;
}

}  // namespace laserscan_common
