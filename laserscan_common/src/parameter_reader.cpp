#include "laserscan_common/parameter_reader.hpp"

#include "laserscan_common/node_log.hpp"

#include <cmath>
#include <limits>

namespace laserscan_common
{
namespace
{
using XmlRpc::XmlRpcValue;

bool isNumber(const XmlRpcValue& v)
{
  return v.getType() == XmlRpcValue::TypeDouble || v.getType() == XmlRpcValue::TypeInt;
}

double toDouble(XmlRpcValue& v)
{
  return v.getType() == XmlRpcValue::TypeInt ? static_cast<double>(static_cast<int>(v)) : static_cast<double>(v);
}
}  // namespace

void fromXmlRpc(XmlRpcValue& value, const std::string& name, bool& out)
{
  if (value.getType() != XmlRpcValue::TypeBoolean)
    throw ParameterError(name, "must be true or false");
  out = static_cast<bool>(value);
}

void fromXmlRpc(XmlRpcValue& value, const std::string& name, int& out)
{
  if (value.getType() == XmlRpcValue::TypeInt)
  {
    out = static_cast<int>(value);
    return;
  }
  const double v = isNumber(value) ? toDouble(value) : std::nan("");
  if (!(std::floor(v) == v && std::fabs(v) <= static_cast<double>(std::numeric_limits<int>::max())))
    throw ParameterError(name, "must be a whole number");
  out = static_cast<int>(v);
}

void fromXmlRpc(XmlRpcValue& value, const std::string& name, double& out)
{
  if (!isNumber(value))
    throw ParameterError(name, "must be a number");
  out = toDouble(value);
}

void fromXmlRpc(XmlRpcValue& value, const std::string& name, std::string& out)
{
  if (value.getType() != XmlRpcValue::TypeString)
    throw ParameterError(name, "must be a string");
  out = static_cast<std::string>(value);
}

void fromXmlRpc(XmlRpcValue& value, const std::string& name, std::vector<std::string>& out)
{
  if (value.getType() != XmlRpcValue::TypeArray)
    throw ParameterError(name, "must be a list of strings");
  out.clear();
  for (int i = 0; i < value.size(); ++i)
  {
    out.emplace_back();
    fromXmlRpc(value[i], name + "[" + std::to_string(i) + "]", out.back());
  }
}

void fromXmlRpc(XmlRpcValue& value, const std::string& name, Polygon& out)
{
  if (value.getType() != XmlRpcValue::TypeArray)
    throw ParameterError(name, "must be a list of [x, y] points");
  out.clear();
  for (int i = 0; i < value.size(); ++i)
  {
    XmlRpcValue& p = value[i];
    if (p.getType() != XmlRpcValue::TypeArray || p.size() != 2 || !isNumber(p[0]) || !isNumber(p[1]))
      throw ParameterError(name, "point " + std::to_string(i) + " is not a pair of numbers [x, y]");
    out.push_back({ toDouble(p[0]), toDouble(p[1]) });
  }
}

bool ParameterReader::readRaw(const std::string& name, XmlRpcValue& value)
{
  known_.insert(name);
  return nh_.getParam(name, value);
}

std::vector<std::pair<std::string, std::string>> ParameterReader::unknown() const
{
  std::vector<std::pair<std::string, std::string>> out;
  std::vector<std::string> all;
  if (!nh_.getParamNames(all))
    return out;
  const std::string prefix = nh_.getNamespace() + "/";
  const std::vector<std::string> known(known_.begin(), known_.end());
  std::set<std::string> seen;
  for (const std::string& full : all)
  {
    if (full.compare(0, prefix.size(), prefix) != 0)
      continue;
    const std::string name = full.substr(prefix.size(), full.find('/', prefix.size()) - prefix.size());
    if (known_.count(name) == 0 && seen.insert(name).second)
      out.emplace_back(name, closestName(name, known));
  }
  return out;
}

void ParameterReader::warnUnknown() const
{
  for (const auto& [name, close] : unknown())
  {
    const std::string hint = close.empty() ? "" : " (did you mean '" + close + "'?)";
    NODE_WARN(nh_.getNamespace(), "unknown parameter '%s'%s, ignored", name.c_str(), hint.c_str());
  }
}

}  // namespace laserscan_common
