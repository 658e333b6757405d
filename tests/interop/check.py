#!/usr/bin/env python3
"""Interop with software nobody here wrote: eclipse-zenoh (Python), rosbags and
pycdr2. One summary line per check; exit status 1 if any check fails.

1. Python reads us: the Rust `interop_publisher` (rmw_zenoh-style keys, SHM above
   the threshold) sends messages to this Python subscriber; each key expression
   and 33-byte attachment is checked, the payload decoded with rosbags and every
   field compared with what Rust says it sent.
2. We read Python: rosbags (little- and big-endian) and pycdr2 serialize messages
   that this script publishes; the Rust `interop_subscriber` decodes them with our
   types and prints what it got, compared here field by field.
3. Differential: thousands of random values of several shapes (`interop_differential`)
   must encode to the same bytes as rosbags (both byte orders) and pycdr2; values
   over a bound must be refused by us and by pycdr2 alike.

    python tests/interop/check.py <target dir with release examples>
"""
import dataclasses
import hashlib
import json
import os
import struct
import subprocess
import sys
import tempfile
import time

import numpy as np
import zenoh
from rosbags.typesys import Stores, get_typestore, get_types_from_msg

HERE = os.path.dirname(os.path.abspath(__file__))
EXAMPLES = sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "../../target/release/examples")

ts = get_typestore(Stores.ROS2_HUMBLE)
BATTERY_MSG = ("std_msgs/Header header\nfloat32 voltage\nfloat32[<=16] cells\nfloat64[3] temperatures\n"
               "bool charging\nbuiltin_interfaces/Time[] history\n")
ts.register(get_types_from_msg(BATTERY_MSG, "interop_msgs/msg/Battery"))
T = ts.types


def norm(v):
    """The normal form shared with examples/src/interop.rs."""
    if dataclasses.is_dataclass(v):
        # Message fields only: rosbags also lists `__msgtype__` and the ROS
        # constants (upper case) as dataclass fields.
        return {f.name: norm(getattr(v, f.name)) for f in dataclasses.fields(v)
                if not f.name.startswith("__") and not f.name.isupper()}
    if isinstance(v, np.ndarray):
        if v.dtype == np.uint8:
            return {"len": int(v.size), "sha256": hashlib.sha256(v.tobytes()).hexdigest()}
        return [norm(x) for x in v.tolist()]
    if isinstance(v, (list, tuple)):
        return [norm(x) for x in v]
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return float(v)
    return v


def open_session(listen):
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("listen/endpoints", json.dumps([listen]))
    return zenoh.open(conf)


def expected_key(topic, typename):
    pkg, _, name = typename.split("/")
    return f"0/{topic.strip('/')}/{pkg}::msg::dds_::{name}_/{ts.hash_rihs01(typename)}"


def python_reads_us(endpoint):
    session = open_session(endpoint)
    sub = session.declare_subscriber("0/**")
    with tempfile.TemporaryDirectory() as tmp:
        expected_path = os.path.join(tmp, "expected.json")
        proc = subprocess.Popen([os.path.join(EXAMPLES, "interop_publisher"), endpoint, expected_path, "2"])
        samples = []
        deadline = time.time() + 60
        while time.time() < deadline and len(samples) < 10:
            sample = sub.try_recv()
            if sample is None:
                if proc.poll() not in (None, 0):
                    break
                time.sleep(0.001)
                continue
            if str(sample.key_expr).startswith("0/parameter_events/"):
                continue  # the node's own parameter declarations, as every ROS 2 node makes them
            samples.append((str(sample.key_expr), sample.payload.as_shm() is not None,
                            sample.payload.to_bytes(), None if sample.attachment is None else sample.attachment.to_bytes()))
        rc = proc.wait(timeout=30)
        sent = json.load(open(expected_path)) if rc == 0 else []
    session.close()

    failures, shm_seen = [], 0
    if rc != 0 or len(samples) != len(sent):
        failures.append(f"publisher exit {rc}, {len(samples)} received, {len(sent)} sent")
    last_seq = {}
    for (key, is_shm, payload, attachment), want in zip(samples, sent):
        typename = want["type"]
        if key != want["key"] or key != expected_key(want["topic"], typename):
            failures.append(f"key {key} != {expected_key(want['topic'], typename)}")
        if attachment is None or len(attachment) != 33:
            failures.append(f"{key}: attachment {attachment!r}")
        else:
            seq, stamp, gid_len, gid = struct.unpack("<qqB16s", attachment)
            if gid_len != 16 or gid.hex() != want["gid"] or seq != want["seq"]:
                failures.append(f"{key}: attachment seq {seq} gid {gid.hex()} vs {want['seq']} {want['gid']}")
            if seq != last_seq.get(key, 0) + 1 or abs(time.time_ns() - stamp) > 120e9:
                failures.append(f"{key}: sequence {seq} after {last_seq.get(key)} or stamp {stamp}")
            last_seq[key] = seq
        got = norm(ts.deserialize_cdr(payload, typename))
        if got != want["value"]:
            failures.append(f"{key}: fields differ:\n  rosbags {json.dumps(got)[:400]}\n  sent    {json.dumps(want['value'])[:400]}")
        if want["kind"] in ("Shm", "Spliced") and not is_shm:
            failures.append(f"{key}: sent as {want['kind']} but not received as shared memory")
        shm_seen += is_shm
    print(f"python reads us: {len(samples)} received / {len(sent)} sent, {shm_seen} as shared memory, "
          f"{len(failures)} mismatches")
    for f in failures:
        print("  " + f)
    return not failures


