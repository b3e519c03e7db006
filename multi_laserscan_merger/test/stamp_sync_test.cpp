// gtest of the publish decision for sources that share stamps (sync_window, stamp_sync.hpp):
// scans are played by their arrival time on a simulated clock, the window's timer fires at its
// deadline, and every output records which scan of each source it held.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include "multi_laserscan_merger/stamp_sync.hpp"

using namespace multi_laserscan_merger;

namespace
{
constexpr std::int64_t kSecond = 1000000000;
constexpr std::int64_t kStart = 1700000000LL * kSecond;

struct Arrival
{
  double time;  ///< s
  std::size_t source;
  std::int64_t stamp;
};

struct Output
{
  std::int64_t stamp;
  double time;                       ///< when published
  std::vector<std::int64_t> held;    ///< stamp of each source's scan in it (-1: none)
  std::vector<std::size_t> missing;  ///< due at the window's end and not in
  bool waited;
};

/// Plays arrivals (sorted here by time) through SyncedOutputs; the timer fires at the deadline.
std::vector<Output> play(std::vector<Arrival> arrivals, std::size_t n_sources, double window,
                         std::vector<double> timeouts = {})
{
  if (timeouts.empty())
    timeouts.assign(n_sources, 1.0);
  std::stable_sort(arrivals.begin(), arrivals.end(),
                   [](const Arrival& a, const Arrival& b) { return a.time < b.time; });
  std::vector<std::int64_t> slot(n_sources, -1);
  std::vector<Output> out;
  double clock = 0.0;
  SyncedOutputs<std::int64_t>::Handlers h;
  h.merge = [&](std::size_t s, const std::int64_t& stamp) { slot[s] = stamp; };
  h.wait = [&](std::int64_t, const StampSync::Decision& d) { EXPECT_FALSE(d.due.empty()); };
  h.publish = [&](std::int64_t stamp, const StampSync::Decision& d, bool waited) {
    out.push_back(Output{ stamp, clock, slot, d.due, waited });
  };
  SyncedOutputs<std::int64_t> outputs(window, timeouts, true, h);
  for (const auto& a : arrivals)
  {
    if (outputs.waiting() && outputs.deadline() <= a.time)
    {
      clock = outputs.deadline();
      outputs.expire(clock);
    }
    clock = a.time;
    outputs.add(a.source, a.stamp, a.time, a.stamp, a.time);
  }
  if (outputs.waiting())
  {
    clock = outputs.deadline();
    outputs.expire(clock);
  }
  return out;
}

/// n sources at `rate` Hz sending one stamp per frame, each scan arriving `delay` + a uniform
/// jitter in [0, jitter] after the stamp (seeded).
std::vector<Arrival> sharedStamps(std::size_t n, double rate, int frames, double delay, double jitter,
                                  std::size_t first_source = 0, unsigned seed = 1)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, jitter);
  std::vector<Arrival> a;
  const std::int64_t period = static_cast<std::int64_t>(kSecond / rate);
  for (int f = 0; f < frames; ++f)
    for (std::size_t s = 0; s < n; ++s)
    {
      const std::int64_t stamp = kStart + f * period;
      a.push_back({ f / rate + delay + u(rng), first_source + s, stamp });
    }
  return a;
}

/// The outputs of publish_rate 0 without sync_window (the merger before it): an output at every
/// scan that makes the newest stamp held newer than the last output.
std::vector<std::int64_t> withoutWindow(std::vector<Arrival> arrivals, std::size_t n_sources)
{
  std::stable_sort(arrivals.begin(), arrivals.end(),
                   [](const Arrival& a, const Arrival& b) { return a.time < b.time; });
  std::vector<std::int64_t> slot(n_sources, -1), out;
  for (const auto& a : arrivals)
  {
    if (a.stamp < slot[a.source])
      continue;
    slot[a.source] = a.stamp;
    const std::int64_t t = *std::max_element(slot.begin(), slot.end());
    if (out.empty() || t > out.back())
      out.push_back(t);
  }
  return out;
}

/// The source sends nothing stamped `stop` or later.
void stopSource(std::vector<Arrival>& arrivals, std::size_t source, std::int64_t stop)
{
  arrivals.erase(std::remove_if(arrivals.begin(), arrivals.end(),
                                [&](const Arrival& a) { return a.source == source && a.stamp >= stop; }),
                 arrivals.end());
}

