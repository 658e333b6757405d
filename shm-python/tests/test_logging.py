"""Loggers as rclpy's: what a node logs goes to stderr as rcutils prints it
and to /rosout as rcl_interfaces/msg/Log, under the node's logger name,
with the caller's file, function and line, as the levels admit; read by a
subscription and by our Rust command line."""

import inspect
import re
import subprocess
import threading

import shm_cdr
from conftest import HUB, run_python, session_env, shm_ros2

ROSOUT = shm_cdr.QoSProfile(depth=100, durability=shm_cdr.DurabilityPolicy.TRANSIENT_LOCAL)


def next_log(sub, name):
    """The next /rosout message of logger `name`."""
    while True:
        msg = sub.recv(timeout=20.0)
        assert msg is not None, f"nothing from {name} on /rosout"
        if msg.name == name:
            return msg


def test_a_node_s_logger_prints_and_publishes_what_its_level_admits(capfd):
    node = shm_cdr.Node("talker", namespace="/logging")
    logger = node.get_logger()
    assert logger.get_name() == "logging.talker"
    sub = node.create_subscription("rcl_interfaces/msg/Log", "/rosout", qos_profile=ROSOUT)

    assert not logger.debug("not at INFO")  # the default level is INFO
    line = inspect.currentframe().f_lineno + 1
    assert logger.info("hello from Python")
    msg = next_log(sub, "logging.talker")
    assert (msg.level, msg.msg) == (20, "hello from Python")
    assert msg.file == __file__
    assert msg.function == "test_a_node_s_logger_prints_and_publishes_what_its_level_admits"
    assert msg.line == line
    assert msg.stamp.sec > 1_600_000_000
    err = capfd.readouterr().err
    assert re.search(r"^\[INFO\] \[\d+\.\d{9}\] \[logging\.talker\]: hello from Python$", err, re.M), err
    assert "not at INFO" not in err

    child = logger.get_child("planner")
    assert child.get_name() == "logging.talker.planner"
    child.set_level(shm_cdr.LoggingSeverity.DEBUG)
    assert child.get_effective_level() == 10 and logger.get_effective_level() == 20
    assert child.is_enabled_for(10) and not logger.is_enabled_for(10)
    assert child.debug("planning")
    msg = next_log(sub, "logging.talker.planner")
    assert (msg.level, msg.msg) == (10, "planning")
    for method, level in [("warning", 30), ("warn", 30), ("error", 40), ("fatal", 50)]:
        assert getattr(logger, method)(method)
        msg = next_log(sub, "logging.talker")
        assert (msg.level, msg.msg) == (level, method)
    assert logger.dropped == 0


LOGGER = """
import time
import shm_cdr

node = shm_cdr.Node("chatty", namespace="/logging")
logger = node.get_logger()
deadline = time.monotonic() + 60
while time.monotonic() < deadline:
    logger.warning("from another process")
    time.sleep(0.05)
"""


def test_our_rust_command_line_reads_a_python_node_s_log():
    proc = run_python(LOGGER, session_env(connect=HUB))
    echo = subprocess.Popen(
        [shm_ros2(), "topic", "echo", "/rosout", "rcl_interfaces/msg/Log"],
        env=session_env(connect=HUB), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    watchdog = threading.Timer(60, echo.kill)
    watchdog.start()
    try:
        # Messages of other loggers on /rosout may come first.
        message = []
        for line in echo.stdout:
            if line.strip() == "---":
                if "name: logging.chatty" in message:
                    break
                message = []
            else:
                message.append(line.strip())
        assert "name: logging.chatty" in message, echo.stderr.read()
        assert "msg: from another process" in message, message
        assert "level: 30" in message, message
    finally:
        watchdog.cancel()
        echo.kill()
        proc.kill()
