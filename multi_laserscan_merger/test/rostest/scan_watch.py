"""Shared by the fuzz and fault rostests: records a LaserScan topic and checks every scan.

Waits are event-driven (a condition variable woken by each message), so the tests are as
fast as the nodes allow and tolerate a loaded machine up to the given timeouts."""
import math
import threading
import time

import rospy
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import LaserScan


# The valid inputs of the fuzz and fault tests (laserscan_toolbox.experiments.fuzz_inputs.valid_scan and
# valid_cloud): the lidar sees a round room of LIDAR_DISTANCE, the camera a wall WALL_DISTANCE
# ahead, 1 m wide. Both sensors sit on base_link's z axis without rotation.
LIDAR_DISTANCE = 2.0
WALL_DISTANCE = 1.5
MOUNTS = {"lidar": (0.0, 0.0, 0.2), "camera": (0.0, 0.0, 0.3)}


def mount_transforms(frames, stamp):
    """base_link -> each frame of MOUNTS, as TransformStamped."""
    transforms = []
    for frame in frames:
        t = TransformStamped()
        t.header.stamp = stamp
        t.header.frame_id = "base_link"
        t.child_frame_id = frame
        t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = MOUNTS[frame]
        t.transform.rotation.w = 1.0
        transforms.append(t)
    return transforms


def beam_angles(msg):
    return [msg.angle_min + i * msg.angle_increment for i in range(len(msg.ranges))]


def room_fraction(msg):
    """Share of the beams beside and behind the robot (where the camera does not look) that
    read the lidar's room."""
    side = [r for a, r in zip(beam_angles(msg), msg.ranges) if abs(a) > 1.0]
    return sum(1 for r in side if abs(r - LIDAR_DISTANCE) < 0.02) / len(side) if side else 0.0


def wall_fraction(msg):
    """Share of the beams straight ahead that read the camera's wall."""
    front = [r for a, r in zip(beam_angles(msg), msg.ranges) if abs(a) < 0.3]
    far = math.hypot(WALL_DISTANCE, 0.5) + 0.01
    return sum(1 for r in front if WALL_DISTANCE - 0.01 <= r <= far) / len(front) if front else 0.0


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
    """Every message of a LaserScan topic with its arrival time (s) by `clock` (default: the
    wall clock; a simulated-time test passes its own clock)."""

    def __init__(self, topic, clock=time.monotonic):
        self.topic = topic
        self.clock = clock
        self.messages = []  # (arrival, msg)
        self.problems = []  # (stamp, problem) of every scan that broke an invariant
        self._cv = threading.Condition()
        self._sub = rospy.Subscriber(topic, LaserScan, self._on_scan, queue_size=1000)

    def _on_scan(self, msg):
        problems = scan_problems(msg)
        with self._cv:
            self.messages.append((self.clock(), msg))
            self.problems.extend((stamp_key(msg.header.stamp), p) for p in problems)
            self._cv.notify_all()

    def connected(self):
        """A publisher of the topic is connected (its first messages are not lost)."""
        return self._sub.get_num_connections() > 0

    def count(self):
        with self._cv:
            return len(self.messages)

    def wait_for(self, predicate, timeout, start=0):
        """The first message from index `start` on that satisfies predicate(msg), with its
        arrival time; (None, None) after `timeout` seconds of wall time (whatever the clock)."""
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

    def between(self, t0, t1):
        """(arrival, msg) of the messages that arrived in [t0, t1]."""
        with self._cv:
            return [(a, m) for a, m in self.messages if t0 <= a <= t1]
