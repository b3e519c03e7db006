"""Shared by the fuzz and fault rostests: records a LaserScan topic and checks every scan.

Waits are event-driven (a condition variable woken by each message), so the tests are as
fast as the nodes allow and tolerate a loaded machine up to the given timeouts."""
import math
import threading
import time

import rospy
from sensor_msgs.msg import LaserScan


def scan_problems(msg):
    """What is wrong with a published scan: its length against its angles (fencepost rule),
    finite readings outside [range_min, range_max] (REP 117). Empty list when nothing."""
    problems = []
    if msg.angle_increment > 0 and math.isfinite(msg.angle_increment):
        expected = int(round((msg.angle_max - msg.angle_min) / msg.angle_increment)) + 1
        if len(msg.ranges) != expected:
            problems.append(f"{len(msg.ranges)} ranges, the angles give {expected}")
    else:
        problems.append(f"angle_increment {msg.angle_increment}")
    if msg.intensities and len(msg.intensities) != len(msg.ranges):
        problems.append(f"{len(msg.intensities)} intensities for {len(msg.ranges)} ranges")
    outside = [r for r in msg.ranges if math.isfinite(r) and not msg.range_min <= r <= msg.range_max]
    # "no return" written as range_max + inf_epsilon (use_inf false) is above range_max on purpose.
    if outside:
        problems.append(f"{len(outside)} finite ranges outside [{msg.range_min}, {msg.range_max}], e.g. {outside[:3]}")
    return problems


def stamp_key(stamp):
    return (stamp.secs, stamp.nsecs)


class ScanWatch:
    """Every message of a LaserScan topic with its arrival (wall clock, s)."""

    def __init__(self, topic):
        self.topic = topic
        self.messages = []  # (arrival, msg)
        self.problems = []  # (stamp, problem) of every scan that broke an invariant
        self._cv = threading.Condition()
        self._sub = rospy.Subscriber(topic, LaserScan, self._on_scan, queue_size=1000)

    def _on_scan(self, msg):
        problems = scan_problems(msg)
        with self._cv:
            self.messages.append((time.monotonic(), msg))
            self.problems.extend((stamp_key(msg.header.stamp), p) for p in problems)
            self._cv.notify_all()

    def count(self):
        with self._cv:
            return len(self.messages)

    def wait_for(self, predicate, timeout, start=0):
        """The first message from index `start` on that satisfies predicate(msg), with its
        arrival time; (None, None) after `timeout` seconds of wall time."""
        deadline = time.monotonic() + timeout
        with self._cv:
            i = start
            while True:
                while i < len(self.messages):
                    arrival, msg = self.messages[i]
                    if predicate(msg):
                        return arrival, msg
                    i += 1
                left = deadline - time.monotonic()
                if left <= 0 or rospy.is_shutdown():
                    return None, None
                self._cv.wait(min(left, 0.1))

    def wait_stamp(self, stamp, timeout):
        key = stamp_key(stamp)
        return self.wait_for(lambda m: stamp_key(m.header.stamp) == key, timeout)

    def arrivals_between(self, t0, t1):
        with self._cv:
            return [a for a, _ in self.messages if t0 <= a <= t1]
