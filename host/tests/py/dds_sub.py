"""Subscribes with Eclipse Cyclone DDS (the `cyclonedds` Python binding) to the ROS 2 topics
`pyramid listen --ros2` publishes, with the message types of `ros2_types.py` (IDL, under the
names ROS 2 gives them on DDS: `nav_msgs::msg::dds_::OccupancyGrid_`, topic
`rt/terrain/fused`), and the QoS Nav2's map subscribers use (reliable, transient local, keep
last 1).

Waits until it has a sample of every topic asked for (or the timeout), then prints one JSON
object {topic: last sample} and exits (status 1 if a topic is missing).

Usage: dds_sub.py LAYERS TIMEOUT_S [DOMAIN]
Run it only inside a network namespace of its own (DDS multicast must not leave the machine).
"""
import json
import sys
import time

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from ros2_json import diagnostics, occupancy_grid
from ros2_types import DiagnosticArray, OccupancyGrid


def grid(s):
    return occupancy_grid(s, list(s.data))


def main():
    layers, timeout = int(sys.argv[1]), float(sys.argv[2])
    domain = int(sys.argv[3]) if len(sys.argv) > 3 else 0
    dp = DomainParticipant(domain)
    map_qos = Qos(Policy.Reliability.Reliable(duration(seconds=1)),
                  Policy.Durability.TransientLocal, Policy.History.KeepLast(1))
    readers = {}
    for name in ["fused"] + [f"layer_{k}" for k in range(layers)]:
        t = Topic(dp, f"rt/terrain/{name}", OccupancyGrid, qos=map_qos)
        readers[f"/terrain/{name}"] = (DataReader(dp, t, qos=map_qos), grid)
    diag_qos = Qos(Policy.Reliability.Reliable(duration(seconds=1)),
                   Policy.Durability.Volatile, Policy.History.KeepLast(10))
    t = Topic(dp, "rt/diagnostics", DiagnosticArray, qos=diag_qos)
    readers["/diagnostics"] = (
        DataReader(dp, t, qos=diag_qos),
        diagnostics,
    )
    last, first_at, counts = {}, {}, {}
    start = time.monotonic()
    quiet_since = None
    # Until every topic has come and the maps have been quiet for a second and a half (the
    # history of a late joiner may come in several samples), or the timeout.
    while time.monotonic() - start < timeout:
        got = False
        for topic, (reader, convert) in readers.items():
            for s in reader.take(N=100):
                # Instance state changes (a writer gone) come as samples without data.
                if type(s).__name__ == "InvalidSample":
                    continue
                last[topic] = convert(s)
                counts[topic] = counts.get(topic, 0) + 1
                first_at.setdefault(topic, round(time.monotonic() - start, 3))
                got = got or topic != "/diagnostics"
        now = time.monotonic()
        if got or quiet_since is None:
            quiet_since = now
        if len(last) == len(readers) and now - quiet_since > 1.5:
            break
        time.sleep(0.02)
    print(json.dumps({"last": last, "first_after_s": first_at, "samples": counts}), flush=True)
    sys.exit(0 if len(last) == len(readers) else 1)


if __name__ == "__main__":
    main()
