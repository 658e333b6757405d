"""Messages of run-time types in one process: building, reading, errors."""

import numpy as np
import pytest

import shm_cdr


def test_a_standard_type_resolves_with_rosidl_s_hash_and_fields():
    image = shm_cdr.message_type("sensor_msgs/msg/Image")
    assert image.name == "sensor_msgs/msg/Image"
    assert image.hash.startswith("RIHS01_")
    fields = image.get_fields_and_field_types()
    assert list(fields) == [
        "header", "height", "width", "encoding", "is_bigendian", "step", "data",
    ]
    assert fields["data"] == "sequence<uint8>"
    assert fields["header"] == "std_msgs/Header"
    assert shm_cdr.message_type("sensor_msgs/Image") == image


def test_fields_are_attributes_with_defaults_and_set_values():
    Imu = shm_cdr.message_type("sensor_msgs/msg/Imu")
    msg = Imu(orientation={"w": 1.0})
    assert msg.orientation.w == 1.0
    assert msg.orientation.x == 0.0
    cov = msg.orientation_covariance
    assert isinstance(cov, np.ndarray) and cov.dtype == np.float64 and cov.shape == (9,)
    msg.header.frame_id = "imu"
    msg.header.stamp.sec = 12
    assert msg.header.frame_id == "imu"
    assert msg.header.stamp.sec == 12
    msg.orientation_covariance = np.arange(9, dtype=np.float64)
    assert list(msg.orientation_covariance) == list(range(9))
    assert msg.to_dict()["header"]["stamp"]["sec"] == 12
    assert "Imu(header=std_msgs.msg.Header(stamp=" in repr(msg)


def test_serialize_and_deserialize_round_trip():
    PointCloud2 = shm_cdr.message_type("sensor_msgs/msg/PointCloud2")
    fields = [
        {"name": n, "offset": 4 * i, "datatype": 7, "count": 1}
        for i, n in enumerate("xyz")
    ]
    data = np.arange(1200, dtype=np.uint8)
    msg = PointCloud2(height=1, width=100, fields=fields, point_step=12, row_step=1200, data=data)
    again = PointCloud2.deserialize(msg.serialize())
    assert again == msg
    assert [f.name for f in again.fields] == ["x", "y", "z"]
    assert again.fields[2].offset == 8
    # The decoded array views the bytes it was decoded from.
    assert not again.data.flags.owndata and not again.data.flags.writeable
    assert isinstance(again.data.base, shm_cdr.SampleMemory)
    np.testing.assert_array_equal(again.data, data)


def test_elements_of_message_arrays_change_their_message():
    PointCloud2 = shm_cdr.message_type("sensor_msgs/msg/PointCloud2")
    msg = PointCloud2(fields=[{"name": "x"}, {"name": "y"}])
    msg.fields[1].name = "intensity"
    assert [f.name for f in msg.fields] == ["x", "intensity"]


def test_unaligned_and_big_endian_arrays_read_correctly():
    Imu = shm_cdr.message_type("sensor_msgs/msg/Imu")
    msg = Imu(linear_acceleration_covariance=np.linspace(0.5, 4.5, 9))
    data = msg.serialize()
    view = Imu.deserialize(data).linear_acceleration_covariance
    np.testing.assert_array_equal(view, np.linspace(0.5, 4.5, 9))


def test_copies_are_independent():
    String = shm_cdr.message_type("std_msgs/msg/String")
    a = String(data="a")
    b = a.copy()
    b.data = "b"
    assert (a.data, b.data) == ("a", "b")
    assert a != b


@pytest.mark.parametrize(
    "field, value, error, words",
    [
        ("height", -1, OverflowError, "uint32"),
        ("height", 2**32, OverflowError, "out of its range"),
        ("height", 1.5, TypeError, "integer"),
        ("encoding", 5, TypeError, "str"),
        ("data", np.zeros(4, dtype=np.float32), TypeError, "astype"),
        ("data", np.zeros((2, 2), dtype=np.uint8), ValueError, "ravel"),
        ("nope", 1, AttributeError, "has no field 'nope'"),
        ("header", 7, TypeError, "dict"),
    ],
)
def test_wrong_values_raise_with_what_to_give(field, value, error, words):
    msg = shm_cdr.message_type("sensor_msgs/msg/Image")()
    with pytest.raises(error, match=words):
        setattr(msg, field, value)


def test_bounds_are_enforced():
    Range = shm_cdr.message_type("sensor_msgs/msg/Imu")
    with pytest.raises(ValueError):
        Range(orientation_covariance=[1.0, 2.0])


def test_float32_out_of_range_is_refused():
    Range = shm_cdr.message_type("sensor_msgs/msg/Range")
    with pytest.raises(OverflowError):
        Range(range=1e39)


def test_unknown_types_say_where_to_look():
    with pytest.raises(LookupError, match="interfaces="):
        shm_cdr.message_type("my_msgs/msg/Nothing")


def test_own_interface_files(tmp_path):
    pkg = tmp_path / "my_msgs" / "msg"
    pkg.mkdir(parents=True)
    (pkg / "Battery.msg").write_text("float32 voltage\nfloat32[] cells\nstring name\n")
    Battery = shm_cdr.message_type("my_msgs/msg/Battery", interfaces=[str(tmp_path)])
    msg = Battery(voltage=12.5, cells=[3.1, 3.2], name="main")
    again = Battery.deserialize(msg.serialize())
    assert again.voltage == 12.5 and again.name == "main"
    np.testing.assert_allclose(again.cells, [3.1, 3.2], rtol=1e-6)


def test_attributes_are_fields_first_then_methods_and_misses_name_the_fields():
    Pose = shm_cdr.message_type("geometry_msgs/msg/PoseStamped")
    msg = Pose()
    # Fields, nested fields and methods all read as before.
    assert msg.pose.position.x == 0.0
    assert msg.to_dict()["header"]["frame_id"] == ""
    assert callable(msg.serialize) and msg.type_name == "geometry_msgs/msg/PoseStamped"
    # A miss is an AttributeError naming the fields, and Python's helpers
    # that rely on it behave.
    with pytest.raises(AttributeError, match="has no field 'posture'; its fields are: header, pose"):
        msg.posture
    assert not hasattr(msg, "posture")
    assert getattr(msg.pose, "posture", 5) == 5
    # Setting a field of a message nested two deep changes the whole, as
    # its bytes show, and nothing else.
    msg.header.stamp.nanosec = 17
    msg.pose.orientation.w = 0.5
    back = Pose.deserialize(msg.serialize())
    assert back.header.stamp.nanosec == 17 and back.pose.orientation.w == 0.5
    assert back.header.stamp.sec == 0 and back.pose.orientation.z == 0.0
    with pytest.raises(TypeError):
        msg.header.stamp.nanosec = "x"
    assert msg.header.stamp.nanosec == 17
