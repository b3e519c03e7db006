"""The node fuzz's generator (scripts/laserscan_toolbox/experiments/fuzz_inputs.py): seeded,
reaches every case, and breaks what each case says while the valid inputs stay valid."""
import io
import math
import random

import genpy

from laserscan_toolbox.experiments import fuzz_inputs as fz

STAMP = genpy.Time(1700000000, 5)


def serialised(msg):
    b = io.BytesIO()
    msg.serialize(b)
    return b.getvalue()


def test_same_seed_same_messages():
    def draw(seed):
        rng = random.Random(seed)
        return [serialised(f(rng, "camera", STAMP)[0]) for f in (fz.malformed_cloud, fz.malformed_scan)] + \
            [serialised(fz.malformed_odometry(rng, "odom", "base_link", STAMP)[0])]
    assert draw(3) == draw(3)
    assert draw(3) != draw(4)


def test_every_case_is_reached_and_every_message_serialises():
    rng = random.Random(0)
    cases = set()
    for _ in range(400):
        for msg, case in (fz.malformed_cloud(rng, "camera", STAMP), fz.malformed_scan(rng, "lidar", STAMP),
                          fz.malformed_odometry(rng, "odom", "base_link", STAMP),
                          fz.malformed_tf(rng, "base_link", "camera", STAMP)):
            serialised(msg)
            cases.add(case)
    kinds = {c.split("/")[0] for c in cases}
    assert kinds == {"cloud", "scan", "odometry", "tf"}
    assert {"cloud/size", "cloud/fields", "cloud/bigendian", "scan/length", "scan/million", "scan/stamp",
            "odometry/zero_quaternion", "odometry/jump"} <= cases
    assert len(cases) >= 35


def test_valid_inputs_are_consistent():
    scan = fz.valid_scan("lidar", STAMP, beams=360, distance=2.0)
    assert len(scan.ranges) == round((scan.angle_max - scan.angle_min) / scan.angle_increment) + 1
    assert all(scan.range_min <= r <= scan.range_max for r in scan.ranges)
    cloud = fz.valid_cloud("camera", STAMP)
    assert len(cloud.data) == cloud.row_step * cloud.height == cloud.width * cloud.height * cloud.point_step
    odom = fz.odometry("odom", "base_link", STAMP, yaw=1.0)
    q = odom.pose.pose.orientation
    assert math.isclose(q.z ** 2 + q.w ** 2, 1.0)


def test_a_malformed_cloud_is_not_a_valid_one():
    rng = random.Random(1)
    for _ in range(200):
        msg, case = fz.malformed_cloud(rng, "camera", STAMP)
        names = [f.name for f in msg.fields]
        consistent = (len(msg.data) == msg.row_step * msg.height and msg.row_step >= msg.width * msg.point_step
                      and sorted(names) == ["x", "y", "z"] and not msg.is_bigendian
                      and len({f.datatype for f in msg.fields}) == 1
                      and all(f.datatype in (7, 8) and f.count == 1
                              and f.offset + (4 if f.datatype == 7 else 8) <= msg.point_step for f in msg.fields)
                      and msg.header.frame_id == "camera" and msg.header.stamp == STAMP)
        # Only bad values (NaN / Inf / huge points) or an empty cloud may leave the layout intact.
        assert not consistent or case in ("cloud/values", "cloud/empty"), case
