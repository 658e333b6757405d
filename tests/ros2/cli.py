#!/usr/bin/env python3
"""`shm-ros2` against software this project did not write: an independent
rmw_zenoh-convention peer (eclipse-zenoh, rclpy's serialization, rosidl's
hashes) that announces a node `/demo/py_node`, publishes rclpy-serialized
messages and serves the node's parameter services with rclpy's own parameter
handlers (an rclpy node in this process).

- `topic list -t`, `topic info`, `node list`, `node info`: the peer's tokens,
  in ros2cli's formats; `topic info -v` with each endpoint as rclpy's
  `TopicEndpointInfo` prints it, for the QoS rmw_zenoh_cpp reads from the
  token (a default one and one with every field set).
- `topic echo --once`: for random values of several standard types (every
  kind of field, YAML's hard strings), the text must be rosidl_runtime_py's
  `message_to_yaml` through PyYAML (the rules restated in yaml_format.py), the
  `---` after it, with `ros2 topic echo`'s default truncation and with
  `--full-length`, `--flow-style`, `--no-arr`.
- `topic pub --once`: the peer subscribes with an `MS` token and reads the
  message with rclpy: the YAML values given.
- `param list/get/set`: rclpy's handlers answer; the printed values are
  ros2param's (Python's `repr`s), and a set reaches rclpy's node.

    python tests/ros2/cli.py <dir with the shm-ros2 binary>
"""
import os
import random
import subprocess
import sys
import threading
import time
from pathlib import Path

import rclpy
from rcl_interfaces.msg import ParameterDescriptor
from rcl_interfaces.srv import (DescribeParameters, GetParameterTypes, GetParameters, ListParameters,
                                SetParameters, SetParametersAtomically)
from rclpy.duration import Duration, Infinite
from rclpy.qos import (QoSDurabilityPolicy, QoSHistoryPolicy, QoSLivelinessPolicy, QoSProfile,
                       QoSReliabilityPolicy)
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.topic_endpoint_info import TopicEndpointInfo, TopicEndpointTypeEnum
from rclpy.type_hash import TypeHash
from rmw_zenoh import attachment, free_port, gid_of, open_session, parse_attachment, rosidl_hash
from yaml_format import message_to_yaml

BIN = Path(sys.argv[1] if len(sys.argv) > 1 else "target/release") / "shm-ros2"
QOS = "::,10:,:,:,,"  # reliable, volatile, keep last 10
failures = []
rng = random.Random(20261126)

HARD_TEXT = ["", "hello", "yes", "1.5", "- x", "a: b", "#c", "it's", " lead", "multi\nline", "tab\there",
             "ハロー", "emoji \U0001f916", "x" * 200]


def check(ok, what):
    if not ok:
        failures.append(what)
    return ok


def dds(type_name):
    pkg, kind, name = type_name.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


class Peer:
    """A node of rmw_zenoh's conventions, written in Python."""

    def __init__(self, endpoint, namespace, name):
        self.session = open_session(endpoint, listen=True)
        self.zid = str(self.session.zid())
        self.namespace, self.name = namespace, name
        self.next_id = 1
        self.keep = []
        self.tokens = []
        self.token("NN", None)

    def token(self, kind, entity, qos=QOS):
        entity_id = self.next_id
        self.next_id += 1
        ns = self.namespace.replace("/", "%")
        key = f"@ros2_lv/0/{self.zid}/0/{entity_id}/{kind}/%/{ns}/{self.name}"
        if entity is not None:
            topic, type_name = entity
            key += f"/{topic.replace('/', '%')}/{dds(type_name)}/{rosidl_hash(type_name)}/{qos}"
        self.keep.append(self.session.liveliness().declare_token(key))
        self.tokens.append(key)
        return key

    def publisher(self, topic, type_name):
        token = self.token("MP", (topic, type_name))
        key = f"0/{topic.strip('/')}/{dds(type_name)}/{rosidl_hash(type_name)}"
        publisher = self.session.declare_publisher(key)
        self.keep.append(publisher)
        gid = gid_of(token)
        seq = [0]

        def publish(message, data=None):
            """Publish `message`, or bytes already serialized (`data`)."""
            seq[0] += 1
            publisher.put(serialize_message(message) if data is None else data, attachment=attachment(seq[0], gid))
        return publish

    def subscriber(self, topic, type_name, on_message):
        self.token("MS", (topic, type_name))
        key = f"0/{topic.strip('/')}/{dds(type_name)}/{rosidl_hash(type_name)}"
        self.keep.append(self.session.declare_subscriber(key, lambda s: on_message(s.payload.to_bytes())))

    def serve(self, service, srv_type, type_name, handler):
        """A server whose requests rclpy reads and whose replies `handler` makes."""
        token = self.token("SS", (service, type_name))
        key = f"0/{service.strip('/')}/{dds(type_name)}/{rosidl_hash(type_name)}"
        del token

        def on_query(query):
            att = parse_attachment(None if query.attachment is None else query.attachment.to_bytes())
            request = deserialize_message(query.payload.to_bytes(), srv_type.Request)
            response = handler(request, srv_type.Response())
            query.reply(key, serialize_message(response), attachment=attachment(att[0], att[2]) if att else None)
        self.keep.append(self.session.declare_queryable(key, on_query, complete=True))