def pycdr2_types():
    from pycdr2 import IdlStruct
    from pycdr2.types import array, float32, float64, int32, sequence, uint32

    @dataclasses.dataclass
    class Time(IdlStruct, typename="builtin_interfaces/msg/Time"):
        sec: int32
        nanosec: uint32

    @dataclasses.dataclass
    class Header(IdlStruct, typename="std_msgs/msg/Header"):
        stamp: Time
        frame_id: str

    @dataclasses.dataclass
    class JointState(IdlStruct, typename="sensor_msgs/msg/JointState"):
        header: Header
        name: sequence[str]
        position: sequence[float64]
        velocity: sequence[float64]
        effort: sequence[float64]

    @dataclasses.dataclass
    class Battery(IdlStruct, typename="interop_msgs/msg/Battery"):
        header: Header
        voltage: float32
        cells: sequence[float32, 16]
        temperatures: array[float64, 3]
        charging: bool
        history: sequence[Time]

    return Time, Header, JointState, Battery


def python_messages():
    """(kind, typename, rosbags value) to publish, plus pycdr2 twins."""
    Time, Header = T["builtin_interfaces/msg/Time"], T["std_msgs/msg/Header"]
    header = Header(stamp=Time(sec=-5, nanosec=999_999_999), frame_id="wörld/frame")
    cloud = T["sensor_msgs/msg/PointCloud2"](
        header=header, height=2, width=3,
        fields=[T["sensor_msgs/msg/PointField"](name=n, offset=4 * i, datatype=7, count=1) for i, n in enumerate("xyz")],
        is_bigendian=False, point_step=12, row_step=36,
        data=np.frombuffer(bytes(range(72)), dtype=np.uint8), is_dense=False)
    image = T["sensor_msgs/msg/Image"](header=header, height=100, width=100, encoding="mono8", is_bigendian=0,
                                       step=100, data=np.frombuffer(bytes(i % 256 for i in range(10_000)), dtype=np.uint8))
    joints = T["sensor_msgs/msg/JointState"](header=header, name=["a", "bb", ""],
                                             position=np.array([1.5, -2.0, 3e-300]), velocity=np.array([]),
                                             effort=np.array([0.1, 0.2, 0.3]))
    battery = T["interop_msgs/msg/Battery"](header=header, voltage=np.float32(12.5), cells=np.array([3.5, 3.25], dtype=np.float32),
                                           temperatures=np.array([1.0, 2.0, 3.0]), charging=True,
                                           history=[Time(sec=1, nanosec=2)])
    return [("cloud", "sensor_msgs/msg/PointCloud2", cloud), ("image", "sensor_msgs/msg/Image", image),
            ("joints", "sensor_msgs/msg/JointState", joints), ("header", "std_msgs/msg/Header", header),
            ("battery", "interop_msgs/msg/Battery", battery)]


