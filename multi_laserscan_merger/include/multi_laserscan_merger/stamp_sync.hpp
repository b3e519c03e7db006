// When may the output at a stamp be published (sync_window)? Several set-ups publish the scans
// of one instant with ONE stamp from several sources (lidars triggered together, a multi-head
// driver, two converters on one camera, a simulator's sensors updated in one step). Published at
// the first of them, the output at that stamp would hold the others' previous scans, and no
// output would ever hold all the scans of that instant. StampSync says which sources' scans are
// still due at a stamp and until when it is worth waiting for them. ROS-free.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <limits>
#include <utility>
#include <vector>

namespace multi_laserscan_merger
{

class StampSync
{
public:
  /// Stamps kept per source: enough to see a shared stamp at rates 1:7 apart (8 Hz and 56 Hz)
  /// and to estimate the period robustly (median of 7 differences).
  static constexpr std::size_t kHistory = 8;

  /// window: sync_window (s), 0 = never wait (one output at the first scan of a stamp).
  /// timeouts: each source's timeout (s), in the order of the sources.
  StampSync(double window, const std::vector<double>& timeouts);

  /// A scan of `source` stamped `stamp` (ns, compared exactly) was accepted for merging at
  /// `arrival` (s, any monotonic clock, the same as decide()'s `now`).
  void observe(std::size_t source, std::int64_t stamp, double arrival);
  /// Forgets every stamp (the timeline changed: bag loop, clock jump).
  void reset();

  struct Decision
  {
    bool publish = true;    ///< the output at the stamp may be published now
    double deadline = 0.0;  ///< when not: publish at this time at the latest (s, decide()'s clock)
    /// Sources whose scan of the stamp is due and not in: waited for (publish false), or missing
    /// from the output (publish true at the deadline).
    std::vector<std::size_t> due;
  };

  /// At `now`: may the output stamped `stamp` be published? A source j is due at the stamp when
  /// (1) it shared a stamp exactly with a source that sent this one (they are in step: one
  /// clock or trigger), (2) its own stamps predict this one: last + period (median of its
  /// differences) within a quarter period of it, (3) its last scan is older than the stamp and
  /// not timed out at it. A source with fewer than two scans, a dead one (its next stamp is long
  /// past) and one on another phase are never due. Wait until the first scan of the stamp
  /// arrived + window, never longer. `out` is reused (no allocation once grown).
  void decide(std::int64_t stamp, double now, Decision& out) const;

private:
  struct History
  {
    std::array<std::int64_t, kHistory> stamps{};
    std::array<double, kHistory> arrivals{};
    std::size_t count = 0;  ///< entries in use (<= kHistory)
    std::size_t next = 0;   ///< slot of the next entry
    std::int64_t last() const { return stamps[(next + kHistory - 1) % kHistory]; }
    bool holds(std::int64_t stamp) const;
  };
  bool dueAt(std::size_t source, std::int64_t stamp) const;
  /// Median of the positive differences of consecutive stamps; 0 when none.
  std::int64_t period(const History& h) const;
  bool shareAStamp(const History& a, const History& b) const;

  double window_;
  std::vector<std::int64_t> timeouts_;  ///< ns
  std::vector<History> history_;
};

/// The publish policy of publish_rate 0 around StampSync: one output for every scan newer than
/// the last output, stamped with the newest stamp held, published once every scan due at that
/// stamp is in or its window ended. A scan newer than an output still waiting is held back until
/// that output is out: the output never holds a scan newer than its stamp, a scan due at it
/// still completes it, and outputs keep increasing stamps (each one published once). With
/// publish_rate > 0 (`every_scan` false) scans go straight into the merge and each timer tick
/// asks tick(). Either way this class alone decides when an output is published (handlers
/// `wait` and `publish`). Payload is the caller's scan (the ROS message and its mount).
template <class Payload>
class SyncedOutputs
{
public:
  struct Handlers
  {
    /// Put a source's scan into the merge (it replaces the one the source had there).
    std::function<void(std::size_t source, const Payload& scan)> merge;
    /// The output at `stamp` waits for `decision.due` until `decision.deadline`: call expire() then.
    std::function<void(std::int64_t stamp, const StampSync::Decision& decision)> wait;
    /// Merge and publish at `stamp`; `decision.due` lists the sources missing at the window's end,
    /// `waited` whether the output waited for any.
    std::function<void(std::int64_t stamp, const StampSync::Decision& decision, bool waited)> publish;
  };

  SyncedOutputs(double window, const std::vector<double>& timeouts, bool every_scan, Handlers handlers)
    : sync_(window, timeouts), every_scan_(every_scan), handlers_(std::move(handlers)), newest_(timeouts.size(), kNone)
  {}

