#!/usr/bin/env python3
"""Development-time check that `flexshape --ros2` topics reach another DDS implementation as a
ROS 2 node would see them: Eclipse Cyclone DDS (ROS 2's default middleware in several
releases), through its Python binding, with the ROS 2 types declared here by their DDS names.

    python3 -m venv /tmp/v && /tmp/v/bin/pip install cyclonedds
    flexshape demo --no-viewer --frames 300 --ros2 57 &
    /tmp/v/bin/python crates/ros2/tests/check_cyclonedds.py 57

Not run by the test command (the product and its tests need no Python).
"""
import json
import sys
import time
from dataclasses import dataclass

import cyclonedds.idl.annotations as annotate
from cyclonedds.core import Qos, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int32, sequence, uint32
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic


@dataclass
@annotate.final
class Time_(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
@annotate.final
class Header_(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time_
    frame_id: str


@dataclass
@annotate.final
class Point_(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64
    y: float64
    z: float64


@dataclass
@annotate.final
class Quaternion_(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
@annotate.final
class Pose_(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point_
    orientation: Quaternion_


@dataclass
@annotate.final
class PoseStamped_(IdlStruct, typename="geometry_msgs::msg::dds_::PoseStamped_"):
    header: Header_
    pose: Pose_


@dataclass
@annotate.final
class Path_(IdlStruct, typename="nav_msgs::msg::dds_::Path_"):
    header: Header_
    poses: sequence[PoseStamped_]


@dataclass
@annotate.final
class String_(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    data: str


domain = int(sys.argv[1]) if len(sys.argv) > 1 else 0
node = DomainParticipant(domain)
qos = Qos(Policy.Reliability.Reliable(max_blocking_time=0))
paths = DataReader(node, Topic(node, "rt/flexshape/centerline", Path_), qos=qos)
records = DataReader(node, Topic(node, "rt/flexshape/record", String_), qos=qos)
got_paths, got_records = [], []
deadline = time.time() + 20
while time.time() < deadline and (len(got_paths) < 5 or len(got_records) < 5):
    got_paths += paths.take(N=10)
    got_records += records.take(N=10)
    time.sleep(0.05)
print(f"domain {domain}: {len(got_paths)} paths, {len(got_records)} records")
p = got_paths[0]
first, last = p.poses[0].pose.position, p.poses[-1].pose.position
print(f"path: {len(p.poses)} poses in {p.header.frame_id}, stamp {p.header.stamp.sec}.{p.header.stamp.nanosec:09d},"
      f" first ({first.x:.4f}, {first.y:.4f}, {first.z:.4f}) m, last ({last.x:.4f}, {last.y:.4f}, {last.z:.4f}) m")
r = json.loads(got_records[0].data)
print(f"record: frame {r['frame']}, status {r['status']}, {len(r['centerline'])} centerline points")
assert got_paths and got_records
