// The one strict reader of every node's private parameters. A parameter that is set must have
// its type (a wrong type is a ParameterError naming it, never a silent default), by one rule for
// numbers: a number is a number, so a double parameter takes 2 as 2.0 and an int parameter takes
// 2.0 as 2, but never 2.5. Every name read is remembered: warnUnknown() then names, once at
// start-up, each private parameter that nothing read, with the closest known name (a typo).
#pragma once

#include <algorithm>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <ros/ros.h>

#include "laserscan_common/parameter_error.hpp"
#include "laserscan_common/parameter_table.hpp"

namespace laserscan_common
{
/// Converts one value by the rule above; throws ParameterError(name, "must be ...").
void fromXmlRpc(XmlRpc::XmlRpcValue& value, const std::string& name, bool& out);
void fromXmlRpc(XmlRpc::XmlRpcValue& value, const std::string& name, int& out);
void fromXmlRpc(XmlRpc::XmlRpcValue& value, const std::string& name, double& out);
void fromXmlRpc(XmlRpc::XmlRpcValue& value, const std::string& name, std::string& out);
void fromXmlRpc(XmlRpc::XmlRpcValue& value, const std::string& name, std::vector<std::string>& out);
void fromXmlRpc(XmlRpc::XmlRpcValue& value, const std::string& name, Polygon& out);

/// Refuses a key of a dictionary parameter (a merger source, the self_filter block) that is not a
/// field of `P`'s table: a ParameterError "<prefix><key>: unknown key", with the closest field
/// named. `prefix` ends with its separator ("sources[1].", "self_filter/").
template <class P>
void refuseUnknownKeys(XmlRpc::XmlRpcValue& dict, const std::string& prefix, const P& params)
{
  const std::vector<std::string> known = fieldNames(params);
  for (auto& kv : dict)
    if (std::find(known.begin(), known.end(), kv.first) == known.end())
    {
      const std::string close = closestName(kv.first, known);
      throw ParameterError(prefix + kv.first,
                           close.empty() ? "unknown key" : "unknown key (did you mean '" + close + "'?)");
    }
}

/// Reads the fields of a dictionary parameter by `P`'s table: every key must be a field
/// (refuseUnknownKeys), every field present must have its type.
template <class P>
void readDictionary(XmlRpc::XmlRpcValue& dict, const std::string& prefix, P& params)
{
  refuseUnknownKeys(dict, prefix, params);
  visitFields(params, [&dict, &prefix](auto& value, const ParamInfo& info) {
    if (dict.hasMember(info.name))
      fromXmlRpc(dict[info.name], prefix + info.name, value);
  });
}

/// A node's private parameters, read strictly.
class ParameterReader
{
public:
  explicit ParameterReader(const ros::NodeHandle& private_nh) : nh_(private_nh) {}

  /// Reads `name` into `value` when it is set (else `value` keeps its default).
  template <class T>
  void read(const std::string& name, T& value)
  {
    XmlRpc::XmlRpcValue raw;
    if (readRaw(name, raw))
      fromXmlRpc(raw, name, value);
  }

  /// Every field of a struct's table (visitFields).
  template <class P>
  void readFields(P& params)
  {
    visitFields(params, [this](auto& value, const ParamInfo& info) { read(info.name, value); });
  }

  /// The raw value of a structured parameter (false when it is not set); `name` becomes known.
  bool readRaw(const std::string& name, XmlRpc::XmlRpcValue& value);

  /// (name, closest known name or "") of every parameter of the private namespace that no read
  /// asked for; a nested one (a/b) by its first part.
  std::vector<std::pair<std::string, std::string>> unknown() const;

  /// One warning per unknown parameter: "<node>: unknown parameter 'x' (did you mean 'y'?),
  /// ignored". Call once, after every read.
  void warnUnknown() const;

  const ros::NodeHandle& nodeHandle() const { return nh_; }

private:
  ros::NodeHandle nh_;
  std::set<std::string> known_;
};

}  // namespace laserscan_common
