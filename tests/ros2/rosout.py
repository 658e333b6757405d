#!/usr/bin/env python3
"""/rosout read by an independent implementation of rmw_zenoh_cpp's conventions:
Python eclipse-zenoh for the transport, rclpy's `deserialize_message` (real rosidl
typesupport) for `rcl_interfaces/msg/Log`, rosidl's `.json` for the type hash.

`interop_rosout` runs a node `/demo/talker` whose `tracing` log goes to /rosout.
Its `MP` token must name /rosout, `rcl_interfaces::msg::dds_::Log_`, rosidl's hash
and a transient-local keep-last-1000 QoS (rclcpp's); each of its three log calls
must arrive as a Log that rclpy reads: logger name `demo.talker`, the level, the
message with its fields, the source file, module and line, a current stamp and
rmw_zenoh's attachment; its debug message must not (the default level is INFO).

Logger levels, differential against rclpy: our node (started with
`--ros-args --log-level demo.talker.arm:=warn`) and an rclpy node with
`enable_logger_service` in this process (rclpy initialised with the same
arguments) are asked the same `~/get_logger_levels` and `~/set_logger_levels`
questions, valid and invalid levels among them; the replies must be equal. The
level set through the service then decides what reaches /rosout: at ERROR only
the error, at DEBUG all four.

    python tests/ros2/rosout.py <dir with the interop_rosout binary>
"""
import subprocess
import sys
import time
from pathlib import Path

import rclpy
from rcl_interfaces.msg import Log, LoggerLevel
from rcl_interfaces.srv import GetLoggerLevels, SetLoggerLevels
from rclpy.serialization import deserialize_message

from rmw_zenoh import call, free_port, gid_of, open_session, parse_attachment, rosidl_hash

BIN = Path(sys.argv[1] if len(sys.argv) > 1 else "target/release/examples") / "interop_rosout"
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
    return ok



SERVICE_KEY = "0/demo/talker/{service}/rcl_interfaces::srv::dds_::{name}_/{hash}"
CLIENT_TOKEN = "@ros2_lv/0/{zid}/0/1/NN/%/%/py_logger_client"


def ask_ours(session, service, request, response_type, seq):
    name = response_type.__qualname__.split("_Response")[0]
    key = SERVICE_KEY.format(service=service, name=name, hash=rosidl_hash(f"rcl_interfaces/srv/{name}"))
    return call(session, key, request, response_type, seq, gid_of(CLIENT_TOKEN.format(zid=session.zid())))


def set_request(pairs):
    return SetLoggerLevels.Request(levels=[LoggerLevel(name=n, level=l) for n, l in pairs])


def set_ours(session, pairs, seq):
    reply = ask_ours(session, "set_logger_levels", set_request(pairs), SetLoggerLevels.Response, seq)
    check(reply is not None and all(r.successful for r in reply.results), f"setting {pairs}: {reply}")


def logger_levels_differential(session, ros_args):
    """The same questions to our node's logger services and to rclpy's."""
    rclpy.init(args=ros_args)
    reference = rclpy.create_node("talker", namespace="/demo", enable_logger_service=True)
    service = reference._logger_service
    names = ["", "demo.talker", "demo.talker.arm", "demo", "x", "y", "w", "a.b", "a"]
    questions = [
        ("get_logger_levels", GetLoggerLevels.Request(names=names)),
        ("set_logger_levels", set_request([("demo.talker.arm", 40), ("x", 15), ("y", 0), ("w", 60),
                                           ("a.b", 20), ("demo", 30)])),
        ("get_logger_levels", GetLoggerLevels.Request(names=names)),
        ("set_logger_levels", set_request([("demo", 0), ("a.b", 50)])),
        ("get_logger_levels", GetLoggerLevels.Request(names=names + ["never.seen"])),
    ]
    equal = 0
    for seq, (name, request) in enumerate(questions, start=1):
        response_type = GetLoggerLevels.Response if name.startswith("get") else SetLoggerLevels.Response
        ours = ask_ours(session, name, request, response_type, seq)
        handler = service._get_logger_levels if name.startswith("get") else service._set_logger_levels
        theirs = handler(request, response_type())
        if check(ours is not None, f"{name}: no reply from our node"):
            equal += check(ours == theirs, f"{name} {request}:\n  ours   {ours}\n  rclpy  {theirs}")
    reference.destroy_node()
    rclpy.shutdown()
    return equal, len(questions)


