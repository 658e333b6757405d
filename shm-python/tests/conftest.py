"""Shared set-up: the test process's session (one per process, as rclpy's
context) listens on a port of its own, and every process a test starts
connects to it, configured as rmw_zenoh_cpp reads its configuration
(ZENOH_CONFIG_OVERRIDE), without a router."""

import os
import socket
import subprocess
import sys
import textwrap

import pytest


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def session_env(listen=None, connect=None, extra=None):
    """The environment of a process whose session listens on and/or connects
    to these ports, looking for no router."""
    overrides = ["scouting/multicast/enabled=false"]
    if listen is not None:
        overrides.append(f'listen/endpoints=["tcp/127.0.0.1:{listen}"]')
    if connect is not None:
        overrides.append(f'connect/endpoints=["tcp/127.0.0.1:{connect}"]')
    env = dict(os.environ)
    env["ZENOH_CONFIG_OVERRIDE"] = ";".join(overrides)
    env["ZENOH_ROUTER_CHECK_ATTEMPTS"] = "-1"
    env.update(extra or {})
    return env


# Before any node of this process opens its session.
HUB = free_port()
os.environ.update(session_env(listen=HUB))


def run_python(code, env, timeout=60):
    """Start `code` in another Python process."""
    return subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(code)],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def shm_ros2():
    """Our Rust command line (a RosNode), built by `cargo test --workspace`
    or named by SHM_ROS2; tests that need it are skipped without it."""
    path = os.environ.get("SHM_ROS2") or os.path.join(
        os.path.dirname(__file__), "..", "..", "target", "debug", "shm-ros2"
    )
    if not os.path.exists(path):
        pytest.skip(f"no shm-ros2 at {path} (build it, or set SHM_ROS2)")
    return path
