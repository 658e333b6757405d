#!/usr/bin/env python3
"""Every generated interface type against real ROS 2 (Kilted wheels from PyPI: rclpy
with rmw_fastrtps_cpp's typesupport, and rosidl's own `.json` type descriptions).

1. Hashes: the RIHS01 hash of every message, service and action type that
   `ros2_types hashes` prints must equal the one in rosidl's `.json` files under
   `<venv>/share/<pkg>/{msg,srv,action}/`. tf2_msgs has no wheel: its hashes are
   compared with rosbags' (correct for it: it has no `char` field).
2. Differential: for every message type, random values (multi-byte UTF-8,
   empty and long sequences, extreme numbers, every field of every nested type)
   are serialized by rclpy (`serialize_message`: its bytes carry stale padding and
   up to 8 bytes past the end). `ros2_types roundtrip` decodes them with our
   types and re-encodes them; rclpy deserializes our bytes, and the result must
   equal the original value. The Rust side also checks that its exact size, its
   borrowing `…Ref` form and decoding into a kept value agree.

    python tests/ros2/check.py <dir with the ros2_types binary> [rounds per type]
"""
import importlib
import json
import math
import os
import random
import struct
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

from rclpy.serialization import deserialize_message, serialize_message
from rosidl_parser import definition as d

BIN = Path(sys.argv[1] if len(sys.argv) > 1 else "target/release/examples") / "ros2_types"
ROUNDS = int(sys.argv[2]) if len(sys.argv) > 2 else 20
SHARE = Path(sys.prefix) / "share"
rng = random.Random(20261122)

TEXT = ["", "a", "frame_id", "héllo wörld", "ハローワールド", "emoji \U0001f916", "x" * 300, "tab\tand\nnewline"]
WTEXT = ["", "a", "héllo", "ハロー", "long " * 40]  # wstring: BMP characters
INT_RANGES = {
    "int8": (-2**7, 2**7 - 1), "uint8": (0, 2**8 - 1), "int16": (-2**15, 2**15 - 1),
    "uint16": (0, 2**16 - 1), "int32": (-2**31, 2**31 - 1), "uint32": (0, 2**32 - 1),
    "int64": (-2**63, 2**63 - 1), "uint64": (0, 2**64 - 1), "char": (0, 255),
}
F32_EXTREMES = [0.0, -0.0, 1.5, -2.25, 3.4028234663852886e38, -3.4028234663852886e38, 1.401298464324817e-45,
                math.inf, -math.inf]
F64_EXTREMES = [0.0, -0.0, 1e-300, -1.7976931348623157e308, 1.7976931348623157e308, 5e-324, math.inf, -math.inf]


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def scalar(t):
    if isinstance(t, d.BasicType):
        n = t.typename
        if n == "boolean":
            return rng.random() < 0.5
        if n == "octet":
            return bytes([rng.randrange(256)])
        if n in INT_RANGES:
            lo, hi = INT_RANGES[n]
            return rng.choice([lo, hi, 0, rng.randint(lo, hi)])
        if n == "float":
            return f32(rng.choice(F32_EXTREMES + [rng.uniform(-1e6, 1e6)]))
        if n in ("double", "long double"):
            return rng.choice(F64_EXTREMES + [rng.uniform(-1e12, 1e12)])
        raise ValueError(f"basic type {n}")
    if isinstance(t, d.AbstractWString):
        s = rng.choice(WTEXT)
        if isinstance(t, d.BoundedWString):
            s = s[: t.maximum_size]
        return s
    if isinstance(t, d.AbstractString):
        s = rng.choice(TEXT)
        if isinstance(t, d.BoundedString):
            # Our bound counts UTF-8 bytes (as rosidl's C++ typesupport), rclpy's
            # characters: stay within both.
            while len(s.encode()) > t.maximum_size:
                s = s[:-1]
        return s
    if isinstance(t, d.NamespacedType):
        return random_message(message_class(t.namespaces, t.name))
    raise ValueError(f"type {t}")


def value(t):
    if isinstance(t, d.AbstractNestedType):
        inner = t.value_type
        if isinstance(t, d.Array):
            n = t.size
        elif isinstance(t, d.BoundedSequence):
            n = rng.choice([0, t.maximum_size, rng.randint(0, t.maximum_size)])
        else:
            n = rng.choice([0, 1, rng.randint(0, 12), 300])
        if isinstance(inner, d.NamespacedType) and n > 12:
            n = 12  # keep nested sequences small: the per-type count is what matters
        return [scalar(inner) for _ in range(n)]
    return scalar(t)


