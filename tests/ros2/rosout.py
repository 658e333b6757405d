#!/usr/bin/env python3
"""/rosout read by an independent implementation of rmw_zenoh_cpp's conventions:
Python eclipse-zenoh for the transport, rclpy's `deserialize_message` (real rosidl
typesupport) for `rcl_interfaces/msg/Log`, rosidl's `.json` for the type hash.

`interop_rosout` runs a node `/demo/talker` whose `tracing` log goes to /rosout.
Its `MP` token must name /rosout, `rcl_interfaces::msg::dds_::Log_`, rosidl's hash
and a transient-local keep-last-1000 QoS (rclcpp's); each of its three log calls
must arrive as a Log that rclpy reads: logger name `demo.talker`, the level, the
message with its fields, the source file, module and line, a current stamp and
rmw_zenoh's attachment.

    python tests/ros2/rosout.py <dir with the interop_rosout binary>
"""
import subprocess
import sys
import time
from pathlib import Path

from rcl_interfaces.msg import Log
from rclpy.serialization import deserialize_message

from rmw_zenoh import free_port, open_session, parse_attachment, rosidl_hash

BIN = Path(sys.argv[1] if len(sys.argv) > 1 else "target/release/examples") / "interop_rosout"
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
    return ok



def main():
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    proc = subprocess.Popen([str(BIN), endpoint], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
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
    proc.stdin.write("go\n")
    proc.stdin.flush()
    check(proc.stdout.readline().strip() == "logged", "interop_rosout did not log")
    deadline = time.time() + 10
    while len(received) < 3 and time.time() < deadline:
        time.sleep(0.05)
    proc.stdin.close()
    proc.wait(timeout=30)
    subscriber.undeclare()
    session.close()

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

    if failures:
        for f in failures:
            print("FAIL:", f)
        sys.exit(1)


if __name__ == "__main__":
    main()
