#!/usr/bin/env python3
"""Services against an independent implementation of rmw_zenoh_cpp's conventions,
written here from its design document: Python eclipse-zenoh for the transport,
rclpy's `serialize_message`/`deserialize_message` (real rosidl typesupport) for
the CDR, rosidl's `.json` for the type hash, python-xxhash for GIDs.

1. Python serves, Rust calls: a complete queryable on the key rmw_zenoh_cpp
   would use for `/py_echo` (`test_msgs/srv/BasicTypes`), with an `SS` token.
   `interop_service client` makes 50 calls; each request must deserialize with
   rclpy to the values the Rust side built, carry sequence numbers 1..50 and one
   GID, which must be XXH3-128 of the Rust client's `SC` token (as a ROS graph
   computes it); each reply carries the request's sequence number and that GID.
2. Rust serves, Python calls: `interop_service server` serves `/rust_echo`; its
   `SS` token must name the service, its type and rosidl's hash, with the
   services' default QoS; 50 calls made with rclpy's bytes and rmw_zenoh's
   attachment come back with the echo, the call's sequence number and the
   caller's GID; a truncated request gets an error reply naming the byte.

    python tests/ros2/services.py <dir with the interop_service binary>
"""
import subprocess
import sys
import time
from pathlib import Path

import zenoh
from rclpy.serialization import deserialize_message, serialize_message
from test_msgs.srv import BasicTypes

from rmw_zenoh import attachment, free_port, gid_of, open_session, parse_attachment, rosidl_hash

BIN = Path(sys.argv[1] if len(sys.argv) > 1 else "target/release/examples") / "interop_service"
SERVICES_QOS = "::,10:,:,:,,"  # reliable, volatile, keep last 10, as rmw_zenoh_cpp 0.6.7 writes it
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
    return ok



def service_key(name, type_name):
    pkg, _, srv = type_name.split("/")
    return f"0/{name.strip('/')}/{pkg}::srv::dds_::{srv}_/{rosidl_hash(type_name)}"


def request(i):
    r = BasicTypes.Request()
    r.bool_value = i % 2 == 1
    r.float64_value = i * 0.5
    r.uint8_value = i % 256
    r.int16_value = -i
    r.uint32_value = i * 7
    r.int64_value = i * 1000 - 7
    r.string_value = f"call {i} ハロー"
    return r


FIELDS = [f for f in BasicTypes.Request.get_fields_and_field_types()]


def echo(req):
    resp = BasicTypes.Response()
    for f in FIELDS:
        setattr(resp, f, getattr(req, f))
    resp.int64_value = req.int64_value + 1
    return resp


def same(a, b):
    return all(getattr(a, f) == getattr(b, f) for f in FIELDS)


def tokens(session, kind):
    replies = session.liveliness().get("@ros2_lv/0/**", timeout=5)
    return [str(r.ok.key_expr) for r in replies if r.ok is not None and f"/{kind}/" in str(r.ok.key_expr)]


def python_serves_rust_calls(calls=50):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    session = open_session(endpoint, listen=True)
    key = service_key("/py_echo", "test_msgs/srv/BasicTypes")
    received = []

    def on_query(query):
        att = parse_attachment(None if query.attachment is None else query.attachment.to_bytes())
        req = deserialize_message(query.payload.to_bytes(), BasicTypes.Request)
        received.append((att, req, str(query.key_expr)))
        if att is None:
            query.reply_err("no rmw_zenoh attachment")
            return
        query.reply(key, serialize_message(echo(req)), attachment=attachment(att[0], att[2]))

    seen_tokens = []
    graph = session.liveliness().declare_subscriber("@ros2_lv/0/**", lambda s: seen_tokens.append(str(s.key_expr)),
                                                    history=True)
    queryable = session.declare_queryable(key, on_query, complete=True)
    token = session.liveliness().declare_token(
        f"@ros2_lv/0/{session.zid()}/0/1/SS/%/%/py_server/%py_echo/"
        f"test_msgs::srv::dds_::BasicTypes_/{rosidl_hash('test_msgs/srv/BasicTypes')}/{SERVICES_QOS}")
    proc = subprocess.run([str(BIN), "client", endpoint, str(calls)], capture_output=True, text=True, timeout=120)
    check(proc.returncode == 0 and proc.stdout.strip() == f"ok {calls}",
          f"Rust client: exit {proc.returncode}, {proc.stdout.strip()!r} {proc.stderr.strip()[-500:]!r}")
    # The client has gone by now: its token as the graph saw it arrive.
    sc = sorted({t for t in seen_tokens if "/SC/" in t and "/rust_client/%py_echo/" in t})
    graph.undeclare()
    token.undeclare()
    queryable.undeclare()
    session.close()

    check(len(received) == calls, f"Python server received {len(received)} of {calls} calls")
    check(all(k == key for _, _, k in received), f"request keys {set(k for _, _, k in received)} != {key}")
    seqs = [att[0] for att, _, _ in received if att]
    check(seqs == list(range(1, calls + 1)), f"sequence numbers {seqs[:5]}… not 1..{calls}")
    gids = {att[2] for att, _, _ in received if att}
    check(len(gids) == 1, f"{len(gids)} client GIDs")
    for i, (_, req, _) in enumerate(received):
        check(same(req, request(i)), f"call {i}: rclpy read {req}")
    print(f"python serves, rust calls: {len(received)}/{calls} calls, sequence numbers 1..{max(seqs, default=0)}, "
          f"{len(gids)} client GID")
    return gids, sc