def cli(endpoint, *args, timeout=60):
    return subprocess.run([str(BIN), "--connect", endpoint, "--domain-id", "0", "--timeout", "10", *args],
                          capture_output=True, text=True, timeout=timeout)


def random_value(cls):
    """A random message of `cls` (rclpy's types), with YAML's hard strings."""
    from rosidl_parser import definition as d

    def scalar(t):
        if isinstance(t, d.BasicType):
            n = t.typename
            if n == "boolean":
                return rng.random() < 0.5
            if n == "octet":
                return bytes([rng.randrange(256)])
            if n in ("float", "double"):
                return rng.choice([0.0, -0.0, 1.5, 0.1, 1e-7, 123456.789, float("inf")])
            if n.startswith("uint") or n == "char":
                return rng.randrange(0, 200)
            return rng.randrange(-100, 100)
        if isinstance(t, d.AbstractString):
            return rng.choice(HARD_TEXT)
        if isinstance(t, d.NamespacedType):
            import importlib
            module = importlib.import_module(".".join(t.namespaces))
            return random_value(getattr(module, t.name))
        raise ValueError(t)

    msg = cls()
    for slot, t in zip(cls.__slots__, cls.SLOT_TYPES):
        name = slot[1:]
        if isinstance(t, d.AbstractNestedType):
            n = t.size if isinstance(t, d.Array) else rng.choice([0, 2, 140])
            if isinstance(t, d.BoundedSequence):
                n = min(n, t.maximum_size)
            if isinstance(t.value_type, d.NamespacedType):
                n = min(n, 3)
            setattr(msg, name, [scalar(t.value_type) for _ in range(n)])
        else:
            setattr(msg, name, scalar(t))
    return msg