void expectIncreasing(const std::vector<Output>& out)
{
  for (std::size_t k = 1; k < out.size(); ++k)
    EXPECT_GT(out[k].stamp, out[k - 1].stamp) << "output " << k << ": a stamp repeated or went back";
}

/// First arrival of each stamp.
std::map<std::int64_t, double> firstArrivals(const std::vector<Arrival>& arrivals)
{
  std::map<std::int64_t, double> first;
  for (const auto& a : arrivals)
  {
    auto it = first.find(a.stamp);
    if (it == first.end() || a.time < it->second)
      first[a.stamp] = a.time;
  }
  return first;
}
}  // namespace

// 2-4 sources with one stamp per frame at 10-40 Hz, arrival jitter within the window: every
// output at T holds every source's scan of T, each T once, within the window of its first scan.
TEST(SyncWindow, EveryOutputOfASharedStampIsComplete)
{
  for (std::size_t n : { 2u, 3u, 4u })
    for (double rate : { 10.0, 20.0, 40.0 })
    {
      SCOPED_TRACE(std::to_string(n) + " sources at " + std::to_string(rate) + " Hz");
      const auto arrivals = sharedStamps(n, rate, 80, 0.02, 0.008, 0, static_cast<unsigned>(n * 100 + rate));
      const auto out = play(arrivals, n, 0.01);
      const auto first = firstArrivals(arrivals);
      ASSERT_EQ(out.size(), 80u);
      expectIncreasing(out);
      // The first two frames give no period yet: they are published at their first scan.
      EXPECT_FALSE(out[0].waited);
      EXPECT_FALSE(out[1].waited);
      for (std::size_t k = 2; k < out.size(); ++k)
      {
        const Output& o = out[k];
        for (std::size_t s = 0; s < n; ++s)
          EXPECT_EQ(o.held[s], o.stamp) << "source " << s << " missing from the output at " << o.stamp;
        EXPECT_TRUE(o.missing.empty());
        EXPECT_TRUE(o.waited);
        EXPECT_LE(o.time, first.at(o.stamp) + 0.01 + 1e-12);
      }
    }
}

// The same arrivals without a window (sync_window 0) give today's outputs exactly: each at the
// first scan of its stamp, holding the other sources' previous scans.
TEST(SyncWindow, ZeroIsThePreviousBehaviour)
{
  const auto arrivals = sharedStamps(3, 20.0, 40, 0.02, 0.008);
  const auto out = play(arrivals, 3, 0.0);
  const auto expected = withoutWindow(arrivals, 3);
  ASSERT_EQ(out.size(), expected.size());
  std::size_t incomplete = 0;
  for (std::size_t k = 0; k < out.size(); ++k)
  {
    EXPECT_EQ(out[k].stamp, expected[k]);
    EXPECT_FALSE(out[k].waited);
    incomplete +=
      std::count_if(out[k].held.begin(), out[k].held.end(), [&](std::int64_t s) { return s != out[k].stamp; }) > 0;
  }
  EXPECT_GT(incomplete, 35u);  // the problem the window solves
}

// A source that stops delays one output by the window (its scan was due), then nothing.
TEST(SyncWindow, ADeadSourceDelaysNothingBeyondTheBound)
{
  auto arrivals = sharedStamps(3, 20.0, 40, 0.02, 0.004);
  const std::int64_t stop = kStart + 20 * (kSecond / 20);
  stopSource(arrivals, 2, stop);
  const auto first = firstArrivals(arrivals);
  std::map<std::int64_t, double> last_live;  // last arrival of the live sources' scans of each stamp
  for (const auto& a : arrivals)
    if (a.source != 2)
      last_live[a.stamp] = std::max(last_live[a.stamp], a.time);
  const auto out = play(arrivals, 3, 0.01);
  ASSERT_EQ(out.size(), 40u);
  expectIncreasing(out);
  std::size_t at_bound = 0;
  for (const auto& o : out)
  {
    EXPECT_LE(o.time, first.at(o.stamp) + 0.01 + 1e-12);
    if (!o.missing.empty())
    {
      ++at_bound;
      EXPECT_EQ(o.stamp, stop);
      EXPECT_EQ(o.missing, std::vector<std::size_t>{ 2 });
      EXPECT_DOUBLE_EQ(o.time, first.at(o.stamp) + 0.01);
    }
    if (o.stamp > stop)
    {
      // Published as soon as the live sources' scans are in: the dead one delays nothing.
      EXPECT_DOUBLE_EQ(o.time, last_live.at(o.stamp));
      EXPECT_EQ(o.held[0], o.stamp);
      EXPECT_EQ(o.held[1], o.stamp);
    }
  }
  EXPECT_EQ(at_bound, 1u);
}

