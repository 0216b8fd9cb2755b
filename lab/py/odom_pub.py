"""Publishes a robot's poses as ROS 2 nav_msgs/msg/Odometry with Eclipse Cyclone DDS (the
`cyclonedds` Python binding), late and jittered as a robot's stack delivers them: each pose
stamped with the wall-clock time the robot was there, published `late ± jitter` ms after it.

The message types are those of host/tests/py/ros2_types.py, declared in IDL form under the
names ROS 2 gives them on DDS (`nav_msgs::msg::dds_::Odometry_`, topic `rt/odom` for ROS 2's
`/odom`), independently of the reader under test. QoS: keep last 10; reliable and volatile by default (rclcpp's default for a
publisher), or as --reliability and --durability say (a best-effort sensor driver, a
transient-local latched publisher): a reader must take each of them.

Input: NDJSON, one pose a line, `{"t": SECONDS, "pose": [x, y, z, roll, pitch, yaw]}` (metres,
radians; t from the recording's start), in time order.

Usage: odom_pub.py POSES.ndjson START_EPOCH_S [--late-ms 30] [--jitter-ms 10] [--seed 29]
       [--topic /odom] [--frame-id odom] [--domain 0] [--wait-s 5] [--log FILE]
       [--reliability reliable|best-effort] [--durability volatile|transient-local]
Waits up to --wait-s for a subscriber to match, then publishes pose k at START + t_k + late_k
(late_k uniform in late ± jitter), stamped START + t_k. Prints one JSON object at the end:
poses published, subscribers matched, the QoS, and the publish delays (publish − stamp, ms). With
--log, one line a pose in FILE: `{"stamp": S, "published": S}` (wall-clock seconds).
Run it only inside a network namespace of its own (DDS multicast must not leave the machine).
"""
import argparse
import json
import math
import os
import random
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "host", "tests", "py"))
from ros2_types import (  # noqa: E402  the IDL declarations of the host's tests
    Header, Odometry, Point, Pose, PoseWithCovariance, Quaternion, Time, Twist,
    TwistWithCovariance, Vector3,
)

from cyclonedds.core import Policy, Qos  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from cyclonedds.util import duration  # noqa: E402


def quaternion(roll, pitch, yaw):
    """The unit quaternion of R_z(yaw)·R_y(pitch)·R_x(roll) (ROS's fixed-axis RPY)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return Quaternion(
        x=sr * cp * cy - cr * sp * sy,
        y=cr * sp * cy + sr * cp * sy,
        z=cr * cp * sy - sr * sp * cy,
        w=cr * cp * cy + sr * sp * sy,
    )


def dds_topic(ros_topic):
    """ROS 2's DDS topic name: `rt` + the ROS name (`/odom` → `rt/odom`)."""
    return "rt" + (ros_topic if ros_topic.startswith("/") else "/" + ros_topic)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("poses")
    ap.add_argument("start", type=float)
    ap.add_argument("--late-ms", type=float, default=30.0)
    ap.add_argument("--jitter-ms", type=float, default=10.0)
    ap.add_argument("--seed", type=int, default=29)
    ap.add_argument("--topic", default="/odom")
    ap.add_argument("--frame-id", default="odom")
    ap.add_argument("--domain", type=int, default=0)
    ap.add_argument("--wait-s", type=float, default=5.0)
    ap.add_argument("--log")
    ap.add_argument("--reliability", choices=["reliable", "best-effort"], default="reliable")
    ap.add_argument("--durability", choices=["volatile", "transient-local"], default="volatile")
    a = ap.parse_args()
    with open(a.poses) as f:
        poses = [json.loads(line) for line in f if line.strip()]
    rng = random.Random(a.seed)
    qos = Qos(
        Policy.Reliability.Reliable(duration(seconds=1))
        if a.reliability == "reliable"
        else Policy.Reliability.BestEffort,
        Policy.Durability.Volatile if a.durability == "volatile" else Policy.Durability.TransientLocal,
        Policy.History.KeepLast(10),
    )
    dp = DomainParticipant(a.domain)
    writer = DataWriter(dp, Topic(dp, dds_topic(a.topic), Odometry), qos=qos)
    deadline = time.time() + a.wait_s
    while writer.get_matched_subscriptions() == [] and time.time() < deadline:
        time.sleep(0.01)
    matched = len(writer.get_matched_subscriptions())
    zero36 = [0.0] * 36
    delays = []
    log = []
    for p in poses:
        stamp = a.start + p["t"]
        late = (a.late_ms + a.jitter_ms * (2 * rng.random() - 1)) / 1000.0
        wait = stamp + late - time.time()
        if wait > 0:
            time.sleep(wait)
        x, y, z, roll, pitch, yaw = p["pose"]
        sec = math.floor(stamp)
        msg = Odometry(
            header=Header(
                stamp=Time(sec=sec, nanosec=min(int(round((stamp - sec) * 1e9)), 999_999_999)),
                frame_id=a.frame_id,
            ),
            child_frame_id="base_link",
            pose=PoseWithCovariance(
                pose=Pose(position=Point(x=x, y=y, z=z), orientation=quaternion(roll, pitch, yaw)),
                covariance=zero36,
            ),
            twist=TwistWithCovariance(
                twist=Twist(linear=Vector3(0.0, 0.0, 0.0), angular=Vector3(0.0, 0.0, 0.0)),
                covariance=zero36,
            ),
        )
        writer.write(msg)
        published = time.time()
        log.append({"stamp": stamp, "published": published})
        delays.append((published - stamp) * 1000.0)
    time.sleep(0.2)
    if a.log:
        with open(a.log, "w") as f:
            f.writelines(json.dumps(e) + "\n" for e in log)
    delays.sort()
    out = {
        "published": len(delays),
        "matched": matched,
        "reliability": a.reliability,
        "durability": a.durability,
        "delay_ms": {
            "median": delays[len(delays) // 2] if delays else None,
            "min": delays[0] if delays else None,
            "max": delays[-1] if delays else None,
        },
    }
    print(json.dumps(out))
    return 0 if matched > 0 else 1


if __name__ == "__main__":
    sys.exit(main())
