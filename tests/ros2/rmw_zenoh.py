"""rmw_zenoh_cpp's conventions as the independent Python peers (services.py,
actions.py) speak them: GIDs, the 33-byte attachment, peer sessions."""
import json
import socket
import struct
import sys
import time
from pathlib import Path

import xxhash
import zenoh


def gid_of(token):
    """rmw_zenoh_cpp's GID: XXH3-128 of the liveliness token, low then high 64 bits, little-endian."""
    h = xxhash.xxh3_128_intdigest(token.encode())
    return struct.pack("<QQ", h & (2**64 - 1), h >> 64)


def attachment(seq, gid):
    """Sequence number, timestamp (ns), GID length 16 as LEB128, GID."""
    return struct.pack("<qqB", seq, time.time_ns(), 16) + gid


def parse_attachment(raw):
    """(sequence number, timestamp, GID), or None if it is not rmw_zenoh's."""
    if raw is None or len(raw) != 33 or raw[16] != 16:
        return None
    seq, stamp, _ = struct.unpack("<qqB", raw[:17])
    return seq, stamp, bytes(raw[17:])


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def open_session(endpoint, listen):
    """A peer session without multicast scouting, listening on or connecting to `endpoint`."""
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("listen/endpoints" if listen else "connect/endpoints", json.dumps([endpoint]))
    return zenoh.open(conf)


def rosidl_hash(type_name):
    """The RIHS01 hash rosidl installed for `pkg/kind/Name` (share/<pkg>/<kind>/<Name>.json)."""
    pkg, kind, name = type_name.split("/")
    path = Path(sys.prefix) / "share" / pkg / kind / f"{name}.json"
    if not path.exists() and kind in ("action", "srv"):
        # An action's parts (`Name_SendGoal`, …) and a service's event type
        # (`Name_Event`) are listed in the action's or service's file.
        path = path.with_name(f"{name.split('_')[0]}.json")
    desc = json.loads(path.read_text())
    return next(h["hash_string"] for h in desc["type_hashes"] if h["type_name"] == type_name)


def package_hashes(source, package, deps):
    """rosidl's RIHS01 hashes of the interface files of `package` in `source`
    (msg/, srv/, action/), computed by rosidl's own tools: rosidl_adapter to
    IDL, then rosidl_generator_type_description, with the installed `deps`."""
    import contextlib
    import io
    import tempfile
    from rosidl_adapter.action import convert_action_to_idl
    from rosidl_adapter.msg import convert_msg_to_idl
    from rosidl_adapter.srv import convert_srv_to_idl
    from rosidl_generator_type_description import generate_type_hash

    source = Path(source).resolve()
    share = Path(sys.prefix) / "share"
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        idl_tuples = []
        for kind, convert in (("msg", convert_msg_to_idl), ("srv", convert_srv_to_idl),
                              ("action", convert_action_to_idl)):
            for f in sorted((source / kind).glob(f"*.{kind}")):
                with contextlib.redirect_stdout(io.StringIO()):  # its "Reading input file" lines
                    idl = convert(source, package, f.relative_to(source), tmp / "idl")
                idl_tuples.append(f"{tmp / 'idl'}:{idl.relative_to(tmp / 'idl')}")
        args = {"package_name": package, "output_dir": str(tmp / "out"), "idl_tuples": idl_tuples,
                "include_paths": [f"{d}:{share / d}" for d in deps]}
        (tmp / "args.json").write_text(json.dumps(args))
        hashes = {}
        for path in generate_type_hash(str(tmp / "args.json")):
            for entry in json.loads(Path(path).read_text())["type_hashes"]:
                hashes[entry["type_name"]] = entry["hash_string"]
        return hashes


def call_raw(session, key, payload, seq, gid, tries=50):
    """Call the rmw_zenoh service on `key` with a serialized request: the first
    reply's bytes, or None if no server answered in `tries` attempts."""
    for _ in range(tries):
        replies = list(session.get(key, payload=payload, attachment=attachment(seq, gid),
                                   target=zenoh.QueryTarget.ALL_COMPLETE, timeout=10))
        oks = [r.ok for r in replies if r.ok is not None]
        if oks:
            return oks[0].payload.to_bytes()
        time.sleep(0.1)
    return None


def call(session, key, request, response_type, seq, gid, tries=50):
    """Call the rmw_zenoh service on `key` with rclpy's serialization: the first
    reply as a `response_type`, or None if no server answered in `tries` attempts."""
    from rclpy.serialization import deserialize_message, serialize_message
    reply = call_raw(session, key, serialize_message(request), seq, gid, tries)
    return None if reply is None else deserialize_message(reply, response_type)


def definition_lines(text):
    """An interface file's fields and constants, without comments or blank lines."""
    lines = (line.split("#", 1)[0].strip() for line in text.splitlines())
    return [line for line in lines if line]
