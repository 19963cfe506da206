#!/usr/bin/python3
"""Independent ROS bag writer and reader for ctcal's tests (run by /usr/bin/python3).

  ros_bags.py ros1 DATA OUT.bag [--compression none|bz2|lz4] [--encoding E] [--bad WHAT]
  ros_bags.py ros2 DATA OUT_FOLDER [--encoding E] [--big-endian] [--bad WHAT]
  ros_bags.py dump X.bag

`ros1` writes a dataset folder (SPEC section 6) as a ROS1 bag through Debian's python3-rosbag
with messages generated from their definitions (genpy), `ros2` as a ROS2 bag (metadata.yaml and
one sqlite3 .db3) with its own CDR encoder; neither shares code with ctcal. Every sensor folder
with a data.csv is a topic: /<name> (sensor_msgs/Imu; a gyro's linear_acceleration zero) or
/<name>/image_raw (sensor_msgs/Image in encoding E, or sensor_msgs/CompressedImage for E = jpeg
or png). --bad writes one defect: stamps_back (the second message of the first sensor's topic,
in name order, stamped before its first: cam0's before imu0's), unknown_type (the first inertial topic as geometry_msgs/Vector3Stamped),
encoding (cameras in bayer_rggb8). `dump` prints one line per message: topic, type, header stamp
in ns, and for images encoding and size.
"""
import argparse
import functools
import os
import sqlite3
import struct
import sys

import cv2
import numpy as np

HEADER_DEF = """================================================================================
MSG: std_msgs/Header
uint32 seq
time stamp
string frame_id
"""
VECTOR3_DEF = """================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
"""
QUATERNION_DEF = """================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
"""
DEFS = {
    "sensor_msgs/Imu": "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n"
    "float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n"
    "float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n"
    "float64[9] linear_acceleration_covariance\n" + HEADER_DEF + QUATERNION_DEF + VECTOR3_DEF,
    "sensor_msgs/Image": "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n"
    "uint8 is_bigendian\nuint32 step\nuint8[] data\n" + HEADER_DEF,
    "sensor_msgs/CompressedImage": "std_msgs/Header header\nstring format\nuint8[] data\n"
    + HEADER_DEF,
    "geometry_msgs/Vector3Stamped": "std_msgs/Header header\ngeometry_msgs/Vector3 vector\n"
    + HEADER_DEF + VECTOR3_DEF,
}


def read_csv(path):
    rows = []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line and not line.startswith("#"):
                rows.append(line.split(","))
    return rows


def sensors_of(data):
    """(name, kind, rows) per sensor folder, kind imu / gyro / camera."""
    out = []
    for name in sorted(os.listdir(data)):
        csv = os.path.join(data, name, "data.csv")
        if name == "groundtruth" or not os.path.isfile(csv):
            continue
        rows = read_csv(csv)
        kind = {7: "imu", 4: "gyro", 2: "camera"}[len(rows[0])]
        out.append((name, kind, rows))
    return out


@functools.lru_cache(maxsize=64)  # a long recording may list the same few files again and again
def image_payload(path, encoding):
    """(width, height, step, bytes, big_endian) or (format, bytes) of one grey image."""
    grey = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if encoding in ("jpeg", "png"):
        ok, buf = cv2.imencode("." + ("jpg" if encoding == "jpeg" else "png"), grey,
                               [cv2.IMWRITE_JPEG_QUALITY, 98] if encoding == "jpeg" else [])
        assert ok
        return encoding, buf.tobytes()
    h, w = grey.shape
    if encoding in ("mono8", "bayer_rggb8"):
        px = grey
    elif encoding == "mono16":
        px = (grey.astype(np.uint16) * 257).astype(">u2")  # big-endian: exercises the swap
    elif encoding in ("rgb8", "bgr8"):
        px = np.dstack([grey, grey, grey])
    elif encoding in ("rgba8", "bgra8"):
        px = np.dstack([grey, grey, grey, np.full_like(grey, 255)])
    else:
        raise SystemExit("unknown encoding " + encoding)
    raw = np.ascontiguousarray(px).tobytes()
    return w, h, len(raw) // h, raw, encoding == "mono16"