def check_echo(endpoint, peer):
    from geometry_msgs.msg import PoseStamped
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String
    from test_msgs.msg import Arrays, UnboundedSequences
    cases = [("/chatter", "std_msgs/msg/String", String), ("/joints", "sensor_msgs/msg/JointState", JointState),
             ("/pose", "geometry_msgs/msg/PoseStamped", PoseStamped),
             ("/arrays", "test_msgs/msg/Arrays", Arrays), ("/sequences", "test_msgs/msg/UnboundedSequences",
                                                            UnboundedSequences)]
    options = [([], dict(truncate_length=128)), (["--full-length"], {}),
               (["--flow-style"], dict(truncate_length=128, flow_style=True)),
               (["--no-arr", "-l", "5"], dict(truncate_length=5, no_arr=True))]
    equal = total = 0
    publishers = {topic: peer.publisher(topic, type_name) for topic, type_name, _ in cases}
    for topic, type_name, cls in cases:
        publish = publishers[topic]
        for flags, kwargs in options:
            message = random_value(cls)
            stop = threading.Event()

            def keep_publishing():
                while not stop.is_set():
                    publish(message)
                    time.sleep(0.05)
            thread = threading.Thread(target=keep_publishing)
            thread.start()
            try:
                proc = cli(endpoint, "topic", "echo", topic, "--once", *flags)
            finally:
                stop.set()
                thread.join()
            total += 1
            # What a subscriber reads: float32 fields rounded as rclpy's
            # deserialization rounds them.
            seen = deserialize_message(serialize_message(message), cls)
            expected = message_to_yaml(seen, **kwargs) + "---\n"
            at = next((i for i, (a, b) in enumerate(zip(proc.stdout + "\0", expected + "\0")) if a != b), 0)
            if check(proc.returncode == 0 and proc.stdout == expected,
                     f"echo {topic} {flags}: exit {proc.returncode} {proc.stderr[-300:]!r}, differs at {at}\n"
                     f"    ours:     {proc.stdout[max(0, at - 150):at + 100]!r}\n"
                     f"    expected: {expected[max(0, at - 150):at + 100]!r}"):
                equal += 1
    print(f"topic echo: {equal}/{total} outputs equal to message_to_yaml's (PyYAML) for rclpy-serialized "
          f"random values of {len(cases)} types, 4 option sets")

    # --field: ros2topic's getattr walk, then a message as YAML and anything
    # else as Python's str of what rclpy holds (numpy arrays, array.array,
    # lists, raw strings).
    fields = {"/pose": ["pose.position", "header.frame_id", "pose.orientation.w", "header.stamp.sec"],
              "/joints": ["position", "name", "header"],
              "/arrays": ["float64_values", "float32_values", "bool_values", "byte_values", "int8_values",
                          "uint64_values", "string_values", "basic_types_values"],
              "/sequences": ["int32_values", "float32_values", "uint8_values", "byte_values", "bool_values",
                             "float64_values"]}
    equal = total = 0
    for topic, type_name, cls in cases:
        for field in fields.get(topic, []):
            message = random_value(cls)
            stop = threading.Event()

            def keep_publishing():
                while not stop.is_set():
                    publishers[topic](message)
                    time.sleep(0.05)
            thread = threading.Thread(target=keep_publishing)
            thread.start()
            try:
                proc = cli(endpoint, "topic", "echo", topic, "--once", "--field", field)
            finally:
                stop.set()
                thread.join()
            total += 1
            value = deserialize_message(serialize_message(message), cls)
            for name in field.split("."):
                value = getattr(value, name)
            if hasattr(value, "__slots__"):
                expected = message_to_yaml(value, truncate_length=128) + "---\n"
            else:
                expected = f"{value}\n---\n"
            if check(proc.returncode == 0 and proc.stdout == expected,
                     f"echo {topic} --field {field}: exit {proc.returncode} {proc.stderr[-300:]!r}\n"
                     f"    ours:     {proc.stdout[:600]!r}\n    expected: {expected[:600]!r}"):
                equal += 1
    proc = cli(endpoint, "topic", "echo", "/pose", "--once", "--field", "pose.position.z.w")
    check(proc.returncode != 0 and "Invalid field 'pose.position.z.w': 'float' object has no attribute 'w'"
          in proc.stderr, f"echo --field of a float's attribute: {proc.returncode} {proc.stderr!r}")
    print(f"topic echo --field: {equal}/{total} outputs equal to ros2topic's (message_to_yaml, or Python's str of "
          "rclpy's value); a field that is not there refused with ros2topic's words")


def check_graph(endpoint, peer):
    proc = cli(endpoint, "topic", "list", "-t")
    check("/chatter [std_msgs/msg/String]" in proc.stdout.splitlines(), f"topic list -t: {proc.stdout!r}")
    proc = cli(endpoint, "topic", "info", "/joints")
    check(proc.stdout == "Type: sensor_msgs/msg/JointState\nPublisher count: 1\nSubscription count: 0\n",
          f"topic info: {proc.stdout!r} {proc.stderr[-300:]!r}")
    proc = cli(endpoint, "node", "list")
    check(proc.stdout == "/demo/py_node\n", f"node list: {proc.stdout!r}")
    proc = cli(endpoint, "node", "info", "/demo/py_node")
    check(proc.stdout.startswith("/demo/py_node\n  Subscribers:\n    /cmd: std_msgs/msg/String\n  Publishers:\n"
                                 "    /arrays: test_msgs/msg/Arrays\n")
          and "  Service Servers:\n    /demo/py_node/describe_parameters: rcl_interfaces/srv/DescribeParameters\n"
          in proc.stdout, f"node info: {proc.stdout!r} {proc.stderr[-300:]!r}")
    check_info_verbose(endpoint, peer)
    print("graph: topic list -t, topic info (-v), node list, node info as ros2cli prints them")


