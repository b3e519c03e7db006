"""Seeded malformed and extreme ROS messages for the node fuzz (issue 8).

The same case ideas as the cores' sanitizer fuzz (test/fuzz/fuzz_values.h), as whole
messages: PointCloud2 with broken layouts, LaserScan with broken geometry or readings,
Odometry with broken poses or stamps, tf with broken transforms. Every function takes a random.Random, so a seed
replays a run. The malformed_* functions return (message, case): the case names what was
broken, for the counts the test prints."""
import math
import struct

import genpy
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan, PointCloud2, PointField
from std_msgs.msg import Header
from tf2_msgs.msg import TFMessage

NAN = float("nan")
INF = float("inf")
FLT_MAX = 3.4028234663852886e38
EXTREME_DOUBLES = [0.0, -0.0, NAN, INF, -INF, 5e-324, 1e-300, 1e300, -1e300, FLT_MAX, -FLT_MAX, 1e38,
                   2147483648.0, 4294967296.0, -1.0, 1e-9, 1e9, math.pi, 2 * math.pi]
EXTREME_READINGS = [0.0, -0.0, NAN, INF, -INF, 1e-45, FLT_MAX, -FLT_MAX, 1e30, -1.0, 0.006, 0.019, 65.533, 65.535]
# (secs, nsecs) a header can carry: zero, one nanosecond, the largest secs (the issue-8 crash:
# more than 2^31 s ahead of now), just past 2^31, and the largest nsecs.
EXTREME_STAMPS = [(0, 0), (0, 1), (4294967295, 999999999), (4294967295, 0), (2147483648, 0), (2147483647, 999999999),
                  (1, 999999999)]
DATATYPES = list(range(0, 10)) + [255]
FRAMES_BAD = ["", "/", "/base_link", "no_such_frame", "base_link ", "\u00e9\u00e8", "a" * 300]


def stamp_of(rng):
    return genpy.Time(*rng.choice(EXTREME_STAMPS))


def _finite_float32(value):
    """struct.pack('f') refuses finite doubles beyond the float range."""
    return max(-FLT_MAX, min(FLT_MAX, value)) if math.isfinite(value) else value


def malformed_cloud(rng, frame, stamp):
    """A PointCloud2 with one broken part."""
    case = rng.choice(["point_step", "row_step", "size", "fields", "datatype", "offset", "bigendian",
                       "values", "frame", "stamp", "empty", "huge_dims"])
    width, height = rng.randint(1, 32), rng.randint(1, 4)
    dtype = rng.choice([7, 8])
    size = 4 if dtype == 7 else 8
    step = 3 * size + rng.choice([0, 4])
    fields = [PointField(name=n, offset=i * size, datatype=dtype, count=1) for i, n in enumerate("xyz")]
    pack = "<" + ("f" if dtype == 7 else "d")
    values = []
    for _ in range(width * height):
        p = [rng.uniform(0.3, 4.0), rng.uniform(-1.0, 1.0), rng.uniform(-0.5, 0.5)]
        if case == "values" and rng.random() < 0.5:
            p[rng.randrange(3)] = rng.choice(EXTREME_DOUBLES)
        values.append(p)
    data = bytearray()
    for p in values:
        point = b"".join(struct.pack(pack, _finite_float32(v) if dtype == 7 else v) for v in p)
        data += point + bytes(step - len(point))
    msg = PointCloud2(height=height, width=width, fields=fields, is_bigendian=False, point_step=step,
                      row_step=step * width, is_dense=False)
    msg.header.frame_id = frame
    msg.header.stamp = stamp
    if case == "point_step":
        msg.point_step = rng.choice([0, 1, 3 * size - 1, step + 1, 2 ** 32 - 1, 2 ** 31])
    elif case == "row_step":
        msg.row_step = rng.choice([0, msg.row_step - 1, msg.row_step + 1, 2 ** 32 - 1])
    elif case == "size":
        data = data[:rng.randrange(len(data))] if rng.random() < 0.5 else data + bytes(rng.randint(1, 64))
    elif case == "fields":
        choice = rng.randrange(3)
        if choice == 0:
            del fields[rng.randrange(3)]  # x, y or z missing
        elif choice == 1:
            fields.append(PointField(name=rng.choice("xyz"), offset=0, datatype=dtype, count=1))  # duplicated
        else:
            fields[rng.randrange(3)].count = rng.choice([0, 2 ** 32 - 1])
    elif case == "datatype":
        fields[rng.randrange(3)].datatype = rng.choice([d for d in DATATYPES if d != dtype])
    elif case == "offset":
        fields[rng.randrange(3)].offset = rng.choice([step, step - 1, 2 ** 32 - 1, 2 ** 32 - 4, 2 ** 31])
    elif case == "bigendian":
        msg.is_bigendian = True
    elif case == "frame":
        msg.header.frame_id = rng.choice(FRAMES_BAD)
    elif case == "stamp":
        msg.header.stamp = stamp_of(rng)
    elif case == "empty":
        msg.width, msg.height, msg.row_step, data = rng.choice([(0, 0, 0, b""), (0, 1, 0, b""), (width, 0, 0, b"")])
    elif case == "huge_dims":
        msg.width, msg.height = rng.choice([(2 ** 32 - 1, 1), (2 ** 16, 2 ** 16), (1, 2 ** 32 - 1)])
    msg.data = bytes(data)
    return msg, "cloud/" + case


def valid_cloud(frame, stamp, distance=1.5, width=121, height=5):
    """An organized float32 x, y, z cloud: a wall `distance` ahead (x forward, z up), 1 m wide,
    0.4 m high around the frame's origin."""
    fields = [PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1) for i, n in enumerate("xyz")]
    data = b"".join(struct.pack("<fff", distance, -0.5 + c / (width - 1), -0.2 + 0.4 * r / (height - 1))
                    for r in range(height) for c in range(width))
    return PointCloud2(header=Header(frame_id=frame, stamp=stamp), height=height, width=width, fields=fields,
                       is_bigendian=False, point_step=12, row_step=12 * width, data=data, is_dense=True)