def messages(data, encoding, bad):
    """Every message in time order: (t_ns, topic, type, fields, header stamp)."""
    out = []
    first_inertial = True
    topics = []
    for name, kind, rows in sensors_of(data):
        if kind == "camera":
            enc = "bayer_rggb8" if bad == "encoding" else encoding
            mtype = "sensor_msgs/CompressedImage" if enc in ("jpeg", "png") else "sensor_msgs/Image"
            topics.append("/%s/image_raw" % name)
            for r in rows:
                path = os.path.join(data, name, "data", r[1])
                out.append((int(r[0]), "/%s/image_raw" % name, mtype, (path, enc), int(r[0])))
        else:
            mtype = "sensor_msgs/Imu"
            if bad == "unknown_type" and first_inertial:
                mtype = "geometry_msgs/Vector3Stamped"
            first_inertial = False
            topics.append("/" + name)
            for r in rows:
                w = [float(x) for x in r[1:4]]
                a = [float(x) for x in r[4:7]] if kind == "imu" else [0.0, 0.0, 0.0]
                out.append((int(r[0]), "/" + name, mtype, (w, a), int(r[0])))
    out.sort(key=lambda m: m[0])
    if bad == "stamps_back":
        # The record keeps its place and time; only its header stamp goes back. The first sensor
        # by name, not the first message's topic: an IMU starting before the cameras would take
        # the defect away from the image topics.
        topic = topics[0]
        idx = [i for i, m in enumerate(out) if m[1] == topic][:2]
        m = out[idx[1]]
        out[idx[1]] = m[:4] + (out[idx[0]][0] - 1000,)
    return out