def we_read_python(endpoint):
    PyTime, PyHeader, PyJointState, PyBattery = pycdr2_types()
    outgoing = []
    for kind, typename, value in python_messages():
        want = norm(value)
        for order, little in (("rosbags_le", True), ("rosbags_be", False)):
            outgoing.append((f"interop/{kind}/{order}", bytes(ts.serialize_cdr(value, typename, little_endian=little)), want))
        h = value.header if kind != "header" else value
        py_header = PyHeader(PyTime(h.stamp.sec, h.stamp.nanosec), h.frame_id)
        twin = {"header": py_header,
                "joints": PyJointState(py_header, list(value.name), list(value.position), list(value.velocity),
                                       list(value.effort)) if kind == "joints" else None,
                "battery": PyBattery(py_header, float(value.voltage), [float(c) for c in value.cells],
                                     list(value.temperatures), value.charging,
                                     [PyTime(t.sec, t.nanosec) for t in value.history]) if kind == "battery" else None}.get(kind)
        if twin is not None:
            data = twin.serialize()
            if data != outgoing[-2][1]:
                print(f"  note: pycdr2 and rosbags differ on {kind}")
            outgoing.append((f"interop/{kind}/pycdr2", data, want))

    session = open_session(endpoint)
    proc = subprocess.Popen([os.path.join(EXAMPLES, "interop_subscriber"), endpoint, str(len(outgoing))],
                            stdout=subprocess.PIPE, text=True)
    ready = proc.stdout.readline().strip()
    time.sleep(1.0)  # let the subscription reach this session
    for key, payload, _ in outgoing:
        session.put(key, payload)
    lines = [json.loads(proc.stdout.readline()) for _ in outgoing]
    rc = proc.wait(timeout=30)
    session.close()

    wanted = {key: want for key, _, want in outgoing}
    failures = []
    for line in lines:
        if "error" in line:
            failures.append(f"{line['key']}: {line['error']}")
        elif line["value"] != wanted[line["key"]]:
            failures.append(f"{line['key']}: decoded {json.dumps(line['value'])[:300]} != {json.dumps(wanted[line['key']])[:300]}")
    got = {line["key"] for line in lines}
    failures += [f"{k}: not received" for k in wanted if k not in got]
    writers = sorted({k.split("/")[2] for k in wanted})
    print(f"we read python: {len(lines)} decoded / {len(outgoing)} sent ({', '.join(writers)}; ready={ready == 'ready'}, "
          f"exit {rc}), {len(failures)} mismatches")
    for f in failures:
        print("  " + f)
    return not failures and rc == 0


DIFF_MSGS = [
    ("diff_msgs/msg/Scalars", "bool flag\nuint8 a\nint8 b\nuint16 c\nint16 d\nuint32 e\nint32 f\nuint64 g\nint64 h\n"
                              "float32 x\nfloat64 y\n"),
    ("diff_msgs/msg/Strings", "string s\nstring<=8 bs\nstring[] many\nstring[2] pair\n"),
    ("diff_msgs/msg/Seqs", "uint8 lead\nfloat64[] f\nint16[<=4] bi\nuint8[] blob\nbool[] flags\n"),
    ("diff_msgs/msg/Nested", "uint8 tag\nbuiltin_interfaces/Time[] stamps\ndiff_msgs/Seqs inner\nfloat32[3] arr\n"),
]
DTYPES = {"bool": np.bool_, "uint8": np.uint8, "int8": np.int8, "uint16": np.uint16, "int16": np.int16,
          "uint32": np.uint32, "int32": np.int32, "uint64": np.uint64, "int64": np.int64,
          "float32": np.float32, "float64": np.float64}


def build_rosbags(typename, value):
    """A rosbags message of `typename` from its JSON value, via rosbags' own field definitions."""
    def conv(desc, v):
        node, arg = desc
        if node.name == "NAME":
            return build_rosbags(arg, v)
        if node.name == "BASE":
            return np.float32(v) if arg[0] == "float32" else v
        (sub_node, sub_arg), _ = arg
        if sub_node.name == "BASE" and sub_arg[0] in DTYPES:
            return np.array(v, dtype=DTYPES[sub_arg[0]])
        return [conv((sub_node, sub_arg), x) for x in v]
    _, fields = ts.fielddefs[typename]
    return T[typename](**{name: conv(desc, value[name]) for name, desc in fields})


