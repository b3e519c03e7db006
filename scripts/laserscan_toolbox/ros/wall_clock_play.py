"""Plays a bag on wall time, the way a robot's drivers publish: no /clock, and every header
stamp (each transform's in /tf and /tf_static too) moved by one offset so that the bag's
first message is stamped "now". The pipeline then runs with use_sim_time false and sees what
it sees on a robot: stamps close to its own clock, transforms at those stamps.

Why not ``rosbag play`` without ``--clock``: it keeps the recorded stamps, so every tf lookup
and every "is this source alive" test against ros::Time::now() would compare a wall clock with
stamps from the recording's day. Why not ``--clock``: every roscpp and rospy process then
takes ``/clock`` (200 Hz in the evaluation), which costs each of them more CPU than an idle
nodelet loader spends on its own; that share is the simulation's, not the robot's.

Stamps of zero ("no stamp": the latest transform) and stamps that the offset would carry out
of ROS 1 time are left as recorded. Messages without a leading std_msgs/Header (other than
tf2_msgs/TFMessage) are played unchanged.

Run as a process (``python3 -m laserscan_toolbox.ros.wall_clock_play BAG [--duration S]``): it
advertises every topic, waits until each one's subscribers are connected, prints
``started <offset in s>``, plays, prints ``done <messages> <seconds of data played>`` and
exits 0.
"""

import struct
import sys
import time

MAX_STAMP_NS = (2 ** 32) * 10 ** 9  # ROS 1 time: unsigned 32-bit seconds
TF_TYPES = ("tf2_msgs/TFMessage", "tf/tfMessage")
_STAMP = struct.Struct("<II")
_U32 = struct.Struct("<I")
_TRANSFORM_BYTES = 7 * 8  # geometry_msgs/Transform: translation (3) + rotation (4) float64


def _shift_at(buf, pos, offset_ns):
    """Moves the stamp (secs, nsecs) at ``buf[pos:pos + 8]`` by offset_ns, in place."""
    secs, nsecs = _STAMP.unpack_from(buf, pos)
    ns = secs * 10 ** 9 + nsecs
    shifted = ns + offset_ns
    if ns == 0 or not 0 <= shifted < MAX_STAMP_NS:
        return
    _STAMP.pack_into(buf, pos, *divmod(shifted, 10 ** 9))


def shift_header_stamp(raw, offset_ns):
    """A serialised message whose first field is a std_msgs/Header (seq, stamp, frame_id),
    its stamp moved by offset_ns."""
    buf = bytearray(raw)
    if len(buf) >= 12:
        _shift_at(buf, 4, offset_ns)
    return bytes(buf)


def shift_tf_stamps(raw, offset_ns):
    """A serialised tf2_msgs/TFMessage with every transform's stamp moved by offset_ns.
    Raises ValueError on a message shorter than its own lengths say."""
    buf = bytearray(raw)
    try:
        (n,), pos = _U32.unpack_from(buf, 0), 4
        for _ in range(n):
            _shift_at(buf, pos + 4, offset_ns)  # header: seq, then the stamp
            pos += 12
            for _string in ("frame_id", "child_frame_id"):
                (length,) = _U32.unpack_from(buf, pos)
                pos += 4 + length
            pos += _TRANSFORM_BYTES
    except struct.error as e:
        raise ValueError("malformed TFMessage: %s" % e) from None
    if pos > len(buf):
        raise ValueError("malformed TFMessage: %d bytes, %d needed" % (len(buf), pos))
    return bytes(buf)


def stamp_shifter(datatype, has_header):
    """The function that moves a serialised message's stamps for this type (None: none)."""
    if datatype in TF_TYPES:
        return shift_tf_stamps
    if has_header:
        return shift_header_stamp
    return None


def _raw_class(datatype, md5sum, definition):
    """A rospy message class that publishes already serialised bytes (``_buff``) under the
    recorded type, so that roscpp subscribers accept the connection."""
    import rospy
    return type("Raw", (rospy.AnyMsg,), {"_type": datatype, "_md5sum": md5sum,
                                         "_full_text": definition, "_has_header": False})


def _wait_subscribers(master, publishers, me, timeout):
    """Waits until every publisher is connected to all the subscribers the master lists."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        try:
            subs = {t: [n for n in nodes if n != me] for t, nodes in master.getSystemState()[1]}
        except Exception:
            subs = {}
        if all(p.get_num_connections() >= len(subs.get(t, ())) for t, p in publishers.items()):
            return True
        time.sleep(0.05)
    return False


def play(bag_path, duration=None, connect_timeout=5.0, out=sys.stdout):
    """Publishes the bag's first ``duration`` seconds (all of it when None) at their recorded
    pace on wall time; returns the number of messages sent."""
    import rosbag
    import rosgraph
    import rospy
    bag = rosbag.Bag(bag_path)  # before the node: a bad bag fails at once, master or not
    rospy.init_node("wall_clock_play", anonymous=True, disable_signals=True)
    with bag:
        start = bag.get_start_time()
        end = bag.get_end_time() if duration is None else min(bag.get_end_time(), start + duration)
        publishers, shifters = {}, {}
        for c in bag._get_connections():
            if c.topic == "/clock" or c.topic in publishers:
                continue
            cls = _raw_class(c.datatype, c.md5sum, c.msg_def)
            publishers[c.topic] = rospy.Publisher(c.topic, cls, queue_size=100,
                                                  latch=c.header.get("latching") == "1")
        _wait_subscribers(rosgraph.Master(rospy.get_name()), publishers, rospy.get_name(),
                          connect_timeout)
        t0 = time.time()
        offset_ns = int(round(t0 * 1e9)) - int(round(start * 1e9))
        print("started %.9f" % (offset_ns / 1e9), file=out, flush=True)
        sent, last = 0, start
        for topic, raw, t in bag.read_messages(end_time=rospy.Time.from_sec(end), raw=True):
            if topic not in publishers:
                continue
            datatype, data, pytype = raw[0], raw[1], raw[4]
            if topic not in shifters:
                shifters[topic] = stamp_shifter(datatype, getattr(pytype, "_has_header", False))
            shift = shifters[topic]
            due = t0 + (t.to_sec() - start)
            wait = due - time.time()
            if wait > 0:
                time.sleep(wait)
            msg = publishers[topic].data_class()
            msg._buff = shift(data, offset_ns) if shift else data
            publishers[topic].publish(msg)
            sent, last = sent + 1, t.to_sec()
    print("done %d %.9f" % (sent, last - start), file=out, flush=True)
    rospy.signal_shutdown("played")
    return sent


def main(argv=None):
    import argparse
    p = argparse.ArgumentParser(prog="wall_clock_play", description=__doc__.split("\n\n")[0])
    p.add_argument("bag")
    p.add_argument("--duration", type=float, help="play only the bag's first S seconds")
    a = p.parse_args(argv)
    play(a.bag, a.duration)
    return 0


if __name__ == "__main__":
    sys.exit(main())