// A window longer than the frame period (a dead source's wait overlaps the next frame, whose
// scans are held back meanwhile): the next frame's held scans still complete its output.
TEST(SyncWindow, ScansHeldBehindAWaitingOutputCompleteTheirOwn)
{
  auto arrivals = sharedStamps(3, 20.0, 40, 0.02, 0.01);
  const std::int64_t stop = kStart + 20 * (kSecond / 20);
  stopSource(arrivals, 2, stop);
  const auto first = firstArrivals(arrivals);
  const auto out = play(arrivals, 3, 0.08);
  ASSERT_EQ(out.size(), 40u);
  expectIncreasing(out);
  for (const auto& o : out)
  {
    EXPECT_LE(o.time, first.at(o.stamp) + 0.08 + 1e-12);
    if (o.stamp < kStart + 2 * (kSecond / 20))
      continue;
    EXPECT_EQ(o.held[0], o.stamp);
    EXPECT_EQ(o.held[1], o.stamp);
    EXPECT_EQ(o.held[2] == o.stamp, o.stamp < stop);
    EXPECT_EQ(o.missing.empty(), o.stamp != stop);
  }
}

// A source late by more than the window: the output goes at the bound without it, naming it; its
// late scan goes into the next output (never a second output at the same stamp).
TEST(SyncWindow, ALateSourceIsNamedAndGoesIntoTheNextOutput)
{
  auto arrivals = sharedStamps(2, 10.0, 20, 0.02, 0.002);
  for (int f = 0; f < 20; ++f)
    arrivals.push_back({ f / 10.0 + 0.05, 2, kStart + f * (kSecond / 10) });  // 30 ms after the others
  const auto first = firstArrivals(arrivals);
  const auto out = play(arrivals, 3, 0.01);
  ASSERT_EQ(out.size(), 20u);
  expectIncreasing(out);
  for (std::size_t k = 3; k < out.size(); ++k)
  {
    EXPECT_EQ(out[k].missing, std::vector<std::size_t>{ 2 });
    EXPECT_DOUBLE_EQ(out[k].time, first.at(out[k].stamp) + 0.01);
    EXPECT_EQ(out[k].held[2], out[k - 1].stamp);  // the late scan, in the next output
  }
}

// A source on another phase (a 14 Hz camera beside two lidars at 10 Hz that share stamps) is
// never waited for: its outputs are published at its arrival, unless an output of the lidars'
// stamp is waiting then (it follows that one, within the window); the lidars' outputs stay complete.
TEST(SyncWindow, ASourceOnAnotherPhaseIsNotWaitedFor)
{
  auto arrivals = sharedStamps(2, 10.0, 30, 0.02, 0.006);
  for (int f = 0; f < 42; ++f)
  {
    const std::int64_t stamp = kStart + 3 * kSecond / 1000 + f * (kSecond / 14);
    arrivals.push_back({ (stamp - kStart) / 1e9 + 0.03, 2, stamp });
  }
  const auto out = play(arrivals, 3, 0.01);
  const auto first = firstArrivals(arrivals);
  expectIncreasing(out);
  std::set<std::int64_t> camera, lidar;
  for (const auto& a : arrivals)
    (a.source == 2 ? camera : lidar).insert(a.stamp);
  std::size_t cameras = 0;
  for (const auto& o : out)
  {
    EXPECT_TRUE(o.missing.empty());
    EXPECT_LE(o.time, first.at(o.stamp) + 0.01 + 1e-12);
    if (camera.count(o.stamp) != 0)
    {
      ++cameras;
      EXPECT_FALSE(o.waited);
      for (std::size_t s = 0; s < 2; ++s)
        EXPECT_LE(o.held[s], o.stamp);  // never a scan newer than the output
    }
    else if (o.stamp >= kStart + 2 * (kSecond / 10))  // from the lidars' third frame on (a period known)
    {
      EXPECT_EQ(o.held[0], o.stamp);
      EXPECT_EQ(o.held[1], o.stamp);
    }
  }
  EXPECT_EQ(cameras, camera.size());  // one output for every camera scan, as without a window
  EXPECT_EQ(out.size(), camera.size() + lidar.size());
}

