#!/usr/bin/env python3
r"""Type descriptions, differential against rclpy: our node (`interop_type_description`,
a publisher of every generated message type, a server of every service type, an
action server of every action type) and an rclpy node (the Kilted wheels, in this
process) using the same types are asked the same `~/get_type_description`
questions: every type by its hash, with and without the type sources, and the
failures (a hash that does not parse, a type the node does not use). Our node is
asked over Zenoh with rclpy's serialization and rmw_zenoh's conventions; rclpy's
through its own service callback (rcl's implementation). The replies must be equal,
field by field: the descriptions with their default values, and the sources.

One known difference is checked exactly rather than left out: rcl answers from
the C typesupport, whose generator (rosidl_generator_c) embeds each source line
and string default as the body of Python's `repr()` of its UTF-8 bytes. A line
with a quote or a backslash comes back escaped (`"Hello\'world!"`), non-ASCII as
`\xc3\xb6`, and such a text is also cut short. Ours are the file's text and
rosidl's `.json` values (`tests/ros2/check.py`); where they differ, rclpy's must be
a prefix of that escaping of ours.

    python tests/ros2/type_description.py <dir with the interop_type_description binary>

With `ROS_DISTRO=jazzy` and Jazzy's wheels, our node speaks Jazzy and is
compared with Jazzy's rclpy: its sources must be Jazzy's files, whose comments
differ from Kilted's in places.

Then `shm-ros2 interface show` (beside the examples' folder), with the same
distribution, for every interface file the wheels install: the lines it shows
at the top level must be the file's own.
"""
import os
import subprocess
import sys
import time
from pathlib import Path

import rclpy
from rclpy.action import ActionServer
from type_description_interfaces.srv import GetTypeDescription

from check import message_class
from rmw_zenoh import call, free_port, gid_of, open_session, rosidl_hash

DISTRO = os.environ.get("ROS_DISTRO", "kilted")
BIN = Path(sys.argv[1] if len(sys.argv) > 1 else "target/release/examples") / "interop_type_description"
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
    return ok


def interface_class(name):
    pkg, ns, tname = name.split("/")
    return message_class([pkg, ns], tname)


def rclpy_node(types):
    """An rclpy node using each type rclpy has, as ours uses it; the names of
    the types it could use."""
    node = rclpy.create_node("td_node", namespace="/demo")
    used = set()
    for i, (kind, name) in enumerate(types):
        cls = interface_class(name)
        if cls is None:
            continue
        if kind == "message":
            node.create_publisher(cls, f"/td/topic_{i}", 1)
        elif kind == "service":
            node.create_service(cls, f"/td/service_{i}", lambda request, response: response)
        else:
            ActionServer(node, cls, f"/td/action_{i}", lambda goal: cls.Result())
        used.add(name)
    return node, used


def reply_fields(reply):
    """Everything a reply says, field by field, for a readable difference."""
    td = reply.type_description
    return {
        "successful": reply.successful,
        "failure_reason": reply.failure_reason,
        "type_description": td.type_description,
        "referenced_type_descriptions": list(td.referenced_type_descriptions),
        "type_sources": list(reply.type_sources),
        "extra_information": list(reply.extra_information),
    }


def c_embedded(text):
    """What rosidl_generator_c's typesupport reports for `text`: each line as the
    body of `repr()` of its UTF-8 bytes."""
    return "\n".join(repr(line.encode("utf-8"))[2:-1] for line in text.split("\n"))


escaped = {"sources": 0, "defaults": 0}


def reconcile(ours, theirs):
    """Replace in `theirs` what differs from `ours` only by rosidl_generator_c's
    escaping, counting it."""
    for a, b in zip(ours.type_sources, theirs.type_sources):
        if a.raw_file_contents != b.raw_file_contents and c_embedded(a.raw_file_contents).startswith(b.raw_file_contents):
            b.raw_file_contents = a.raw_file_contents
            escaped["sources"] += 1
    described = lambda r: [r.type_description.type_description] + list(r.type_description.referenced_type_descriptions)
    for da, db in zip(described(ours), described(theirs)):
        for fa, fb in zip(da.fields, db.fields):
            if fa.default_value != fb.default_value and c_embedded(fa.default_value).startswith(fb.default_value):
                fb.default_value = fa.default_value
                escaped["defaults"] += 1


