"""Reads an MCAP file with the `mcap` package and its ROS 2 (CDR) and protobuf decoders,
independently of the Rust writer, and prints one JSON object:

  {"summary": {...}, "counts": {topic: n}, "schemas": {topic: [schema, encoding]},
   "errors": [...], "last": {topic: decoded last message}}

Grids are given with their cells (OccupancyGrid `data`; foxglove.Grid fields unpacked).
"""
import json
import struct
import sys

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory as ProtobufDecoderFactory
from mcap_ros2.decoder import DecoderFactory as Ros2DecoderFactory

from ros2_json import diagnostics, occupancy_grid


def ros2_grid(m):
    cells = struct.unpack(f"<{len(m.data)}b", bytes(bytearray(x & 0xFF for x in m.data)))
    return occupancy_grid(m, list(cells))


def foxglove_grid(m):
    fields = {f.name: (f.offset, f.type) for f in m.fields}
    data = bytes(m.data)
    n = len(data) // m.cell_stride
    out = {
        "frame_id": m.frame_id,
        "column_count": m.column_count,
        "cell_size": [m.cell_size.x, m.cell_size.y],
        "origin": [m.pose.position.x, m.pose.position.y],
        "row_stride": m.row_stride,
        "cell_stride": m.cell_stride,
        "fields": sorted(fields),
    }
    if "occupancy" in fields:
        off = fields["occupancy"][0]
        out["occupancy"] = [struct.unpack_from("<b", data, i * m.cell_stride + off)[0] for i in range(n)]
    if "log_odds" in fields:
        off = fields["log_odds"][0]
        vals = [struct.unpack_from("<f", data, i * m.cell_stride + off)[0] for i in range(n)]
        # Q8.8 raw cells (unknown = -32768), to compare with the device's.
        out["raw"] = [-32768 if v != v else int(round(v * 256.0)) for v in vals]
    return out


def main():
    path = sys.argv[1]
    counts, schemas, last, errors = {}, {}, {}, []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[Ros2DecoderFactory(), ProtobufDecoderFactory()])
        summary = reader.get_summary()
        info = {
            "chunks": len(summary.chunk_indexes) if summary else 0,
            "channels": len(summary.channels) if summary else 0,
            "message_count": summary.statistics.message_count if summary and summary.statistics else None,
            "compression": sorted({c.compression for c in summary.chunk_indexes}) if summary else [],
        }
        f.seek(0)
        reader = make_reader(f, decoder_factories=[Ros2DecoderFactory(), ProtobufDecoderFactory()])
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            topic = channel.topic
            counts[topic] = counts.get(topic, 0) + 1
            schemas[topic] = [schema.name, schema.encoding, channel.message_encoding]
            try:
                if schema.name == "nav_msgs/msg/OccupancyGrid":
                    last[topic] = ros2_grid(decoded)
                elif schema.name == "foxglove.Grid":
                    last[topic] = foxglove_grid(decoded)
                elif schema.name == "foxglove.PoseInFrame":
                    p = decoded.pose.position
                    last[topic] = {"frame_id": decoded.frame_id, "xy": [p.x, p.y]}
                elif schema.name == "foxglove.SceneUpdate":
                    e = decoded.entities[0]
                    last[topic] = {"id": e.id, "loops": [[[q.x, q.y] for q in l.points] for l in e.lines]}
                elif schema.name == "diagnostic_msgs/msg/DiagnosticArray":
                    last[topic] = diagnostics(decoded)
                else:
                    errors.append(f"unexpected schema {schema.name} on {topic}")
            except Exception as e:  # noqa: BLE001 - reported to the test
                errors.append(f"{topic}: {e!r}")
    print(json.dumps({"summary": info, "counts": counts, "schemas": schemas,
                      "errors": errors, "last": last}))


if __name__ == "__main__":
    main()