// One clock, two rates (a simulator's 20 Hz and 10 Hz sensors): the 10 Hz source is waited for
// at the stamps it shares, not at the others.
TEST(SyncWindow, ASlowerSourceOfTheSameClockIsWaitedForAtItsStampsOnly)
{
  auto arrivals = sharedStamps(1, 20.0, 40, 0.02, 0.0);
  auto slow = sharedStamps(1, 10.0, 20, 0.026, 0.0, 1);
  arrivals.insert(arrivals.end(), slow.begin(), slow.end());
  const auto out = play(arrivals, 2, 0.01);
  ASSERT_EQ(out.size(), 40u);
  expectIncreasing(out);
  for (std::size_t k = 4; k < out.size(); ++k)
  {
    const bool shared = k % 2 == 0;
    EXPECT_EQ(out[k].waited, shared) << "output " << k;
    EXPECT_EQ(out[k].held[1] == out[k].stamp, shared);
    EXPECT_TRUE(out[k].missing.empty());
    EXPECT_NEAR(out[k].time, k / 20.0 + (shared ? 0.026 : 0.02), 1e-9);
  }
}

// Timed out at the stamp, the source is not waited for (the merge leaves it out anyway).
TEST(SyncWindow, ATimedOutSourceIsNotWaitedFor)
{
  StampSync sync(0.01, { 1.0, 0.05 });
  const std::int64_t p = kSecond / 10;
  for (int f = 0; f < 3; ++f)
  {
    sync.observe(0, kStart + f * p, f * 0.1);
    sync.observe(1, kStart + f * p, f * 0.1);
  }
  StampSync::Decision d;
  sync.observe(0, kStart + 3 * p, 0.3);
  sync.decide(kStart + 3 * p, 0.3, d);
  EXPECT_TRUE(d.publish);  // source 1's 0.1 s period exceeds its 0.05 s timeout
  EXPECT_TRUE(d.due.empty());
  StampSync lenient(0.01, { 1.0, 1.0 });
  for (int f = 0; f < 3; ++f)
  {
    lenient.observe(0, kStart + f * p, f * 0.1);
    lenient.observe(1, kStart + f * p, f * 0.1);
  }
  lenient.observe(0, kStart + 3 * p, 0.3);
  lenient.decide(kStart + 3 * p, 0.3, d);
  EXPECT_FALSE(d.publish);
  EXPECT_EQ(d.due, std::vector<std::size_t>{ 1 });
  EXPECT_DOUBLE_EQ(d.deadline, 0.31);
}

