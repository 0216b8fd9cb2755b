"""Receives the ROS 2 map topics of `pyramid --ros2` with Eclipse Cyclone DDS (the `cyclonedds`
Python binding; the types declared in IDL under the names ROS 2 gives them on DDS) and logs when
each sample arrived.

Prints "ready" once its readers exist, then polls every reader until its standard input closes
(the publisher has finished) and then IDLE_S seconds pass without a sample, and prints one JSON
object:
{"messages": [[topic, stamp_ns, received_ns], ...]} where stamp_ns is the sample's
header.stamp (the hand-off's stamp) and received_ns the wall clock (`time.time_ns()`) when the
reader returned it.

Usage: latency_dds.py LAYERS IDLE_S [DOMAIN]
Run it only inside a network namespace of its own (DDS multicast must not leave the machine).
"""
import json
import os
import sys
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "host", "tests", "py"))
from ros2_types import OccupancyGrid  # noqa: E402  the IDL declarations of the host's tests

from cyclonedds.core import Policy, Qos  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from cyclonedds.util import duration  # noqa: E402


def main(layers, idle_s, domain):
    dp = DomainParticipant(domain)
    qos = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(64))
    names = ["/terrain/fused"] + [f"/terrain/layer_{k}" for k in range(layers)]
    readers = {n: DataReader(dp, Topic(dp, "rt" + n, OccupancyGrid), qos=qos) for n in names}
    print("ready", flush=True)
    ended = threading.Event()
    threading.Thread(target=lambda: (sys.stdin.read(), ended.set()), daemon=True).start()
    log, last = [], time.monotonic()
    while not ended.is_set() or time.monotonic() - last < idle_s:
        got = False
        for name, reader in readers.items():
            for s in reader.take(N=64):
                now = time.time_ns()
                if not hasattr(s, "header"):
                    continue  # an InvalidSample: a writer's state changed, no data
                stamp = s.header.stamp.sec * 1_000_000_000 + s.header.stamp.nanosec
                log.append([name, stamp, now])
                got = True
        if got:
            last = time.monotonic()
        else:
            time.sleep(0.0005)
    print(json.dumps({"messages": log}), flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3]) if len(sys.argv) > 3 else 0)