def check_info_verbose(endpoint, peer):
    """`topic info -v` as ros2topic's info verb prints it: each endpoint is
    rclpy's `TopicEndpointInfo.__str__`, built here from the QoS
    rmw_zenoh_cpp's `keyexpr_to_qos` reads out of the token (an empty field is
    its default: reliable, volatile, keep last, durations RMW_DURATION_INFINITE)."""
    def endpoint_info(token, endpoint_type, type_name, qos):
        return str(TopicEndpointInfo(
            node_name="py_node", node_namespace="/demo", topic_type=type_name,
            topic_type_hash=TypeHash(version=1, value=bytes.fromhex(rosidl_hash(type_name)[len("RIHS01_"):])),
            endpoint_type=endpoint_type, endpoint_gid=list(gid_of(token)), qos_profile=qos))

    def want(type_name, publishers, subscriptions):
        # ros2topic's info verb: every line and endpoint followed by a blank line.
        text = f"Type: {type_name}\n\nPublisher count: {len(publishers)}\n\n"
        text += "".join(info + "\n\n" for info in publishers)
        text += f"Subscription count: {len(subscriptions)}\n\n"
        return text + "".join(info + "\n\n" for info in subscriptions)

    # Every field set: best effort, transient local, keep last 5, deadline
    # 1 s 500 ns, lifespan 0, liveliness manual by topic with a 3 s lease.
    token = peer.token("MP", ("/qos_probe", "std_msgs/msg/Int32"), qos="2:1:,5:1,500:0,0:3,3,0")
    qos = QoSProfile(history=QoSHistoryPolicy.KEEP_LAST, depth=5, reliability=QoSReliabilityPolicy.BEST_EFFORT,
                     durability=QoSDurabilityPolicy.TRANSIENT_LOCAL,
                     deadline=Duration(seconds=1, nanoseconds=500), lifespan=Duration(nanoseconds=0),
                     liveliness=QoSLivelinessPolicy.MANUAL_BY_TOPIC, liveliness_lease_duration=Duration(seconds=3))
    expected = want("std_msgs/msg/Int32",
                    [endpoint_info(token, TopicEndpointTypeEnum.PUBLISHER, "std_msgs/msg/Int32", qos)], [])
    proc = cli(endpoint, "topic", "info", "-v", "/qos_probe")
    check(proc.stdout == expected, f"topic info -v /qos_probe: {proc.stdout!r}, ros2topic: {expected!r}")
    # rclpy's qos_profile_best_available (Jazzy and later), as rmw_zenoh_cpp's
    # qos_to_keyexpr writes it: the policies unresolved (reliability and
    # durability 4, liveliness 5), deadline and lease one nanosecond short of
    # infinite (the seconds equal the default's, so they are left out), the
    # unspecified lifespan made infinite by `best_available_qos`.
    from rclpy.qos import qos_profile_best_available as best
    token = peer.token("MP", ("/best_probe", "std_msgs/msg/Int32"), qos="4:4:,10:,854775806:,:5,,854775806")
    qos = QoSProfile(history=best.history, depth=best.depth, reliability=best.reliability,
                     durability=best.durability, deadline=best.deadline, lifespan=Infinite,
                     liveliness=best.liveliness, liveliness_lease_duration=best.liveliness_lease_duration)
    expected = want("std_msgs/msg/Int32", [endpoint_info(token, TopicEndpointTypeEnum.PUBLISHER, "std_msgs/msg/Int32",
                                                         qos)], [])
    proc = cli(endpoint, "topic", "info", "-v", "/best_probe")
    check(proc.stdout == expected, f"topic info -v /best_probe: {proc.stdout!r}, ros2topic: {expected!r}")
    # The peer's subscriber of /cmd, default QoS but for its depth (QOS).
    cmd = next(t for t in peer.tokens if "/MS/" in t and "/%cmd/" in t)
    qos = QoSProfile(history=QoSHistoryPolicy.KEEP_LAST, depth=10, reliability=QoSReliabilityPolicy.RELIABLE,
                     durability=QoSDurabilityPolicy.VOLATILE, deadline=Infinite, lifespan=Infinite,
                     liveliness=QoSLivelinessPolicy.AUTOMATIC, liveliness_lease_duration=Infinite)
    expected = want("std_msgs/msg/String", [],
                    [endpoint_info(cmd, TopicEndpointTypeEnum.SUBSCRIPTION, "std_msgs/msg/String", qos)])
    proc = cli(endpoint, "topic", "info", "-v", "/cmd")
    check(proc.stdout == expected, f"topic info -v /cmd: {proc.stdout!r}, ros2topic: {expected!r}")


