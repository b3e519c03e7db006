#include "multi_laserscan_merger/stamp_sync.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace multi_laserscan_merger
{

StampSync::StampSync(double window, const std::vector<double>& timeouts) : window_(window), history_(timeouts.size())
{
  for (double t : timeouts)
    timeouts_.push_back(static_cast<std::int64_t>(std::min(t, 1e9) * 1e9));
}

bool StampSync::History::holds(std::int64_t stamp) const
{
  for (std::size_t k = 0; k < count; ++k)
    if (stamps[k] == stamp)
      return true;
  return false;
}

void StampSync::observe(std::size_t source, std::int64_t stamp, double arrival)
{
  History& h = history_[source];
  h.stamps[h.next] = stamp;
  h.arrivals[h.next] = arrival;
  h.next = (h.next + 1) % kHistory;
  h.count = std::min(h.count + 1, kHistory);
}

void StampSync::reset()
{
  for (auto& h : history_)
    h = History();
}

std::int64_t StampSync::period(const History& h) const
{
  std::array<std::int64_t, kHistory> d{};
  std::size_t n = 0;
  // Oldest to newest: slot (next - count + k) for k = 0 .. count-1.
  for (std::size_t k = 1; k < h.count; ++k)
  {
    const std::int64_t a = h.stamps[(h.next + kHistory - h.count + k - 1) % kHistory];
    const std::int64_t b = h.stamps[(h.next + kHistory - h.count + k) % kHistory];
    if (b > a)
      d[n++] = b - a;
  }
  if (n == 0)
    return 0;
  std::nth_element(d.begin(), d.begin() + n / 2, d.begin() + n);
  return d[n / 2];
}

bool StampSync::shareAStamp(const History& a, const History& b) const
{
  for (std::size_t k = 0; k < a.count; ++k)
    if (b.holds(a.stamps[k]))
      return true;
  return false;
}

bool StampSync::dueAt(std::size_t j, std::int64_t stamp) const
{
  const History& h = history_[j];
  if (h.count < 2)
    return false;  // no scans, or no period yet
  const std::int64_t last = h.last();
  if (last >= stamp || stamp - last > timeouts_[j])
    return false;  // already in (or newer), or timed out at the stamp: the merge leaves it out anyway
  const std::int64_t p = period(h);
  // A quarter period: a driver's stamps jitter by far less; a source at another rate of the
  // same clock (20 Hz beside 10 Hz) is half a period (or more) away from the stamps it skips.
  if (p <= 0 || std::llabs(last + p - stamp) * 4 > p)
    return false;
  for (std::size_t k = 0; k < history_.size(); ++k)
    if (k != j && history_[k].holds(stamp) && shareAStamp(h, history_[k]))
      return true;
  return false;
}

void StampSync::decide(std::int64_t stamp, double now, Decision& out) const
{
  out.due.clear();
  out.publish = true;
  out.deadline = now;
  if (window_ <= 0.0)
    return;
  for (std::size_t j = 0; j < history_.size(); ++j)
    if (dueAt(j, stamp))
      out.due.push_back(j);
  if (out.due.empty())
    return;
  double first = std::numeric_limits<double>::infinity();
  for (const auto& h : history_)
    for (std::size_t k = 0; k < h.count; ++k)
      if (h.stamps[k] == stamp)
        first = std::min(first, h.arrivals[k]);
  if (!std::isfinite(first))
    first = now;  // nobody sent the stamp (cannot happen in the merger): wait one window from now
  out.deadline = first + window_;
  out.publish = now >= out.deadline;
}

}  // namespace multi_laserscan_merger