def rust_serves_python_calls(calls=50):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    proc = subprocess.Popen([str(BIN), "server", endpoint], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True)
    check(proc.stdout.readline().strip() == "ready", "Rust server did not start")
    session = open_session(endpoint, listen=False)
    key = service_key("/rust_echo", "test_msgs/srv/BasicTypes")
    h = rosidl_hash("test_msgs/srv/BasicTypes")
    ss = []
    deadline = time.time() + 20
    while not ss and time.time() < deadline:
        # The echo service's token; the node's own services (parameters, type
        # description) are there too, as on every ROS 2 node.
        ss = [t for t in tokens(session, "SS") if "/rust_server/%rust_echo/" in t]
    check(len(ss) == 1 and ss[0].endswith(f"/SS/%/%/rust_server/%rust_echo/test_msgs::srv::dds_::BasicTypes_/{h}/"
                                          f"{SERVICES_QOS}"), f"SS token {ss}")

    my_token = (f"@ros2_lv/0/{session.zid()}/0/2/SC/%/%/py_client/%rust_echo/"
                f"test_msgs::srv::dds_::BasicTypes_/{h}/{SERVICES_QOS}")
    token = session.liveliness().declare_token(my_token)
    gid = gid_of(my_token)
    answered = 0
    for i in range(calls):
        replies = list(session.get(key, payload=serialize_message(request(i)), attachment=attachment(i + 1, gid),
                                   target=zenoh.QueryTarget.ALL_COMPLETE,
                                   consolidation=zenoh.ConsolidationMode.NONE, timeout=10))
        oks = [r.ok for r in replies if r.ok is not None]
        if not check(len(oks) == 1, f"call {i}: {len(replies)} replies, {len(oks)} ok"):
            continue
        att = parse_attachment(None if oks[0].attachment is None else oks[0].attachment.to_bytes())
        check(att is not None and att[0] == i + 1 and att[2] == gid, f"call {i}: reply attachment {att}")
        check(att is not None and abs(time.time_ns() - att[1]) < 60e9, f"call {i}: reply stamp {att}")
        resp = deserialize_message(oks[0].payload.to_bytes(), BasicTypes.Response)
        answered += check(same(resp, echo(request(i))), f"call {i}: rclpy read {resp}")

    truncated = serialize_message(request(3))[:12]
    replies = list(session.get(key, payload=truncated, attachment=attachment(calls + 1, gid),
                               target=zenoh.QueryTarget.ALL_COMPLETE, consolidation=zenoh.ConsolidationMode.NONE,
                               timeout=10))
    errs = [r.err.payload.to_string() for r in replies if r.err is not None]
    check(len(errs) == 1 and "at byte 12" in errs[0], f"truncated request: {errs}")
    token.undeclare()
    session.close()
    out, _ = proc.communicate("", timeout=30)
    check(proc.returncode == 0 and out.strip() == f"served {calls} malformed 1",
          f"Rust server: exit {proc.returncode}, {out.strip()!r}")
    print(f"rust serves, python calls: {answered}/{calls} answered with the echo, SS token {'ok' if ss else 'missing'}, "
          f"malformed request: {errs[:1]}")


def main():
    gids, sc = python_serves_rust_calls()
    if check(len(sc) == 1, f"SC tokens {sc}"):
        check(sc[0].endswith(f"/SC/%/%/rust_client/%py_echo/test_msgs::srv::dds_::BasicTypes_/"
                             f"{rosidl_hash('test_msgs/srv/BasicTypes')}/{SERVICES_QOS}"), f"SC token {sc[0]}")
        check(gids == {gid_of(sc[0])}, f"client GID {[g.hex() for g in gids]} != XXH3-128 of {sc[0]}")
    rust_serves_python_calls()
    for f in failures:
        print("  FAIL " + f)
    print(f"services: {len(failures)} failures")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