def check_pub(endpoint, received):
    from std_msgs.msg import String
    proc = cli(endpoint, "topic", "pub", "--once", "/cmd", "std_msgs/msg/String", "data: 'hello: rclpy'")
    deadline = time.time() + 5
    while not received and time.time() < deadline:
        time.sleep(0.05)
    got = [deserialize_message(b, String).data for b in received]
    check(proc.returncode == 0 and got == ["hello: rclpy"], f"topic pub: exit {proc.returncode}, rclpy read {got} "
                                                             f"{proc.stderr[-300:]!r}")
    print(f"topic pub: rclpy read {got}")


def check_params(endpoint, node):
    proc = cli(endpoint, "param", "list", "/demo/py_node")
    expected = "".join(f"  {n}\n" for n in sorted(["gain", "names", "flags", "mode", "use_sim_time",
                                                      "start_type_description_service"]))
    check(proc.stdout == expected, f"param list: {proc.stdout!r} expected {expected!r} {proc.stderr[-300:]!r}")
    # ros2param prints Python's values.
    for name, line in [("gain", "Double value is: 0.1"), ("names", "String values are: ['a', \"it's\"]"),
                       ("flags", "Boolean values are: [True, False]"), ("mode", "String value is: auto"),
                       ("use_sim_time", "Boolean value is: False")]:
        proc = cli(endpoint, "param", "get", "/demo/py_node", name)
        check(proc.stdout == line + "\n", f"param get {name}: {proc.stdout!r} expected {line!r} {proc.stderr[-300:]!r}")
    proc = cli(endpoint, "param", "set", "/demo/py_node", "gain", "2.5")
    check(proc.stdout == "Set parameter successful\n" and node.get_parameter("gain").value == 2.5,
          f"param set: {proc.stdout!r} {proc.stderr[-300:]!r}, rclpy holds {node.get_parameter('gain').value}")
    # Integer and double arrays: rclpy's message holds them as Python arrays,
    # which ros2param prints as they are.
    from rcl_interfaces.msg import ParameterValue
    for name, values, label, field in [("counts", [1, -2, 3], "Integer values are:", "integer_array_value"),
                                       ("weights", [1.5, -2.0], "Double values are:", "double_array_value")]:
        node.declare_parameter(name, values)
        line = f"{label} {getattr(ParameterValue(**{field: values}), field)}"
        proc = cli(endpoint, "param", "get", "/demo/py_node", name)
        check(proc.stdout == line + "\n", f"param get {name}: {proc.stdout!r} expected {line!r} {proc.stderr[-300:]!r}")
        node.undeclare_parameter(name)
    # A refused set: the node's reason on stderr, exit 0, as ros2param.
    proc = cli(endpoint, "param", "set", "/demo/py_node", "gain", "fast")
    check(proc.returncode == 0 and proc.stderr.startswith("Setting parameter failed"),
          f"param set refused: exit {proc.returncode} {proc.stderr!r}")
    print("param: list, get (every kind printed as ros2param prints it), set (and a refused set) "
          "answered by rclpy's parameter handlers")


