"""Reads a trajopt recording with rosbags (pip install rosbags), a ROS 2 bag library that
needs no ROS installation: its MCAP storage reader checks the `ros2` profile, and the
message types are registered from the ros2msg schema texts the file carries.

Usage: python3 replay/scripts/rosbags_read.py out/run.mcap
"""
import sys
from pathlib import Path
from rosbags.rosbag2.storage_mcap import McapReader
from rosbags.typesys import Stores, get_typestore, get_types_from_msg

r = McapReader(Path(sys.argv[1]))
r.open()
store = get_typestore(Stores.EMPTY)
for s in r.schemas.values():
    print("schema", s.name, s.encoding)
    store.register(get_types_from_msg(s.data, s.name))
n = 0
conns = r.connections
print("connections", [(c.topic, c.msgtype) for c in conns])
for conn, ts, data in r.messages(conns):
    m = store.deserialize_cdr(data, conn.msgtype)
    if conn.topic == "/planner/output":
        print("output", m.seq, m.status, m.iterations, len(m.v), float(m.v[0]))
    else:
        print("input", m.seq, m.scenario, len(m.kappa))
    n += 1
print("messages", n)
