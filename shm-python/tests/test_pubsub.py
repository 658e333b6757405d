"""Processes: a Python publisher and this Python subscriber, through shared
memory and the network; and each against our Rust node (shm-ros2)."""

import subprocess
import time

import numpy as np
import pytest

import shm_cdr
from conftest import HUB, run_python, session_env, shm_ros2

PUBLISHER = """
import sys, time
import numpy as np
import shm_cdr

node = shm_cdr.Node("camera", namespace="/robot")
pub = node.create_publisher("sensor_msgs/msg/Image", "image")
if not pub.wait_for_subscribers(20.0):
    sys.exit("no subscriber came")
Image = shm_cdr.message_type("sensor_msgs/msg/Image")
height, width = {height}, {width}
kinds = []
for seq in range({count}):
    data = np.full(height * width * 3, seq % 251, dtype=np.uint8)
    data[:8] = np.arange(8, dtype=np.uint8)
    kinds.append(pub.publish(Image(height=height, width=width, encoding="rgb8", step=width * 3,
                                   data=data, header={{"frame_id": "cam", "stamp": {{"sec": seq}}}})))
    time.sleep(0.05)
print(" ".join(kinds))
time.sleep(1.0)
"""

node = None


def this_node():
    global node
    if node is None:
        node = shm_cdr.Node("viewer")
    return node


def images(topic, height, width, count, callback=None):
    """Start a publisher of `count` images; a subscription to them here."""
    pub = run_python(
        PUBLISHER.format(height=height, width=width, count=count),
        session_env(connect=HUB),
    )
    sub = this_node().create_subscription("sensor_msgs/msg/Image", "/robot/image", callback)
    return pub, sub


def receive(height, width, count):
    pub, sub = images("/robot/image", height, width, count)
    try:
        got = []
        while len(got) < count:
            msg = sub.recv(timeout=30.0)
            assert msg is not None, "nothing arrived"
            got.append(msg)
        out, err = pub.communicate(timeout=30)
        assert pub.returncode == 0, err
        return got, sub, out.split()
    finally:
        pub.kill()


def test_large_images_arrive_as_views_of_shared_memory():
    got, sub, kinds = receive(480, 640, 5)
    # The first image may go by the network while the publisher asks whether
    # this process's Zenoh session maps its pool; it says so, and every later one is in place.
    assert kinds[0] in ("shm", "receiver_pending"), kinds
    assert kinds[1:] == ["shm"] * 4, kinds
    for seq, msg in enumerate(got):
        assert msg.header.stamp.sec == seq and msg.header.frame_id == "cam"
        assert (msg.height, msg.width, msg.encoding) == (480, 640, "rgb8")
        data = msg.data
        assert data.shape == (480 * 640 * 3,) and data.dtype == np.uint8
        assert list(data[:8]) == list(range(8)) and int(data[-1]) == seq % 251
        assert msg.memory.is_shm == (kinds[seq] == "shm"), (seq, kinds)
        # No copy: the array views the sample where it lies, and keeps it.
        assert not data.flags.owndata and not data.flags.writeable
        assert isinstance(data.base, shm_cdr.SampleMemory)
    assert (sub.lost, sub.missed, sub.wrong_type) == (0, 0, 0)
    kept = got[-1].data
    del got
    assert int(kept[8]) == 4 and int(kept[-1]) == 4  # readable after its message is gone


def test_small_messages_come_by_the_network_as_views_of_its_buffer():
    got, sub, kinds = receive(2, 2, 3)
    assert kinds == ["heap"] * 3  # 12 bytes: below the pool's threshold
    for seq, msg in enumerate(got):
        assert not msg.memory.is_shm
        assert msg.header.stamp.sec == seq
        assert list(msg.data[:8]) == list(range(8))
        assert not msg.data.flags.owndata


def test_a_callback_s_exception_is_raised_by_spin():
    seen = []

    def on_image(msg):
        seen.append(msg.header.stamp.sec)
        if len(seen) == 3:
            raise RuntimeError("third")

    pub, sub = images("/robot/image", 2, 2, 20, on_image)
    try:
        with pytest.raises(RuntimeError, match="third"):
            shm_cdr.spin(timeout_sec=30.0)
        assert seen[:3] == [0, 1, 2]
    finally:
        pub.kill()
        assert this_node().destroy_subscription(sub)


