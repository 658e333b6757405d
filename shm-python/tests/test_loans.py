"""Loans: a message built in its publisher's buffer, its sequences of numbers
writable numpy arrays where they are sent from; received by another Python
process as views of shared memory."""

import numpy as np
import pytest

import shm_cdr
from conftest import HUB, run_python, session_env

LOAN_PUBLISHER = """
import sys, time
import numpy as np
import shm_cdr

node = shm_cdr.Node("loaning_camera", namespace="/loans")
pub = node.create_publisher("sensor_msgs/msg/Image", "image")
if not pub.wait_for_subscribers(20.0):
    sys.exit("no subscriber came")
height, width = {height}, {width}
out = []
for seq in range({count}):
    loan = pub.loan({{"height": height, "width": width, "encoding": "rgb8", "step": width * 3,
                     "header": {{"frame_id": "cam"}}}}, data=height * width * 3)
    data = loan.data
    assert data.flags.writeable and not data.flags.owndata, data.flags
    assert isinstance(data.base, shm_cdr.LoanMemory), type(data.base)
    assert not data.any(), "a loan's arrays start zeroed"
    data.reshape(height, width, 3)[:, :, 0] = seq % 251
    data[:8] = np.arange(8, dtype=np.uint8)
    loan.header.stamp.sec = seq
    lent = loan.memory.kind
    out.append(lent + ":" + pub.publish(loan))
    assert not data.flags.writeable
    time.sleep(0.05)
print(" ".join(out))
time.sleep(1.0)
"""

node = None


def this_node():
    global node
    if node is None:
        node = shm_cdr.Node("loan_tests")
    return node


def test_a_loaned_image_arrives_in_shared_memory_as_built_in_place():
    height, width, count = 480, 640, 5
    pub = run_python(
        LOAN_PUBLISHER.format(height=height, width=width, count=count),
        session_env(connect=HUB),
    )
    sub = this_node().create_subscription("sensor_msgs/msg/Image", "/loans/image")
    try:
        got = []
        while len(got) < count:
            msg = sub.recv(timeout=30.0)
            assert msg is not None, "nothing arrived"
            got.append(msg)
        out, err = pub.communicate(timeout=30)
        assert pub.returncode == 0, err
    finally:
        pub.kill()
    kinds = out.split()
    # Lent from the pool; the first may go by the network while the
    # publisher asks whether this session maps its pool.
    assert all(k.startswith("shm:") for k in kinds), kinds
    assert kinds[0] in ("shm:shm", "shm:receiver_pending"), kinds
    assert kinds[1:] == ["shm:shm"] * (count - 1), kinds
    for seq, msg in enumerate(got):
        assert (msg.height, msg.width, msg.encoding, msg.step) == (height, width, "rgb8", width * 3)
        assert msg.header.stamp.sec == seq and msg.header.frame_id == "cam"
        pixels = msg.data.reshape(height, width, 3)
        assert list(msg.data[:8]) == list(range(8))
        assert int(pixels[height - 1, width - 1, 0]) == seq % 251
        assert int(pixels[height - 1, width - 1, 1]) == 0
        assert msg.memory.is_shm == (kinds[seq] == "shm:shm")
    assert (sub.lost, sub.missed, sub.wrong_type) == (0, 0, 0)


def image_loan(pub, frame_id="cam", n=12):
    return pub.loan({"height": 2, "width": 2, "encoding": "rgb8", "step": 6,
                     "header": {"frame_id": frame_id}}, data=n)


def test_a_loan_holds_the_message_it_is_published_as():
    pub = this_node().create_publisher("sensor_msgs/msg/Image", "/loans/alone")
    loan = image_loan(pub)
    assert loan.data.dtype == np.uint8 and loan.data.shape == (12,)
    assert not loan.data.any()
    loan.data[:] = np.arange(12, dtype=np.uint8)
    loan.header.stamp.nanosec = 7
    Image = shm_cdr.message_type("sensor_msgs/msg/Image")
    expected = Image(height=2, width=2, encoding="rgb8", step=6,
                     header={"frame_id": "cam", "stamp": {"nanosec": 7}},
                     data=np.arange(12, dtype=np.uint8))
    assert loan.to_message() == expected
    assert loan.to_message().serialize() == expected.serialize()
    assert len(loan.memory) == len(expected.serialize())
    assert "Loan of a sensor_msgs/msg/Image" in repr(loan)