def main():
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    ros_args = ["--ros-args", "--log-level", "demo.talker.arm:=warn"]
    proc = subprocess.Popen([str(BIN), endpoint] + ros_args, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True)
    check(proc.stdout.readline().strip() == "ready", "interop_rosout did not start")
    session = open_session(endpoint, listen=False)
    h = rosidl_hash("rcl_interfaces/msg/Log")
    key = f"0/rosout/rcl_interfaces::msg::dds_::Log_/{h}"
    received = []
    subscriber = session.declare_subscriber(key, lambda s: received.append(s))

    token = []
    deadline = time.time() + 20
    while not token and time.time() < deadline:
        replies = session.liveliness().get("@ros2_lv/0/**", timeout=5)
        token = [str(r.ok.key_expr) for r in replies
                 if r.ok is not None and "/MP/" in str(r.ok.key_expr) and "/talker/%rosout/" in str(r.ok.key_expr)]
    if check(len(token) == 1, f"/rosout MP token: {token}"):
        fields = token[0].split("/")
        check(fields[7:11] == ["%demo", "talker", "%rosout", "rcl_interfaces::msg::dds_::Log_"],
              f"token names {fields[7:11]}")
        check(fields[11] == h, f"token hash {fields[11]} != rosidl's {h}")
        # rclcpp's rcl_qos_profile_rosout_default as rmw_zenoh_cpp writes it:
        # reliable, transient local, keep last 1000, lifespan 10 s.
        check(fields[12] == ":1:,1000:,:10,0:,,", f"token QoS {fields[12]} is not rclcpp's /rosout QoS")

    time.sleep(0.5)
    started = time.time()

    def log_round(expected):
        """Have the node log its four messages; the levels that reached /rosout."""
        before = len(received)
        proc.stdin.write("go\n")
        proc.stdin.flush()
        check(proc.stdout.readline().strip() == "logged", "interop_rosout did not log")
        deadline = time.time() + 10
        while len(received) < before + expected and time.time() < deadline:
            time.sleep(0.05)
        time.sleep(0.3)  # anything more than expected would arrive meanwhile
        return [deserialize_message(s.payload.to_bytes(), Log).level for s in received[before:]]

    levels = log_round(3)
    check(levels == [Log.INFO, Log.WARN, Log.ERROR], f"at the default level, /rosout got levels {levels}")
    first_round = list(received)
    levels_equal, levels_asked = logger_levels_differential(session, ros_args)
    levels_at = {}
    for name, level, expected in (("error", 40, 1), ("debug", 10, 4)):
        set_ours(session, [("demo.talker", level)], 100 + level)
        levels_at[name] = log_round(expected)
    check(levels_at["error"] == [Log.ERROR], f"at ERROR, /rosout got levels {levels_at['error']}")
    check(levels_at["debug"] == [Log.DEBUG, Log.INFO, Log.WARN, Log.ERROR],
          f"at DEBUG, /rosout got levels {levels_at['debug']}")
    proc.stdin.close()
    proc.wait(timeout=30)
    subscriber.undeclare()
    session.close()

    received = first_round
    check(len(received) == 3, f"{len(received)} of 3 log messages arrived")
    logs = [deserialize_message(s.payload.to_bytes(), Log) for s in received]
    expected = [(Log.INFO, "moving speed=1.5"), (Log.WARN, "careful: ünïcode"), (Log.ERROR, "failed code=7")]
    for log, (level, msg), sample in zip(logs, expected, received):
        check(log.level == level, f"level {log.level} != {level}")
        check(log.msg == msg, f"msg {log.msg!r} != {msg!r}")
        check(log.name == "demo.talker", f"logger name {log.name!r}")
        check(log.file.endswith("interop_rosout.rs"), f"file {log.file!r}")
        check(log.function == "interop_rosout", f"function {log.function!r}")
        check(log.line > 0, f"line {log.line}")
        stamp = log.stamp.sec + log.stamp.nanosec * 1e-9
        check(abs(stamp - started) < 30, f"stamp {stamp} is not now ({started})")
        att = parse_attachment(None if sample.attachment is None else sample.attachment.to_bytes())
        check(att is not None, "no rmw_zenoh attachment")
    lines = [log.line for log in logs]
    check(lines == sorted(lines) and len(set(lines)) == 3, f"lines {lines}")
    print(f"/rosout: {len(logs)} Log messages read by rclpy: "
          + ", ".join(f"[{log.level}] {log.name}: {log.msg}" for log in logs))
    print(f"logger levels: {levels_equal}/{levels_asked} replies equal to rclpy's; /rosout at ERROR got levels "
          f"{levels_at['error']}, at DEBUG {levels_at['debug']}")

    if failures:
        for f in failures:
            print("FAIL:", f)
        sys.exit(1)


if __name__ == "__main__":
    main()
