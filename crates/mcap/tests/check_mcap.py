#!/usr/bin/env python3
"""Development-time check that an MCAP file from `flexshape track --mcap` decodes with Foxglove's
Python readers (mcap + mcap-ros2-support), independently of our own CDR encoder.

    python3 -m venv /tmp/v && /tmp/v/bin/pip install mcap mcap-ros2-support
    flexshape simulate --out REC --frames 5
    flexshape track REC -o /tmp/run.jsonl --mcap /tmp/run.mcap --mcap-images   # or --mcap-images jpeg
    /tmp/v/bin/python crates/mcap/tests/check_mcap.py /tmp/run.mcap

Not run by the test command (the product and its tests need no Python).
"""
import sys
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
with open(sys.argv[1], "rb") as f:
    reader = make_reader(f, decoder_factories=[DecoderFactory()])
    summary = reader.get_summary()
    print("profile", reader.get_header().profile, "channels", len(summary.channels))
    seen = {}
    factory = DecoderFactory()
    import json
    for schema, channel, message in reader.iter_messages():
        if channel.message_encoding == "json":
            decoded = json.loads(message.data)
        else:
            decoded = factory.decoder_for(channel.message_encoding, schema)(message.data)
        seen.setdefault(channel.topic, 0)
        seen[channel.topic] += 1
        if seen[channel.topic] == 1:
            if schema.name == "nav_msgs/msg/Path":
                print(channel.topic, len(decoded.poses), decoded.poses[0].pose.position, decoded.header.frame_id)
            elif schema.name == "visualization_msgs/msg/MarkerArray":
                print(channel.topic, [(m.ns, m.type, len(m.points), round(m.scale.x, 4)) for m in decoded.markers])
            elif schema.name == "sensor_msgs/msg/PointCloud2":
                print(channel.topic, decoded.width, [f.name for f in decoded.fields], len(decoded.data))
            elif schema.name == "tf2_msgs/msg/TFMessage":
                print(channel.topic, [(t.child_frame_id, round(t.transform.translation.x, 3)) for t in decoded.transforms])
            elif schema.name == "sensor_msgs/msg/CameraInfo":
                print(channel.topic, decoded.width, decoded.height, decoded.distortion_model, list(decoded.k)[:3])
            elif schema.name == "sensor_msgs/msg/Image":
                print(channel.topic, decoded.width, decoded.height, decoded.encoding, len(decoded.data))
            elif schema.name == "sensor_msgs/msg/CompressedImage":
                print(channel.topic, decoded.format, len(decoded.data), bytes(decoded.data[:4]))
            else:
                print(channel.topic, schema.name, decoded["frame"], decoded["status"])
    print(seen)
    tf = [c for c in summary.channels.values() if c.topic == "/tf_static"]
    print("/tf_static QoS", tf[0].metadata.get("offered_qos_profiles", "none").replace("\n", " "))
