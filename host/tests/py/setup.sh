#!/bin/sh
# Installs the Python readers the tests of `pyramid listen`'s outputs use
# (host/tests/outputs.rs): MCAP (mcap, mcap-ros2-support, mcap-protobuf-support), the
# Foxglove WebSocket protocol (websockets), and Eclipse Cyclone DDS (cyclonedds).
set -eu
cd "$(dirname "$0")"
python3 -m pip install --quiet --disable-pip-version-check -r requirements.txt
python3 -c "import mcap, mcap_ros2, mcap_protobuf, websockets, cyclonedds; print('host/tests/py: readers installed')"
