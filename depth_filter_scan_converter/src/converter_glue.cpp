#include "depth_filter_scan_converter/converter_glue.hpp"

namespace depth_filter_scan_converter
{
void summarize(diagnostic_updater::DiagnosticStatusWrapper& status, const std::string& problem, bool subscribed,
               double rate, const std::string& nothing_arrives)
{
  if (!problem.empty())
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, problem);
  else if (subscribed && rate == 0.0)
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, nothing_arrives);
  else
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, subscribed ? "converting" : "idle (nobody listens)");
}

}  // namespace depth_filter_scan_converter