  /// A usable scan of `source` stamped `stamp` (ns) arrived at `arrival` (s, the clock of `now`).
  /// Ignored when older than the scan the source has in the merge (not newer information).
  void add(std::size_t source, std::int64_t stamp, double arrival, Payload scan, double now)
  {
    if (every_scan_ && waiting_ && stamp > waiting_stamp_)
    {
      held_.push_back(Held{ source, stamp, arrival, std::move(scan) });
      return;
    }
    admit(source, stamp, arrival, scan, now);
    release(now);
  }

  /// The waiting output's deadline passed: publish it with what is in, then what was held back.
  void expire(double now)
  {
    if (!waiting_ || now < decision_.deadline)
      return;
    publishNow(waiting_stamp_, true, now);
    release(now);
  }

  /// publish_rate > 0: a tick (or, while one waits, a new scan or the end of its window:
  /// `at_deadline`) with the newest data stamped `stamp` (ns). Publishes at it unless nothing is
  /// in the merge or it is not newer than the last output; while scans of the newest scan's stamp
  /// are due within the window the tick waits for them (handler `wait` once, deadline() until
  /// when), never past the window's end.
  void tick(std::int64_t stamp, double now, bool at_deadline)
  {
    const std::int64_t newest = newestStamp();
    if (newest == kNone || (last_published_ != kNone && stamp <= last_published_))
    {
      waiting_ = false;
      return;
    }
    sync_.decide(newest, now, decision_);
    if (!decision_.publish && !at_deadline)
    {
      if (!waiting_)
      {
        waiting_ = true;
        waiting_stamp_ = stamp;
        tick_deadline_ = decision_.deadline;
        handlers_.wait(stamp, decision_);
      }
      return;
    }
    const bool waited = waiting_;
    waiting_ = false;
    last_published_ = stamp;
    handlers_.publish(stamp, decision_, waited);
  }

  /// Forget the timeline (bag loop, clock jump): held scans, the waiting output, the last one.
  void reset()
  {
    sync_.reset();
    held_.clear();
    waiting_ = false;
    last_published_ = kNone;
    std::fill(newest_.begin(), newest_.end(), kNone);
  }

  bool waiting() const { return waiting_; }
  /// Until when the waiting output (or tick) waits.
  double deadline() const { return every_scan_ ? decision_.deadline : tick_deadline_; }
  std::int64_t newestStamp() const
  {
    std::int64_t t = kNone;
    for (std::int64_t s : newest_)
      t = std::max(t, s);
    return t;
  }
  static constexpr std::int64_t kNone = std::numeric_limits<std::int64_t>::min();

private:
  struct Held
  {
    std::size_t source;
    std::int64_t stamp;
    double arrival;
    Payload scan;
  };

  void admit(std::size_t source, std::int64_t stamp, double arrival, const Payload& scan, double now)
  {
    if (newest_[source] != kNone && stamp < newest_[source])
      return;
    newest_[source] = stamp;
    sync_.observe(source, stamp, arrival);
    handlers_.merge(source, scan);
    if (!every_scan_)
      return;
    const std::int64_t t = newestStamp();
    if (last_published_ != kNone && t <= last_published_)
      return;  // older than the last output (a sensor a little behind): it goes into the next one
    sync_.decide(t, now, decision_);
    if (decision_.publish)
      publishNow(t, false, now);
    else if (!waiting_)
    {
      waiting_ = true;
      waiting_stamp_ = t;
      handlers_.wait(t, decision_);
    }
  }

  void publishNow(std::int64_t stamp, bool at_deadline, double now)
  {
    if (at_deadline)
      sync_.decide(stamp, std::max(now, decision_.deadline), decision_);
    const bool waited = waiting_;
    waiting_ = false;
    last_published_ = stamp;
    handlers_.publish(stamp, decision_, waited);
  }

  /// Admits the held scans in their order of arrival; while an output waits, only those not
  /// newer than it (a scan of its stamp held behind a newer one completes it). The queue holds
  /// the scans of one window: a few, so starting over after each admission is cheap.
  void release(double now)
  {
    for (auto it = held_.begin(); it != held_.end();)
    {
      if (waiting_ && it->stamp > waiting_stamp_)
      {
        ++it;
        continue;
      }
      Held h = std::move(*it);
      held_.erase(it);
      admit(h.source, h.stamp, h.arrival, h.scan, now);
      it = held_.begin();
    }
  }

  StampSync sync_;
  bool every_scan_;
  Handlers handlers_;
  std::vector<std::int64_t> newest_;  ///< stamp of each source's scan in the merge
  std::deque<Held> held_;
  bool waiting_ = false;
  std::int64_t waiting_stamp_ = 0;
  std::int64_t last_published_ = kNone;
  double tick_deadline_ = 0.0;  ///< publish_rate > 0: the end of the window the waiting tick opened
  StampSync::Decision decision_;
};

}  // namespace multi_laserscan_merger
