"""Helpers to build ROS messages and write them into a bag (rosbag Python API)."""
import rospy
from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage


def stamp(t):
    """rospy.Time from float seconds (a rospy.Time as it is: exact nanoseconds)."""
    if isinstance(t, rospy.Time):
        return t
    return rospy.Time.from_sec(float(t))


def transform(t, parent, child, xyz, quat):
    """geometry_msgs/TransformStamped from a translation and an (x, y, z, w) quaternion."""
    m = TransformStamped()
    m.header.stamp = stamp(t)
    m.header.frame_id = parent
    m.child_frame_id = child
    m.transform.translation.x, m.transform.translation.y, m.transform.translation.z = map(float, xyz)
    (m.transform.rotation.x, m.transform.rotation.y, m.transform.rotation.z,
     m.transform.rotation.w) = map(float, quat)
    return m


def tf_message(transforms):
    return TFMessage(transforms=list(transforms))


def write_latched(bag, topic, msg, t, callerid="/simulate_scenario"):
    """Write ``msg`` with a full connection header marked latching, so that
    ``rosbag play`` re-publishes it latched (e.g. /tf_static, /scenario).  The
    header needs every field (topic, type, md5sum, message_definition, callerid,
    latching) or the bag's connection record is unusable."""
    header = {
        "topic": topic,
        "type": msg._type,
        "md5sum": msg._md5sum,
        "message_definition": msg._full_text,
        "callerid": callerid,
        "latching": "1",
    }
    bag.write(topic, msg, stamp(t), connection_header=header)
