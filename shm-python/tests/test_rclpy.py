"""Against rclpy (the Kilted wheels): what rclpy serializes reads back field
by field, and what we serialize rclpy reads back as the same message (byte
for byte where the encoding has no padding: rclpy's carries stale bytes
there). Skipped where rclpy is not installed."""

import numpy as np
import pytest

import shm_cdr

rclpy_serialization = pytest.importorskip("rclpy.serialization")
sensor_msgs = pytest.importorskip("sensor_msgs.msg")
geometry_msgs = pytest.importorskip("geometry_msgs.msg")
std_msgs = pytest.importorskip("std_msgs.msg")


def ours(name, **fields):
    return shm_cdr.message_type(name)(**fields)


def test_an_image_reads_back_in_rclpy_as_the_same_image():
    data = np.arange(3 * 4 * 5, dtype=np.uint8)
    theirs = sensor_msgs.Image(height=4, width=5, encoding="rgb8", step=15, data=data.tobytes())
    theirs.header.frame_id = "cam"
    theirs.header.stamp.sec = 3
    mine = ours("sensor_msgs/msg/Image", height=4, width=5, encoding="rgb8", step=15, data=data,
                header={"frame_id": "cam", "stamp": {"sec": 3}})
    assert rclpy_serialization.deserialize_message(mine.serialize(), sensor_msgs.Image) == theirs


def test_messages_without_padding_encode_as_rclpy_encodes_them():
    point = geometry_msgs.Point(x=1.5, y=-2.0, z=1e300)
    mine = ours("geometry_msgs/msg/Point", x=1.5, y=-2.0, z=1e300)
    assert mine.serialize() == rclpy_serialization.serialize_message(point)
    text = "ünïcode ✓"
    mine = ours("std_msgs/msg/String", data=text)
    assert mine.serialize() == rclpy_serialization.serialize_message(std_msgs.String(data=text))


def test_imu_and_pointcloud_read_back_field_by_field():
    imu = sensor_msgs.Imu()
    imu.header.frame_id = "imu_link"
    imu.orientation.w = 0.5
    imu.angular_velocity.z = -1.25
    imu.orientation_covariance = [float(i) / 7 for i in range(9)]
    mine = shm_cdr.message_type("sensor_msgs/msg/Imu").deserialize(
        rclpy_serialization.serialize_message(imu))
    assert mine.header.frame_id == "imu_link"
    assert mine.orientation.w == 0.5 and mine.angular_velocity.z == -1.25
    np.testing.assert_array_equal(mine.orientation_covariance, imu.orientation_covariance)
    assert rclpy_serialization.deserialize_message(mine.serialize(), sensor_msgs.Imu) == imu

    cloud = sensor_msgs.PointCloud2()
    cloud.fields = [sensor_msgs.PointField(name=n, offset=4 * i, datatype=7, count=1)
                    for i, n in enumerate("xyz")]
    cloud.width, cloud.height, cloud.point_step, cloud.row_step = 10, 1, 12, 120
    cloud.data = np.arange(120, dtype=np.uint8).tobytes()
    mine = shm_cdr.message_type("sensor_msgs/msg/PointCloud2").deserialize(
        rclpy_serialization.serialize_message(cloud))
    assert [f.name for f in mine.fields] == ["x", "y", "z"]
    assert [f.offset for f in mine.fields] == [0, 4, 8]
    np.testing.assert_array_equal(mine.data, np.arange(120, dtype=np.uint8))