def check_dump_load(endpoint, node):
    import tempfile
    import yaml
    names = sorted(node._parameters)
    expected = yaml.dump({"/demo/py_node": {"ros__parameters": {n: node.get_parameter(n).value for n in names}}},
                         default_flow_style=False) + "\n"
    proc = cli(endpoint, "param", "dump", "/demo/py_node")
    check(proc.stdout == expected, f"param dump: {proc.stdout!r} expected {expected!r} {proc.stderr[-300:]!r}")
    with tempfile.NamedTemporaryFile("w", suffix=".yaml", delete=False) as f:
        yaml.dump({"/**": {"ros__parameters": {"mode": "wild"}},
                   "/demo/py_node": {"ros__parameters": {"gain": 4.5, "names": ["x", "y: z"]}}}, f)
    proc = cli(endpoint, "param", "load", "/demo/py_node", f.name)
    lines = set(proc.stdout.splitlines())
    check(proc.returncode == 0 and lines == {"Set parameter gain successful", "Set parameter names successful",
                                             "Set parameter mode successful"}
          and node.get_parameter("gain").value == 4.5 and node.get_parameter("names").value == ["x", "y: z"]
          and node.get_parameter("mode").value == "wild",
          f"param load: {proc.stdout!r} {proc.stderr[-300:]!r}")
    proc = cli(endpoint, "param", "load", "/demo/py_node", f.name, "--no-use-wildcard")
    check(set(proc.stdout.splitlines()) == {"Set parameter gain successful", "Set parameter names successful"},
          f"param load --no-use-wildcard: {proc.stdout!r}")
    os.unlink(f.name)
    print("param: dump equal to ros2param's (yaml.dump of rclpy's values), load (with and without /**) reaching "
          "rclpy's node")


def check_service_call(endpoint, peer):
    from std_srvs.srv import Trigger
    from test_msgs.srv import BasicTypes

    def basic(request, response):
        # Every field echoed back, changed where it can be.
        for name in BasicTypes.Request.get_fields_and_field_types():
            setattr(response, name, getattr(request, name))
        response.string_value = request.string_value + " (it's back)"
        response.int64_value = request.int64_value * 2
        return response

    def trigger(request, response):
        response.success, response.message = True, "done: yes"
        return response
    peer.serve("/demo/basic", BasicTypes, "test_msgs/srv/BasicTypes", basic)
    peer.serve("/demo/trigger", Trigger, "std_srvs/srv/Trigger", trigger)
    values = ("{bool_value: true, byte_value: 7, char_value: 65, float32_value: 1.5, float64_value: 0.1, "
              "int8_value: -3, uint8_value: 200, int16_value: -300, uint16_value: 60000, int32_value: -7, "
              "uint32_value: 4000000000, int64_value: -9000000000, uint64_value: 18000000000000000000, "
              "string_value: 'naïve: yes'}")
    request = BasicTypes.Request(bool_value=True, byte_value=b"\x07", char_value=65, float32_value=1.5,
                                 float64_value=0.1, int8_value=-3, uint8_value=200, int16_value=-300,
                                 uint16_value=60000, int32_value=-7, uint32_value=4000000000,
                                 int64_value=-9000000000, uint64_value=18000000000000000000,
                                 string_value="naïve: yes")
    response = deserialize_message(serialize_message(basic(request, BasicTypes.Response())), BasicTypes.Response)
    for service, type_name, args, expected in [
        ("/demo/basic", "test_msgs/srv/BasicTypes", [values],
         f"requester: making request: {request!r}\n\nresponse:\n{response!r}\n\n"),
        ("/demo/trigger", "std_srvs/srv/Trigger", [],
         f"requester: making request: {Trigger.Request()!r}\n\nresponse:\n"
         f"{Trigger.Response(success=True, message='done: yes')!r}\n\n"),
    ]:
        proc = cli(endpoint, "service", "call", service, type_name, *args)
        check(proc.returncode == 0 and proc.stdout == expected,
              f"service call {service}: exit {proc.returncode} {proc.stderr[-300:]!r}\n"
              f"    ours:     {proc.stdout!r}\n    expected: {expected!r}")
    proc = cli(endpoint, "service", "call", "/demo/trigger", "std_srvs/srv/SetBool")
    check(proc.returncode != 0 and "is of type std_srvs/srv/Trigger" in proc.stderr,
          f"service call of the wrong type: {proc.returncode} {proc.stderr!r}")
    print("service call: test_msgs/srv/BasicTypes (every scalar kind) and std_srvs/srv/Trigger answered by the "
          "peer, request and response printed as rclpy's repr")
    check_numpy_arrays(endpoint, peer)