def valid_scan(frame, stamp, beams=360, distance=2.0):
    """A full turn of `beams` readings, all at `distance` (a round room around the sensor)."""
    inc = 2 * math.pi / beams
    return LaserScan(header=Header(frame_id=frame, stamp=stamp), angle_min=-math.pi,
                     angle_max=-math.pi + (beams - 1) * inc,
                     angle_increment=inc, time_increment=0.0, scan_time=0.1, range_min=0.05, range_max=30.0,
                     ranges=[distance] * beams, intensities=[])


def malformed_scan(rng, frame, stamp):
    """A LaserScan with broken geometry, readings, frame or stamp."""
    msg = valid_scan(frame, stamp, beams=rng.choice([90, 360, 720]), distance=rng.uniform(0.5, 5.0))
    n = len(msg.ranges)
    # A million readings (4 MB) is costly to send: one scan in a hundred.
    case = "million" if rng.random() < 0.01 else rng.choice(
        ["length", "increment", "angles", "readings", "intensities", "range_limits", "time_increment", "frame",
         "stamp"])
    if case == "length":
        msg.ranges = msg.ranges[:rng.choice([0, 1, n // 2, n - 2])] if rng.random() < 0.5 else msg.ranges + [1.0] * 5
    elif case == "increment":
        msg.angle_increment = rng.choice([0.0, -msg.angle_increment, NAN, INF, -INF, 5e-324])
    elif case == "angles":
        msg.angle_min, msg.angle_max = rng.choice([(msg.angle_max, msg.angle_min), (NAN, 1.0), (-INF, INF),
                                                   (-1e30, 1e30)])
    elif case == "million":
        msg.ranges = [1.0] * 1000000
        msg.angle_increment = (msg.angle_max - msg.angle_min) / (1000000 - 1)
    elif case == "readings":
        msg.ranges = [rng.choice(EXTREME_READINGS) if rng.random() < 0.5 else r for r in msg.ranges]
    elif case == "intensities":
        msg.intensities = [1.0] * rng.choice([1, n - 1, n + 1, 2 * n])
    elif case == "range_limits":
        msg.range_min, msg.range_max = rng.choice([(30.0, 0.05), (NAN, 30.0), (0.05, NAN), (-INF, INF), (0.0, 0.0)])
    elif case == "time_increment":
        msg.time_increment = rng.choice([NAN, INF, -INF, 1e30, -1e-3])
    elif case == "frame":
        msg.header.frame_id = rng.choice(FRAMES_BAD)
    elif case == "stamp":
        msg.header.stamp = stamp_of(rng)
    return msg, "scan/" + case


def odometry(frame, child, stamp, x=0.0, y=0.0, yaw=0.0):
    msg = Odometry()
    msg.header.frame_id = frame
    msg.header.stamp = stamp
    msg.child_frame_id = child
    msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return msg


def malformed_odometry(rng, frame, child, stamp):
    """Odometry with a broken pose, a stamp backwards or extreme, or a huge jump."""
    msg = odometry(frame, child, stamp)
    case = rng.choice(["nan", "zero_quaternion", "unnormalised", "backwards", "stamp", "jump", "child"])
    q = msg.pose.pose.orientation
    if case == "nan":
        setattr(msg.pose.pose.position, rng.choice("xyz"), rng.choice([NAN, INF, -INF]))
    elif case == "zero_quaternion":
        q.x = q.y = q.z = q.w = 0.0
    elif case == "unnormalised":
        s = rng.choice([2.0, 1e-7, 1e6, NAN])
        q.x, q.y, q.z, q.w = q.x * s, q.y * s, q.z * s, q.w * s
    elif case == "backwards":
        msg.header.stamp = stamp - genpy.Duration(rng.choice([0.001, 0.5, 10.0, 1000.0]))
        if msg.header.stamp.secs < 0:
            msg.header.stamp = genpy.Time(0, 0)
    elif case == "stamp":
        msg.header.stamp = stamp_of(rng)
    elif case == "jump":
        msg.pose.pose.position.x = rng.choice([1e4, -1e6, 1e300, FLT_MAX])
    elif case == "child":
        msg.child_frame_id = rng.choice(FRAMES_BAD)
    return msg, "odometry/" + case


def malformed_tf(rng, parent, child, stamp):
    """A /tf message about the child frame that tf2 must refuse (NaN or infinite translation,
    zero, non-normalised or NaN rotation, no child frame, a frame its own parent)."""
    t = TransformStamped(header=Header(frame_id=parent, stamp=stamp), child_frame_id=child)
    t.transform.rotation.w = 1.0
    case = rng.choice(["nan_translation", "inf_translation", "zero_rotation", "unnormalised", "nan_rotation",
                       "no_child", "self"])
    if case in ("nan_translation", "inf_translation"):
        value = NAN if case == "nan_translation" else rng.choice([INF, -INF])
        setattr(t.transform.translation, rng.choice("xyz"), value)
    elif case == "zero_rotation":
        t.transform.rotation.w = 0.0
    elif case == "unnormalised":
        t.transform.rotation.w = rng.choice([2.0, 1e-3, 1e6])
    elif case == "nan_rotation":
        setattr(t.transform.rotation, rng.choice("xyzw"), NAN)
    elif case == "no_child":
        t.child_frame_id = ""
    elif case == "self":
        t.child_frame_id = parent
    return TFMessage(transforms=[t]), "tf/" + case