def test_the_node_keeps_a_callback_s_subscription_until_destroyed():
    got = []
    # Not held here: the node keeps it, as rclpy's does.
    this_node().create_subscription("std_msgs/msg/String", "/kept", lambda m: got.append(m.data))
    pub = this_node().create_publisher("std_msgs/msg/String", "/kept")
    deadline = time.monotonic() + 20.0
    while not got and time.monotonic() < deadline:
        pub.publish({"data": "still here"})
        time.sleep(0.05)
    assert got and got[0] == "still here"


def test_our_rust_node_reads_what_python_publishes():
    cli = shm_ros2()
    pub = run_python(PUBLISHER.format(height=2, width=2, count=40), session_env(connect=HUB))
    try:
        echo = subprocess.run(
            [cli, "topic", "echo", "/robot/image", "sensor_msgs/msg/Image", "--once",
             "--field", "header"],
            env=session_env(connect=HUB), capture_output=True, text=True, timeout=60,
        )
        assert echo.returncode == 0, echo.stderr
        assert "frame_id: cam" in echo.stdout
    finally:
        pub.kill()


def test_python_reads_what_our_rust_node_publishes():
    cli = shm_ros2()
    sub = this_node().create_subscription("std_msgs/msg/String", "/chatter")
    pub = subprocess.Popen(
        [cli, "topic", "pub", "/chatter", "std_msgs/msg/String", "{data: from rust}",
         "--rate", "20", "--times", "200"],
        env=session_env(connect=HUB), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        text=True,
    )
    try:
        msg = sub.recv(timeout=30.0)
        assert msg is not None
        assert msg.data == "from rust"
        assert msg.type_name == "std_msgs/msg/String"
    finally:
        pub.kill()


LATCHED = """
import sys, time
import shm_cdr

node = shm_cdr.Node("map_server")
qos = shm_cdr.QoSProfile(depth=1, durability=shm_cdr.DurabilityPolicy.TRANSIENT_LOCAL)
pub = node.create_publisher("std_msgs/msg/String", "/latched", qos)
pub.publish({"data": "the map"})
print("published", flush=True)
time.sleep(30)
"""


def latched_publisher():
    pub = run_python(LATCHED, session_env(connect=HUB))
    assert pub.stdout.readline().strip() == "published", pub.stderr.read()
    return pub


def test_a_transient_local_subscription_gets_what_was_published_before_it():
    pub = latched_publisher()
    try:
        qos = shm_cdr.QoSProfile(depth=1, durability=shm_cdr.DurabilityPolicy.TRANSIENT_LOCAL)
        sub = this_node().create_subscription("std_msgs/msg/String", "/latched", qos_profile=qos)
        msg = sub.recv(timeout=20.0)
        assert msg is not None and msg.data == "the map"
    finally:
        pub.kill()


def test_qos_profiles_that_make_no_sense_are_refused():
    with pytest.raises(ValueError, match="durability 7"):
        this_node().create_subscription(
            "std_msgs/msg/String", "/x", qos_profile=shm_cdr.QoSProfile(durability=7))
    with pytest.raises(TypeError):
        this_node().create_subscription("std_msgs/msg/String", "/x", qos_profile="reliable")


def test_callback_exceptions_past_those_kept_for_spin_are_printed():
    code = """
import sys, time
import shm_cdr

node = shm_cdr.Node("raiser")
seen = []
def on_message(msg):
    seen.append(msg.data)
    raise ValueError("bad " + msg.data)
sub = node.create_subscription("std_msgs/msg/String", "/raise", on_message, qos_profile=50)
pub = node.create_publisher("std_msgs/msg/String", "/raise")
for i in range(20):
    pub.publish({"data": str(i)})
deadline = time.monotonic() + 20
while len(seen) < 20 and time.monotonic() < deadline:
    time.sleep(0.05)
try:
    shm_cdr.spin(timeout_sec=1.0)
except ValueError as e:
    print("raised", e)
"""
    proc = run_python(code, session_env())
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert out.strip() == "raised bad 0"
    # The first 16 wait for spin; the other 4 are printed with their traceback.
    assert err.count("ValueError: bad ") == 4, err
