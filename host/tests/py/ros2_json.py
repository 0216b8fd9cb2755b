"""The JSON the readers here print for a decoded ROS 2 message, whichever library decoded it
(the `mcap` package's CDR decoder or Cyclone DDS): the same attributes, the same keys.
"""


def occupancy_grid(m, cells):
    """A nav_msgs/OccupancyGrid: its header, its map metadata (the origin as x, y and the
    quaternion's w) and `cells`, its data as a list of signed bytes (−1 unknown, 0 ..= 100)."""
    return {
        "frame_id": m.header.frame_id,
        "stamp": [m.header.stamp.sec, m.header.stamp.nanosec],
        "resolution": m.info.resolution,
        "width": m.info.width,
        "height": m.info.height,
        "origin": [m.info.origin.position.x, m.info.origin.position.y,
                   m.info.origin.orientation.w],
        "data": cells,
    }


def diagnostics(m):
    """A diagnostic_msgs/DiagnosticArray: {status name: {key: value}}."""
    return {s.name: {kv.key: kv.value for kv in s.values} for s in m.status}
