// The one description of a node's parameters: each parameter struct has a function
// visitFields(params, visit) that calls visit(member, ParamInfo) once per field, in the order of
// the README table. The member gives the type and (in a default-constructed struct) the default;
// the ParamInfo gives the name the YAML spells, the unit, the limits and the meaning. The ROS
// readers, the pybind11 modules and the export that check_config's schema and the README tables
// are generated from all walk these functions, so a parameter is declared once. ROS-free.
#pragma once

#include <algorithm>
#include <array>
#include <limits>
#include <string>
#include <vector>

namespace laserscan_common
{
/// A list of [x, y] points (a polygon parameter such as the merger's footprint).
using Polygon = std::vector<std::array<double, 2>>;

/// A parameter's table line beside its value. The limits are those of check_config's schema; the
/// struct's validate() is the authority (the agreement tests tie the two together).
struct ParamInfo
{
  ParamInfo(const char* name_, const char* unit_, const char* meaning_) : name(name_), unit(unit_), meaning(meaning_) {}

  const char* name;
  const char* unit;
  const char* meaning;
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;  ///< lo itself is refused
  bool finite = false;   ///< +-inf is refused too
  bool nonempty = false;
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

/// The type names of the export and the README tables.
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
