// The error every node of the toolbox raises for a bad parameter, so that users, check_config
// and the Python bindings all see which parameter is wrong and why. ROS-free (plain C++17).
#pragma once

#include <stdexcept>
#include <string>

namespace laserscan_common
{

/// Thrown when a parameter is invalid; what() is "<parameter>: <reason>".
class ParameterError : public std::invalid_argument
{
public:
  ParameterError(const std::string& parameter, const std::string& reason)
    : std::invalid_argument(parameter + ": " + reason), parameter_(parameter), reason_(reason)
  {}
  const std::string& parameter() const { return parameter_; }
  const std::string& reason() const { return reason_; }

private:
  std::string parameter_;
  std::string reason_;
};

}  // namespace laserscan_common