def check_interface_show():
    """`shm-ros2 interface show` of every interface file the wheels install,
    as released for DISTRO: its top-level lines are the file's lines."""
    cli = BIN.parent.parent / "shm-ros2"
    share = Path(sys.prefix) / "share"
    files = sorted(f for kind in ("msg", "srv", "action") for f in share.glob(f"*/{kind}/*.{kind}"))
    shown = equal = 0
    for f in files:
        name = f"{f.parent.parent.name}/{f.parent.name}/{f.stem}"
        out = subprocess.run([str(cli), "interface", "show", name, "--distro", DISTRO],
                             capture_output=True, text=True)
        if out.returncode != 0:
            # A package this build does not carry (rclpy's own test types).
            check("not a standard interface" in out.stderr, f"interface show {name}: {out.stderr.strip()}")
            continue
        shown += 1
        top = [line for line in out.stdout.splitlines() if not line.startswith("\t")]
        want = [line.rstrip() for line in f.read_text().splitlines()]
        if top == want:
            equal += 1
        else:
            line = next(i for i, (a, b) in enumerate(zip(top + [None], want + [None])) if a != b)
            check(False, f"interface show {name} --distro {DISTRO}: line {line + 1} is "
                  f"{(top + [None])[line]!r}, the file's {(want + [None])[line]!r}")
    check(shown > 0, "interface show: no interface file was shown")
    print(f"interface show --distro {DISTRO}: {equal}/{shown} interface files shown as the wheels install them")


def first_difference(ours, theirs):
    reconcile(ours, theirs)
    a, b = reply_fields(ours), reply_fields(theirs)
    for key in a:
        if a[key] != b[key]:
            return f"{key}:\n    ours   {str(a[key])[:700]}\n    rclpy  {str(b[key])[:700]}"
    return None


def main():
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    proc = subprocess.Popen([str(BIN), endpoint], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    types, hashes = [], {}
    for line in proc.stdout:
        line = line.strip()
        if line == "ready":
            break
        kind, name, type_hash = line.split()
        types.append((kind, name))
        hashes[name] = type_hash
    check(len(types) > 0, "interop_type_description declared nothing")

    rclpy.init()
    reference, used = rclpy_node(types)
    # The node's own services and topics, which both nodes use.
    for name in ("type_description_interfaces/srv/GetTypeDescription", "rcl_interfaces/msg/Log"):
        hashes.setdefault(name, rosidl_hash(name))
        used.add(name)

    session = open_session(endpoint, listen=False)
    token = f"@ros2_lv/0/{session.zid()}/0/1/NN/%/%/py_type_description_client"
    live = session.liveliness().declare_token(token)
    gid = gid_of(token)
    key = ("0/demo/td_node/get_type_description/type_description_interfaces::srv::dds_::GetTypeDescription_/"
           + rosidl_hash("type_description_interfaces/srv/GetTypeDescription"))
    time.sleep(0.5)

    def ask_both(request, seq):
        ours = call(session, key, request, GetTypeDescription.Response, seq, gid)
        theirs = reference._type_description_service._service_callback(request, GetTypeDescription.Response())
        return ours, theirs

    questions = []
    for name in sorted(used):
        questions.append((name, GetTypeDescription.Request(type_name=name, type_hash=hashes[name],
                                                           include_type_sources=True)))
        questions.append((name + " (no sources)", GetTypeDescription.Request(
            type_name=name, type_hash=hashes[name], include_type_sources=False)))
    some_hash = hashes["rcl_interfaces/msg/Log"]
    questions += [
        ("hash of another name", GetTypeDescription.Request(type_name="std_msgs/msg/Bool", type_hash=some_hash)),
        ("upper-case hash", GetTypeDescription.Request(type_hash="RIHS01_" + some_hash[7:].upper())),
        ("unused type", GetTypeDescription.Request(type_hash="RIHS01_" + "ab" * 32)),
        ("unparsable hash", GetTypeDescription.Request(type_hash="RIHS01_1234")),
        ("version 2 hash", GetTypeDescription.Request(type_hash="RIHS02_" + some_hash[7:])),
        ("empty hash", GetTypeDescription.Request()),
    ]
    equal = sources = 0
    for seq, (what, request) in enumerate(questions, start=1):
        ours, theirs = ask_both(request, seq)
        if not check(ours is not None, f"{what}: no reply from our node"):
            continue
        difference = first_difference(ours, theirs)
        if check(difference is None, f"{what}: {difference}"):
            equal += 1
            sources += len(ours.type_sources)
    successful = sum(1 for _, r in questions if r.include_type_sources and r.type_hash in hashes.values())

    live.undeclare()
    session.close()
    proc.stdin.close()
    proc.wait(timeout=30)
    check(proc.returncode == 0, f"interop_type_description exited with {proc.returncode}")
    reference.destroy_node()
    rclpy.shutdown()
    skipped = sorted({name for _, name in types} - used)
    print(f"type description: {equal}/{len(questions)} replies equal to rclpy's ({len(used)} types, "
          f"each with and without sources, {sources} type sources compared, 6 failure cases; "
          f"rosidl_generator_c's escaping: {escaped['sources']} sources, {escaped['defaults']} default values)"
          + (f"; not in rclpy (no wheel): {len(skipped)} types" if skipped else ""))
    check_interface_show()
    if failures:
        for f in failures[:20]:
            print("FAIL:", f)
        sys.exit(1)


if __name__ == "__main__":
    main()