@pytest.mark.parametrize("seed", range(20))
def test_random_values_of_many_fields_match_rclpy(seed):
    rng = np.random.default_rng(seed)
    theirs = geometry_msgs.PoseWithCovarianceStamped()
    theirs.header.frame_id = "map" * int(rng.integers(0, 5))
    theirs.header.stamp.sec = int(rng.integers(-2**31, 2**31))
    theirs.header.stamp.nanosec = int(rng.integers(0, 2**32))
    theirs.pose.pose.position.x = float(rng.normal())
    theirs.pose.pose.orientation.w = float(rng.normal())
    theirs.pose.covariance = rng.normal(size=36)
    data = rclpy_serialization.serialize_message(theirs)
    mine = shm_cdr.message_type("geometry_msgs/msg/PoseWithCovarianceStamped").deserialize(data)
    assert mine.header.stamp.nanosec == theirs.header.stamp.nanosec
    assert mine.header.stamp.sec == theirs.header.stamp.sec
    np.testing.assert_array_equal(mine.pose.covariance, theirs.pose.covariance)
    back = rclpy_serialization.deserialize_message
    kind = geometry_msgs.PoseWithCovarianceStamped
    assert back(mine.serialize(), kind) == theirs
    rebuilt = shm_cdr.message_type("geometry_msgs/msg/PoseWithCovarianceStamped").from_dict(mine.to_dict())
    assert back(rebuilt.serialize(), kind) == theirs


def test_rclpy_s_own_qos_profile_is_taken():
    from rclpy.qos import DurabilityPolicy, QoSProfile

    from test_pubsub import latched_publisher, this_node

    pub = latched_publisher()
    try:
        qos = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        sub = this_node().create_subscription("std_msgs/msg/String", "/latched", qos_profile=qos)
        msg = sub.recv(timeout=20.0)
        assert msg is not None and msg.data == "the map"
    finally:
        pub.kill()


def rclpy_interfaces(kind):
    """Every message class (`kind` "msg") or service class ("srv") of the
    interface packages installed beside rclpy, by `pkg/kind/Name`."""
    import importlib
    import importlib.util
    import pkgutil

    found = {}
    for module in pkgutil.iter_modules():
        # Interface packages by rosidl's naming, never importing others.
        if not module.name.endswith(("_msgs", "_interfaces")):
            continue
        try:
            spec = importlib.util.find_spec(f"{module.name}.{kind}")
        except (ImportError, ValueError):
            continue
        if spec is None:
            continue
        package = importlib.import_module(f"{module.name}.{kind}")
        for name, cls in vars(package).items():
            if isinstance(cls, type) and cls.__module__.startswith(f"{module.name}.{kind}."):
                found[f"{module.name}/{kind}/{name}"] = cls
    return found


def test_fields_and_their_types_are_named_as_rclpy_names_them():
    compared = 0
    for name, cls in rclpy_interfaces("msg").items():
        try:
            ty = shm_cdr.message_type(name)
        except LookupError:
            continue  # not in the standard set built in
        assert ty.get_fields_and_field_types() == cls.get_fields_and_field_types(), name
        compared += 1
    for name, cls in rclpy_interfaces("srv").items():
        try:
            srv = shm_cdr.service_type(name)
        except LookupError:
            continue
        assert srv.Request.get_fields_and_field_types() == cls.Request.get_fields_and_field_types(), name
        assert srv.Response.get_fields_and_field_types() == cls.Response.get_fields_and_field_types(), name
        compared += 1
    assert compared > 100, compared


def test_an_empty_message_shows_no_member_as_rclpy_shows_none():
    from rcl_interfaces.msg import ParameterType

    ParameterTypeOurs = shm_cdr.message_type("rcl_interfaces/msg/ParameterType")
    empty = ParameterTypeOurs()
    assert repr(empty) == repr(ParameterType()) == "rcl_interfaces.msg.ParameterType()"
    assert empty.to_dict() == {}
    # On the wire it keeps rosidl's one placeholder byte, which each reads
    # from the other (rclpy pads its bytes to a multiple of four).
    ours = empty.serialize()
    assert ours == b"\x00\x01\x00\x00\x00"
    assert rclpy_serialization.deserialize_message(ours, ParameterType) == ParameterType()
    theirs = rclpy_serialization.serialize_message(ParameterType())
    assert ParameterTypeOurs.deserialize(theirs) == empty