def check_numpy_arrays(endpoint, peer):
    """Fixed arrays of numbers are numpy arrays in rclpy: `service call`
    prints them as numpy's repr does (padding, scientific notation, nan and
    inf, dtype, lines wrapped at 75 columns), for random and chosen values."""
    from sensor_msgs.msg import CameraInfo
    from sensor_msgs.srv import SetCameraInfo
    from test_msgs.srv import Arrays
    nan, inf = float("nan"), float("inf")
    floats = [[1e-7, 123456.789, inf], [nan, -inf, 0.5], [-0.0, 0.1, 1.5], [1e8, 1.0, 2.0], [0.001953125, 3.0, -2.5],
              [1 / 3, 2 / 3, 1e5], [1e300, -1e-300, 0.0], [0.0, 0.0, 0.0], [nan, nan, nan], [-inf, 1e16, 7.0]]
    responses = []
    for i, values in enumerate(floats):
        response = random_value(Arrays.Response)
        response.float64_values = values
        # Scaled off float64's digits; kept within float32's range.
        response.float32_values = [max(-3e38, min(3e38, v * 1.0000001)) if abs(v) < inf else v
                                   for v in reversed(values)]
        responses.append(deserialize_message(serialize_message(response), Arrays.Response))
    for _ in range(6):
        responses.append(deserialize_message(serialize_message(random_value(Arrays.Response)), Arrays.Response))
    served = iter(responses)
    peer.serve("/demo/arrays", Arrays, "test_msgs/srv/Arrays", lambda request, response: next(served))
    for response in responses:
        proc = cli(endpoint, "service", "call", "/demo/arrays", "test_msgs/srv/Arrays")
        expected = f"requester: making request: {Arrays.Request()!r}\n\nresponse:\n{response!r}\n\n"
        check(proc.returncode == 0 and proc.stdout == expected,
              f"service call /demo/arrays: exit {proc.returncode} {proc.stderr[-300:]!r}\n"
              f"    ours:     {proc.stdout!r}\n    expected: {expected!r}")
    # Long arrays wrap: a camera's matrices, sent in the request.
    k = [512.345678, 0.0, 320.5, 0.0, 511.98765, 240.25, 0.0, 0.0, 1.0]
    r = [0.99998, -0.00123, 0.00456, 0.00123, 0.99999, -0.00789, -0.00456, 0.00789, 0.99997]
    p = [512.345678, 0.0, 320.5, -35.123456, 0.0, 511.98765, 240.25, 0.0, 0.0, 0.0, 1.0, 0.0]
    info = CameraInfo(k=k, r=r, p=p, width=640, height=480)
    request = SetCameraInfo.Request(camera_info=info)
    peer.serve("/demo/set_camera_info", SetCameraInfo, "sensor_msgs/srv/SetCameraInfo",
               lambda request, response: SetCameraInfo.Response(success=True, status_message="stored"))
    text = "{camera_info: {width: 640, height: 480, k: %s, r: %s, p: %s}}" % (
        [repr(v) for v in k], [repr(v) for v in r], [repr(v) for v in p])
    proc = cli(endpoint, "service", "call", "/demo/set_camera_info", "sensor_msgs/srv/SetCameraInfo",
               text.replace("'", ""))
    response = SetCameraInfo.Response(success=True, status_message="stored")
    expected = f"requester: making request: {request!r}\n\nresponse:\n{response!r}\n\n"
    check(proc.returncode == 0 and proc.stdout == expected,
          f"service call /demo/set_camera_info: exit {proc.returncode} {proc.stderr[-300:]!r}\n"
          f"    ours:     {proc.stdout!r}\n    expected: {expected!r}")
    print(f"service call: {len(responses)} test_msgs/srv/Arrays responses and a sensor_msgs/CameraInfo request "
          "with fixed arrays printed as numpy's repr (padding, scientific notation, nan, inf, dtype, wrapping)")