// publish_rate > 0: a tick between the scans of one stamp waits for the rest (once, until the
// first one's arrival + window) and publishes once they are in, or at the window's end without
// the late ones; a tick with nothing newer than the last output publishes nothing.
TEST(SyncWindow, ATickWaitsForScansOnTheirWay)
{
  SyncedOutputs<int>::Handlers h;
  std::vector<std::size_t> merged;
  std::vector<double> waits;
  struct Published
  {
    std::int64_t stamp;
    std::vector<std::size_t> missing;
    bool waited;
  };
  std::vector<Published> published;
  h.merge = [&](std::size_t s, const int&) { merged.push_back(s); };
  h.wait = [&](std::int64_t, const StampSync::Decision& d) { waits.push_back(d.deadline); };
  h.publish = [&](std::int64_t t, const StampSync::Decision& d, bool waited) {
    published.push_back({ t, d.due, waited });
  };
  SyncedOutputs<int> outputs(0.01, { 1.0, 1.0, 1.0 }, false, h);
  const std::int64_t p = kSecond / 40;
  for (int f = 0; f < 3; ++f)
    for (std::size_t s = 0; s < 3; ++s)
      outputs.add(s, kStart + f * p, f * 0.025 + 0.001 * s, 0, f * 0.025 + 0.001 * s);
  EXPECT_TRUE(published.empty());  // only ticks publish
  outputs.tick(kStart + 2 * p, 0.06, false);
  ASSERT_EQ(published.size(), 1u);
  EXPECT_EQ(published[0].stamp, kStart + 2 * p);
  EXPECT_FALSE(published[0].waited);
  outputs.tick(kStart + 2 * p, 0.07, false);  // nothing newer
  EXPECT_EQ(published.size(), 1u);

  outputs.add(1, kStart + 3 * p, 0.0752, 0, 0.0752);
  outputs.tick(kStart + 3 * p, 0.0753, false);
  EXPECT_EQ(published.size(), 1u);
  ASSERT_EQ(waits.size(), 1u);
  EXPECT_DOUBLE_EQ(waits[0], 0.0852);
  EXPECT_TRUE(outputs.waiting());
  EXPECT_DOUBLE_EQ(outputs.deadline(), 0.0852);
  outputs.add(0, kStart + 3 * p, 0.0760, 0, 0.0760);
  outputs.tick(kStart + 3 * p, 0.0761, false);
  EXPECT_EQ(waits.size(), 1u);  // still the same wait
  outputs.add(2, kStart + 3 * p, 0.0790, 0, 0.0790);
  outputs.tick(kStart + 3 * p, 0.0791, false);
  ASSERT_EQ(published.size(), 2u);
  EXPECT_TRUE(published[1].waited);
  EXPECT_TRUE(published[1].missing.empty());
  EXPECT_FALSE(outputs.waiting());
  EXPECT_EQ(merged.size(), 12u);  // every scan went straight into the merge

  outputs.add(1, kStart + 4 * p, 0.1002, 0, 0.1002);
  outputs.tick(kStart + 4 * p, 0.1003, false);
  EXPECT_EQ(published.size(), 2u);
  outputs.tick(kStart + 4 * p, 0.1103, true);  // the window ended: publish without the late ones
  ASSERT_EQ(published.size(), 3u);
  EXPECT_EQ(published[2].missing, (std::vector<std::size_t>{ 0, 2 }));
  EXPECT_TRUE(published[2].waited);
}

// A jump back of the timeline (bag loop) forgets the last output: the new timeline's first
// stamp, older than it, is published.
TEST(SyncWindow, ResetForgetsTheTimeline)
{
  std::vector<std::int64_t> published;
  SyncedOutputs<int>::Handlers h;
  h.merge = [](std::size_t, const int&) {};
  h.wait = [](std::int64_t, const StampSync::Decision&) {};
  h.publish = [&](std::int64_t t, const StampSync::Decision&, bool) { published.push_back(t); };
  SyncedOutputs<int> outputs(0.01, { 1.0 }, true, h);
  outputs.add(0, kStart + kSecond, 0.0, 0, 0.0);
  outputs.add(0, kStart, 0.1, 0, 0.1);
  EXPECT_EQ(published.size(), 1u);
  outputs.reset();
  outputs.add(0, kStart, 0.2, 0, 0.2);
  EXPECT_EQ(published, (std::vector<std::int64_t>{ kStart + kSecond, kStart }));
}

TEST(SyncWindow, PeriodIsTheMedianOfTheStampDifferences)
{
  // A dropped frame (a double step) and jitter of 2 ms do not move the prediction.
  StampSync sync(0.01, { 1.0, 1.0 });
  const std::int64_t p = kSecond / 20, ms = kSecond / 1000;
  const std::int64_t j[] = { 0, 2 * ms, -1 * ms, 0, 1 * ms, -2 * ms };
  for (int f = 0; f < 6; ++f)
  {
    sync.observe(0, kStart + f * p, f * 0.05);
    if (f != 3)
      sync.observe(1, kStart + f * p + (f == 0 ? 0 : j[f]), f * 0.05);
  }
  sync.observe(0, kStart + 6 * p, 0.3);
  StampSync::Decision d;
  sync.decide(kStart + 6 * p, 0.3, d);
  EXPECT_EQ(d.due, std::vector<std::size_t>{ 1 });  // shared stamp kStart, next one due at 6 p
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