def random_message(cls):
    msg = cls()
    for slot, t in zip(cls.__slots__, cls.SLOT_TYPES):
        name = slot[1:]
        if name == "structure_needs_at_least_one_member":
            continue
        setattr(msg, name, value(t))
    return msg


_classes = {}


def message_class(namespaces, name):
    key = (tuple(namespaces), name)
    if key not in _classes:
        try:
            module = importlib.import_module(".".join(namespaces))
        except ModuleNotFoundError:
            _classes[key] = None
            return None
        cls = getattr(module, name, None)
        if cls is None:
            # Service and action parts live in the service's own module.
            for sub in os.listdir(os.path.dirname(module.__file__)):
                if sub.startswith("_") and sub.endswith(".py") and not sub.startswith("__"):
                    m = importlib.import_module(".".join(namespaces) + "." + sub[:-3])
                    cls = getattr(m, name, None)
                    if cls is not None:
                        break
        _classes[key] = cls
    return _classes[key]


def rosidl_hashes():
    hashes = {}
    for path in SHARE.glob("*/*/*.json"):
        if path.parent.name not in ("msg", "srv", "action"):
            continue
        try:
            doc = json.loads(path.read_text())
        except ValueError:
            continue
        for entry in doc.get("type_hashes", []):
            hashes[entry["type_name"]] = entry["hash_string"]
    return hashes


def check_hashes():
    ours = [line.split() for line in subprocess.run([BIN, "hashes"], check=True, capture_output=True,
                                                     text=True).stdout.splitlines()]
    oracle = rosidl_hashes()
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)
    per_package = defaultdict(lambda: [0, 0])
    failures = []
    for kind, name, ours_hash in ours:
        pkg = name.split("/")[0]
        expected = oracle.get(name)
        source = "rosidl"
        if expected is None and name in store.fielddefs:
            expected, source = store.hash_rihs01(name), "rosbags"
        per_package[pkg][1] += 1
        if expected == ours_hash:
            per_package[pkg][0] += 1
        else:
            failures.append(f"{kind} {name}: ours {ours_hash}, {source} {expected}")
    total = sum(v[1] for v in per_package.values())
    good = sum(v[0] for v in per_package.values())
    print(f"hashes: {good}/{total} equal to rosidl's .json (tf2_msgs: rosbags): "
          + ", ".join(f"{p} {g}/{n}" for p, (g, n) in sorted(per_package.items())))
    for f in failures[:20]:
        print("  MISMATCH", f)
    return [name for kind, name, _ in ours if kind == "message"], not failures


def check_roundtrips(names):
    proc = subprocess.Popen([BIN, "roundtrip"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    per_package = defaultdict(lambda: [0, 0])
    failures = []
    missing = []
    trailing = 0
    for name in names:
        pkg, ns, tname = name.split("/")
        cls = message_class([pkg, ns], tname)
        if cls is None:
            missing.append(name)
            continue
        for _ in range(ROUNDS):
            original = random_message(cls)
            theirs = serialize_message(original)
            proc.stdin.write(f"{name} {theirs.hex()}\n")
            proc.stdin.flush()
            reply = proc.stdout.readline().strip()
            per_package[pkg][1] += 1
            if not reply.startswith("ok "):
                failures.append(f"{name}: we could not read rclpy's bytes: {reply} ({theirs.hex()[:200]})")
                continue
            ours = bytes.fromhex(reply[3:])
            trailing += len(theirs) > len(ours)
            back = deserialize_message(ours, cls)
            if back != original:
                failures.append(f"{name}: rclpy reads our bytes as a different value ({ours.hex()[:200]})")
                continue
            per_package[pkg][0] += 1
    proc.stdin.close()
    proc.wait()
    total = sum(v[1] for v in per_package.values())
    good = sum(v[0] for v in per_package.values())
    print(f"differential: {good}/{total} random values of {len(names) - len(missing)} message types "
          f"rclpy -> ours -> rclpy equal ({trailing} of rclpy's encodings had bytes past the message): "
          + ", ".join(f"{p} {g}/{n}" for p, (g, n) in sorted(per_package.items())))
    if missing:
        print(f"  not in rclpy (no wheel; checked by hash only): {len(missing)}: {', '.join(sorted(missing))}")
    for f in failures[:20]:
        print("  FAIL", f)
    return not failures


def main():
    names, hashes_ok = check_hashes()
    roundtrips_ok = check_roundtrips(names)
    if not (hashes_ok and roundtrips_ok):
        sys.exit(1)


if __name__ == "__main__":
    main()