def check_send_goal(endpoint, peer):
    from test_msgs.action import Fibonacci
    impl = Fibonacci.Impl
    publish_feedback = peer.publisher("/demo/fib/_action/feedback", "test_msgs/action/Fibonacci_FeedbackMessage")
    goals = {}
    feedbacks = []

    def sequence(order):
        out = [0, 1]
        for i in range(1, order):
            out.append(out[i] + out[i - 1])
        return out

    def send_goal(request, response):
        response.accepted = request.goal.order < 20
        if response.accepted:
            goals[bytes(request.goal_id.uuid)] = request.goal.order
            for n in range(3, request.goal.order + 2):
                message = impl.FeedbackMessage(goal_id=request.goal_id)
                message.feedback.sequence = sequence(n - 1)
                publish_feedback(message)
                feedbacks.append(message.feedback)
        return response

    def get_result(request, response):
        time.sleep(0.2)
        order = goals.get(bytes(request.goal_id.uuid))
        response.status = 4 if order is not None else 0
        response.result.sequence = sequence(order or 0)
        return response
    peer.serve("/demo/fib/_action/send_goal", impl.SendGoalService, "test_msgs/action/Fibonacci_SendGoal", send_goal)
    peer.serve("/demo/fib/_action/get_result", impl.GetResultService, "test_msgs/action/Fibonacci_GetResult",
               get_result)
    time.sleep(0.5)
    proc = cli(endpoint, "action", "send_goal", "-f", "/demo/fib", "test_msgs/action/Fibonacci", "{order: 4}")
    ids = [line.split(": ")[1] for line in proc.stdout.splitlines() if line.startswith("Goal accepted with ID: ")]
    goal = Fibonacci.Goal(order=4)
    result = Fibonacci.Result(sequence=sequence(4))
    expected = ("Waiting for an action server to become available...\n"
                f"Sending goal:\n     {message_to_yaml(goal)}\n"
                f"Goal accepted with ID: {ids[0] if ids else '?'}\n\n"
                + "".join(f"Feedback:\n    {message_to_yaml(f)}\n" for f in feedbacks)
                + f"Result:\n    {message_to_yaml(result)}\n"
                + "Goal finished with status: SUCCEEDED\n")
    check(proc.returncode == 0 and proc.stdout == expected and len(feedbacks) == 3
          and [bytes(k).hex() for k in goals] == ids,
          f"action send_goal: exit {proc.returncode} {proc.stderr[-300:]!r}\n    ours:     {proc.stdout!r}\n"
          f"    expected: {expected!r}")
    proc = cli(endpoint, "action", "send_goal", "/demo/fib", "test_msgs/action/Fibonacci", "{order: 50}")
    check(proc.stdout.endswith("Goal was rejected.\n"), f"action send_goal rejected: {proc.stdout!r}")
    print(f"action send_goal: a goal, its {len(feedbacks)} feedback messages and result from the peer's "
          "Fibonacci server, printed as ros2action prints them; a rejected goal")


def main():
    rclpy.init()
    node = rclpy.create_node("py_node", namespace="/demo")
    node.declare_parameter("gain", 0.1)
    node.declare_parameter("names", ["a", "it's"])
    node.declare_parameter("flags", [True, False])
    node.declare_parameter("mode", "auto", ParameterDescriptor(description="operating mode"))
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    peer = Peer(endpoint, "/demo", "py_node")
    handlers = node._parameter_service
    for service, srv_type, callback in [
        ("list_parameters", ListParameters, handlers._list_parameters_callback),
        ("get_parameters", GetParameters, handlers._get_parameters_callback),
        ("get_parameter_types", GetParameterTypes, handlers._get_parameter_types_callback),
        ("describe_parameters", DescribeParameters, handlers._describe_parameters_callback),
        ("set_parameters", SetParameters, handlers._set_parameters_callback),
        ("set_parameters_atomically", SetParametersAtomically, handlers._set_parameters_atomically_callback),
    ]:
        peer.serve(f"/demo/py_node/{service}", srv_type, f"rcl_interfaces/srv/{srv_type.__name__}", callback)
    received = []
    peer.subscriber("/cmd", "std_msgs/msg/String", received.append)
    check_echo(endpoint, peer)
    check_graph(endpoint, peer)
    check_pub(endpoint, received)
    check_params(endpoint, node)
    check_dump_load(endpoint, node)
    check_service_call(endpoint, peer)
    check_send_goal(endpoint, peer)
    for f in failures:
        print("  FAIL", f)
    return 1 if failures else 0


if __name__ == "__main__":
    try:
        code = main()
    except BaseException:
        import traceback
        traceback.print_exc()
        code = 1
    sys.stdout.flush()
    # Zenoh's threads would keep the interpreter from exiting.
    os._exit(code)