def write_ros1(args):
    import genpy
    import genpy.dynamic
    import rosbag
    classes = {t: genpy.dynamic.generate_dynamic(t, d)[t] for t, d in DEFS.items()}
    with rosbag.Bag(args.out, "w", compression=args.compression) as bag:
        for t, topic, mtype, fields, stamp in messages(args.data, args.encoding, args.bad):
            m = classes[mtype]()
            m.header.stamp = genpy.Time(stamp // 1000000000, stamp % 1000000000)
            m.header.frame_id = topic
            if mtype == "sensor_msgs/Imu":
                m.orientation.w = 1.0
                (m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z) = fields[0]
                (m.linear_acceleration.x, m.linear_acceleration.y,
                 m.linear_acceleration.z) = fields[1]
            elif mtype == "geometry_msgs/Vector3Stamped":
                (m.vector.x, m.vector.y, m.vector.z) = fields[0]
            else:
                p = image_payload(*fields)
                if mtype == "sensor_msgs/CompressedImage":
                    m.format, m.data = p
                else:
                    m.width, m.height, m.step, m.data, big = p
                    m.encoding = fields[1]
                    m.is_bigendian = 1 if big else 0
            bag.write(topic, m, genpy.Time(t // 1000000000, t % 1000000000))


class Cdr:
    """XCDR1 as Fast-CDR writes it: alignment counted from the end of the 4-byte header."""

    def __init__(self, big_endian):
        self.e = ">" if big_endian else "<"
        self.b = bytearray(b"\x00\x00\x00\x00" if big_endian else b"\x00\x01\x00\x00")

    def put(self, fmt, v):
        n = struct.calcsize(fmt)
        self.b += b"\x00" * ((-(len(self.b) - 4)) % n)
        self.b += struct.pack(self.e + fmt, v)

    def string(self, s):
        self.put("I", len(s) + 1)
        self.b += s.encode() + b"\x00"

    def octets(self, raw):
        self.put("I", len(raw))
        self.b += raw

    def header(self, t, frame):
        self.put("i", t // 1000000000)
        self.put("I", t % 1000000000)
        self.string(frame)


def cdr_message(t, topic, mtype, fields, big_endian):
    c = Cdr(big_endian)
    c.header(t, topic)
    if mtype == "sensor_msgs/Imu":
        for v in [0.0, 0.0, 0.0, 1.0] + [0.0] * 9 + list(fields[0]) + [0.0] * 9 + list(
                fields[1]) + [0.0] * 9:
            c.put("d", v)
    elif mtype == "geometry_msgs/Vector3Stamped":
        for v in fields[0]:
            c.put("d", v)
    elif mtype == "sensor_msgs/CompressedImage":
        fmt, raw = image_payload(*fields)
        c.string(fmt)
        c.octets(raw)
    else:
        w, h, step, raw, big = image_payload(*fields)
        c.put("I", h)
        c.put("I", w)
        c.string(fields[1])
        c.put("B", 1 if big else 0)
        c.put("I", step)
        c.octets(raw)
    return bytes(c.b)


def write_ros2(args):
    os.makedirs(args.out, exist_ok=True)
    name = os.path.basename(os.path.normpath(args.out)) + "_0.db3"
    db_path = os.path.join(args.out, name)
    if os.path.exists(db_path):
        os.remove(db_path)
    db = sqlite3.connect(db_path)
    db.executescript(
        "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);"
        "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,"
        " serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);"
        "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL,"
        " timestamp INTEGER NOT NULL, data BLOB NOT NULL);"
        "CREATE INDEX timestamp_idx ON messages (timestamp ASC);"
        "INSERT INTO schema VALUES (3, 'humble');")
    ids = {}
    counts = {}
    msgs = messages(args.data, args.encoding, args.bad)
    for t, topic, mtype, fields, stamp in msgs:
        if topic not in ids:
            ids[topic] = len(ids) + 1
            pkg, typ = mtype.split("/")
            db.execute("INSERT INTO topics VALUES (?, ?, ?, 'cdr', '')",
                       (ids[topic], topic, pkg + "/msg/" + typ))
        counts[topic] = counts.get(topic, 0) + 1
        db.execute("INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)",
                   (ids[topic], t, cdr_message(stamp, topic, mtype, fields, args.big_endian)))
    db.commit()
    db.close()
    with open(os.path.join(args.out, "metadata.yaml"), "w") as f:
        f.write("rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: %s\n"
                "  duration:\n    nanoseconds: %d\n  starting_time:\n"
                "    nanoseconds_since_epoch: %d\n  message_count: %d\n"
                "  relative_file_paths:\n    - %s\n" %
                (args.storage, msgs[-1][0] - msgs[0][0], msgs[0][0], len(msgs), name))


def dump(args):
    import rosbag
    with rosbag.Bag(args.bag) as bag:
        for topic, m, _ in bag.read_messages():
            t = m.header.stamp.to_nsec()
            if m._type == "sensor_msgs/Image":
                print(topic, m._type, t, m.encoding, m.width, m.height, len(m.data))
            elif m._type == "sensor_msgs/Imu":
                w, a = m.angular_velocity, m.linear_acceleration
                print(topic, m._type, t, repr(w.x), repr(w.y), repr(w.z), repr(a.x), repr(a.y),
                      repr(a.z))
            else:
                print(topic, m._type, t)


def main():
    p = argparse.ArgumentParser()
    sub = p.add_subparsers(dest="cmd", required=True)
    for cmd in ("ros1", "ros2"):
        s = sub.add_parser(cmd)
        s.add_argument("data")
        s.add_argument("out")
        s.add_argument("--encoding", default="mono8")
        s.add_argument("--bad", default="none")
        if cmd == "ros1":
            s.add_argument("--compression", default="none")
        else:
            s.add_argument("--big-endian", action="store_true")
            s.add_argument("--storage", default="sqlite3")
    d = sub.add_parser("dump")
    d.add_argument("bag")
    args = p.parse_args()
    {"ros1": write_ros1, "ros2": write_ros2, "dump": dump}[args.cmd](args)


if __name__ == "__main__":
    sys.exit(main())
