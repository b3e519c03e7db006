// Nodelet wrapper: the work is done by ReactiveNavigatorRos.
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include "reactive_navigator/reactive_navigator_ros.hpp"

namespace reactive_navigator
{

class ReactiveNavigatorNodelet : public nodelet::Nodelet
{
private:
  void onInit() override
  {
    try
    {
      impl_ = std::make_unique<ReactiveNavigatorRos>(getNodeHandle(), getPrivateNodeHandle());
    }
    catch (const ParameterError& e)
    {
      // Bad configuration: say which parameter and why, and do nothing else.
      NODELET_FATAL("bad configuration, not navigating: parameter '%s': %s", e.parameter().c_str(), e.reason().c_str());
    }
  }

  std::unique_ptr<ReactiveNavigatorRos> impl_;
};

}  // namespace reactive_navigator

PLUGINLIB_EXPORT_CLASS(reactive_navigator::ReactiveNavigatorNodelet, nodelet::Nodelet)
