"""A Python node's parameters: declared with defaults and --ros-args -p,
read and set in Python, and read and set by our Rust command line through
the node's parameter services."""

import subprocess

import pytest

import shm_cdr
from conftest import HUB, run_python, session_env, shm_ros2


@pytest.fixture(scope="module")
def node():
    return shm_cdr.Node("params", namespace="/py", args=["prog", "--ros-args", "-p", "rate:=5"])


def test_declared_values_and_command_line_overrides(node):
    assert node.declare_parameter("rate", 10).value == 5  # -p rate:=5 wins
    assert node.declare_parameter("frame", "cam").value == "cam"
    assert node.declare_parameter("gains", [0.5, 1.5]).value == [0.5, 1.5]
    assert node.get_parameter("frame").name == "frame"
    assert node.has_parameter("rate") and not node.has_parameter("nothing")
    with pytest.raises(LookupError, match="declare_parameter"):
        node.get_parameter("nothing")


def test_set_parameters_all_or_none_with_the_reason(node):
    node.declare_parameter("limit", 3)
    results = node.set_parameters({"limit": 4})
    assert [r.successful for r in results] == [True]
    assert node.get_parameter("limit").value == 4
    results = node.set_parameters([shm_cdr.Parameter("limit", "high")])
    assert not results[0].successful and results[0].reason
    assert node.get_parameter("limit").value == 4
    with pytest.raises(TypeError, match="one kind"):
        node.set_parameters({"limit": [1, "a"]})


def test_our_rust_command_line_reads_and_sets_a_python_node_s_parameters(node):
    cli = shm_ros2()
    node.declare_parameter("speed", 1.5)
    env = session_env(connect=HUB)
    got = subprocess.run([cli, "param", "get", "/py/params", "speed"], env=env,
                         capture_output=True, text=True, timeout=60)
    assert got.returncode == 0, got.stderr
    assert "1.5" in got.stdout
    done = subprocess.run([cli, "param", "set", "/py/params", "speed", "2.5"], env=env,
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert node.get_parameter("speed").value == 2.5


def test_a_node_is_subclassed_as_rclpy_s():
    class Talker(shm_cdr.Node):
        def __init__(self):
            super().__init__("talker", namespace="/sub", cli_args=["--ros-args", "-p", "n:=3"])
            self.count = self.declare_parameter("n", 1).value
            self.pub = self.create_publisher("std_msgs/msg/String", "chatter", 10)

    talker = Talker()
    assert talker.get_fully_qualified_name() == "/sub/talker"
    assert talker.count == 3
    assert talker.pub.publish({"data": "hi"}) == "heap"


INIT = """
import shm_cdr

shm_cdr.init(args=["prog", "--ros-args", "-r", "__ns:=/globally", "-p", "rate:=7"])
node = shm_cdr.Node("first")
print(node.get_fully_qualified_name(), node.declare_parameter("rate", 1).value)
own = shm_cdr.Node("second", cli_args=["--ros-args", "-r", "__node:=renamed", "-p", "rate:=9"])
print(own.get_fully_qualified_name(), own.declare_parameter("rate", 1).value)
"""


def test_init_s_arguments_apply_to_every_node_before_its_own():
    proc = run_python(INIT, session_env(connect=HUB))
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert out.split("\n")[:2] == ["/globally/first 7", "/globally/renamed 9"], out