def test_a_published_loan_is_spent_and_its_arrays_read_only():
    pub = this_node().create_publisher("sensor_msgs/msg/Image", "/loans/spent")
    loan = image_loan(pub)
    data = loan.data
    data[:] = 5
    assert pub.publish(loan) == "heap"  # 12 pixels: below the pool's threshold
    assert loan.memory.published and not data.flags.writeable
    assert int(data[11]) == 5  # still readable: the memory is kept for it
    with pytest.raises(RuntimeError, match="published already"):
        loan.data
    with pytest.raises(RuntimeError, match="published already"):
        pub.publish(loan)
    with pytest.raises(ValueError, match="read-only"):
        data[0] = 1


def test_floats_are_filled_in_place_with_numpy_s_rules():
    pub = this_node().create_publisher("sensor_msgs/msg/LaserScan", "/loans/scan")
    loan = pub.loan({"range_max": 30.0}, ranges=360, intensities=4)
    assert loan.ranges.dtype == np.dtype("<f4") and loan.ranges.shape == (360,)
    loan.ranges = np.linspace(0.5, 10.0, 360, dtype=np.float32)
    loan.intensities[:] = [1, 2, 3, 4]
    with pytest.raises(ValueError):
        loan.intensities = np.zeros(5, dtype=np.float32)  # numpy: shapes differ
    msg = loan.to_message()
    assert msg.range_max == 30.0
    assert np.array_equal(msg.ranges, np.linspace(0.5, 10.0, 360, dtype=np.float32))
    assert list(msg.intensities) == [1.0, 2.0, 3.0, 4.0]
    assert pub.publish(loan) in ("heap", "shm", "heap_fallback")


def test_a_string_that_changed_length_is_refused_and_the_loan_kept():
    pub = this_node().create_publisher("sensor_msgs/msg/Image", "/loans/moved")
    loan = image_loan(pub, frame_id="cam")
    loan.data[:] = 9
    loan.header.frame_id = "a_longer_frame"
    with pytest.raises(ValueError, match="data no longer lies where it was laid out"):
        pub.publish(loan)
    assert not loan.memory.published
    loan.header.frame_id = "arm"  # the same length as when it was laid out
    loan.width = 2  # a fixed-size field may change
    assert pub.publish(loan) == "heap"


def test_what_cannot_be_lent_is_named_with_what_to_do():
    node = this_node()
    pub = node.create_publisher("sensor_msgs/msg/Image", "/loans/errors")
    with pytest.raises(TypeError, match="loan\\(data=n\\); sensor_msgs/msg/Image has: data"):
        pub.loan()
    with pytest.raises(ValueError, match="no such field"):
        pub.loan(pixels=3)
    with pytest.raises(ValueError, match="not a sequence of numbers"):
        pub.loan(encoding=3)
    with pytest.raises(TypeError, match="an int, 0 or more"):
        pub.loan(data=-1)
    with pytest.raises(TypeError, match="a sensor_msgs/msg/Image or a dict"):
        pub.loan(3, data=4)
    other = node.create_publisher("sensor_msgs/msg/Image", "/loans/other")
    with pytest.raises(ValueError, match="another publisher"):
        other.publish(pub.loan(data=4))
    cloud = node.create_publisher("sensor_msgs/msg/PointCloud2", "/loans/cloud")
    loan = cloud.loan(data=32, zeroed=False)
    assert loan.data.shape == (32,)
    with pytest.raises(AttributeError):
        del loan.data


def test_a_loan_reads_its_fields_first_and_its_own_attributes_after_publishing():
    node = this_node()
    pub = node.create_publisher("sensor_msgs/msg/PointCloud2", "/loans/attributes")
    loan = pub.loan(data=8, zeroed=True)
    loan.header.stamp.sec = 3
    assert loan.header.stamp.sec == 3 and loan.data.shape == (8,)
    with pytest.raises(AttributeError, match="has no field 'pixels'"):
        loan.pixels
    pub.publish(loan)
    # The fields are spent; the loan's memory is still there to read.
    with pytest.raises(RuntimeError, match="published already"):
        loan.header
    with pytest.raises(RuntimeError, match="published already"):
        loan.data
    assert loan.memory.published