def pycdr2_builders():
    from pycdr2 import IdlStruct
    from pycdr2.types import (array, bounded_str, float32, float64, int8, int16, int32, int64, sequence,
                              uint8, uint16, uint32, uint64)
    Time = pycdr2_types()[0]

    @dataclasses.dataclass
    class Scalars(IdlStruct, typename="diff_msgs/msg/Scalars"):
        flag: bool
        a: uint8
        b: int8
        c: uint16
        d: int16
        e: uint32
        f: int32
        g: uint64
        h: int64
        x: float32
        y: float64

    @dataclasses.dataclass
    class Strings(IdlStruct, typename="diff_msgs/msg/Strings"):
        s: str
        bs: bounded_str[8]
        many: sequence[str]
        pair: array[str, 2]

    @dataclasses.dataclass
    class Seqs(IdlStruct, typename="diff_msgs/msg/Seqs"):
        lead: uint8
        f: sequence[float64]
        bi: sequence[int16, 4]
        blob: sequence[uint8]
        flags: sequence[bool]

    @dataclasses.dataclass
    class Nested(IdlStruct, typename="diff_msgs/msg/Nested"):
        tag: uint8
        stamps: sequence[Time]
        inner: Seqs
        arr: array[float32, 3]

    return {
        "diff_msgs/msg/Scalars": lambda v: Scalars(**v),
        "diff_msgs/msg/Strings": lambda v: Strings(**v),
        "diff_msgs/msg/Seqs": lambda v: Seqs(**v),
        "diff_msgs/msg/Nested": lambda v: Nested(v["tag"], [Time(**t) for t in v["stamps"]], Seqs(**v["inner"]), v["arr"]),
    }


def differential(count=4000, seed=20261121):
    for name, text in DIFF_MSGS:
        ts.register(get_types_from_msg(text, name))
    builders = pycdr2_builders()
    out = subprocess.run([os.path.join(EXAMPLES, "interop_differential"), str(count), str(seed)],
                         capture_output=True, text=True, check=True).stdout.splitlines()
    same, bound_errors, code_point_bounds, failures = 0, 0, 0, []
    for line in out:
        case = json.loads(line)
        typename, value = case["type"], case["value"]
        try:
            py = builders[typename](value).serialize().hex()
            py_error = None
        except Exception as e:  # pycdr2 enforces bounds by raising
            py, py_error = None, f"{type(e).__name__}: {e}"
        if "error" in case:
            if py_error is not None:
                bound_errors += 1
            elif typename == "diff_msgs/msg/Strings" and len(value["bs"]) <= 8 < len(value["bs"].encode()):
                # pycdr2 counts a string<=N bound in code points; we count bytes, as
                # rosidl's C++ typesupport (std::string::size(), the rmw_zenoh_cpp wire
                # path) does. Only this class of disagreement is tolerated.
                code_point_bounds += 1
            else:
                failures.append(f"{typename}: we refused ({case['error']}) but pycdr2 wrote {py[:60]}")
            continue
        le = bytes(ts.serialize_cdr(build_rosbags(typename, value), typename, little_endian=True)).hex()
        be = bytes(ts.serialize_cdr(build_rosbags(typename, value), typename, little_endian=False)).hex()
        if le != case["le"] or be != case["be"]:
            failures.append(f"{typename}: rosbags differs: {value}")
        elif py_error is not None:
            failures.append(f"{typename}: pycdr2 refused a value we and rosbags accept: {py_error}: {value}")
        elif py != case["le"]:
            failures.append(f"{typename}: pycdr2 differs: {value}")
        else:
            same += 1
    print(f"differential: {len(out)} random values of {len(DIFF_MSGS)} shapes: {same} byte-identical with rosbags "
          f"(LE and BE) and pycdr2, {bound_errors} over-bound values refused by us and by pycdr2, "
          f"{code_point_bounds} multi-byte strings within pycdr2's code-point bound but over our byte bound, "
          f"{len(failures)} mismatches")
    for f in failures[:10]:
        print("  " + f)
    return not failures


if __name__ == "__main__":
    ok = python_reads_us("tcp/127.0.0.1:17501")
    ok = we_read_python("tcp/127.0.0.1:17502") and ok
    ok = differential() and ok
    sys.exit(0 if ok else 1)
