#!/usr/bin/env python3
"""Parameters, differential against rclpy: the same node (`/demo/param_node`,
the same parameters and descriptors, a validation callback that refuses a speed of
7.5) as an rclpy node (the Kilted wheels, in this process) and as our node
(`interop_parameters`), asked the same sequence of questions through the six
`rcl_interfaces` services: listing by prefix and depth, getting, types,
descriptors, and every kind of set that succeeds or fails (a value out of range or
off its step, a wrong type, a read-only parameter, undeclaring a static one,
retyping and undeclaring a dynamic one, the callback's refusal, all-or-nothing
sets). Our node is asked over Zenoh with rclpy's serialization and rmw_zenoh's
conventions; rclpy's node through its own service callbacks. The replies must be
equal, and so must the `/parameter_events` both publish for the sets.

The parameters every node declares (`use_sim_time`,
`start_type_description_service`) are listed and described as well. Known
difference, left out of the comparison: for a parameter that was never
declared, rclpy's reason reads "Invalid access to undeclared parameter(s): []"
(its list comes out empty), ours names the parameter.

    python tests/ros2/parameters.py <dir with the interop_parameters binary>
"""
import subprocess
import sys
import time
from pathlib import Path

import rclpy
from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, Parameter, ParameterDescriptor,
                                ParameterEvent, ParameterType, ParameterValue, SetParametersResult)
from rcl_interfaces.srv import (DescribeParameters, GetParameterTypes, GetParameters, ListParameters,
                                SetParameters, SetParametersAtomically)
from rclpy.serialization import deserialize_message

from rmw_zenoh import call, free_port, gid_of, open_session, rosidl_hash

BIN = Path(sys.argv[1] if len(sys.argv) > 1 else "target/release/examples") / "interop_parameters"
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
    return ok


def rclpy_node():
    node = rclpy.create_node("param_node", namespace="/demo")
    node.declare_parameter("speed", 1.5, ParameterDescriptor(
        description="m/s", floating_point_range=[FloatingPointRange(from_value=0.0, to_value=10.0, step=0.5)]))
    node.declare_parameter("count", 4, ParameterDescriptor(
        integer_range=[IntegerRange(from_value=0, to_value=10, step=2)]))
    node.declare_parameter("frame", "map", ParameterDescriptor(read_only=True))
    node.declare_parameter("any", 1, ParameterDescriptor(dynamic_typing=True))
    node.declare_parameter("name.first", "ada")
    node.declare_parameter("name.last", "lovelace")
    node.declare_parameter("nested.deep.flag", True)
    node.declare_parameter("ids", [1, 2, 3])

    def refuse_unlucky(params):
        if any(p.name == "speed" and p.value == 7.5 for p in params):
            return SetParametersResult(successful=False, reason="7.5 is not allowed")
        return SetParametersResult(successful=True)
    node.add_on_set_parameters_callback(refuse_unlucky)
    return node


def value(kind, v):
    pv = ParameterValue(type=kind)
    field = {ParameterType.PARAMETER_BOOL: "bool_value", ParameterType.PARAMETER_INTEGER: "integer_value",
             ParameterType.PARAMETER_DOUBLE: "double_value", ParameterType.PARAMETER_STRING: "string_value",
             ParameterType.PARAMETER_INTEGER_ARRAY: "integer_array_value"}.get(kind)
    if field:
        setattr(pv, field, v)
    return pv


def p(name, kind, v=None):
    return Parameter(name=name, value=value(kind, v))


D, I, S, B, N = (ParameterType.PARAMETER_DOUBLE, ParameterType.PARAMETER_INTEGER, ParameterType.PARAMETER_STRING,
                 ParameterType.PARAMETER_BOOL, ParameterType.PARAMETER_NOT_SET)

# (service, type, request): asked of both nodes in this order.
QUESTIONS = [
    ("list_parameters", ListParameters, ListParameters.Request(prefixes=[], depth=0)),
    ("list_parameters", ListParameters, ListParameters.Request(prefixes=[], depth=1)),
    ("list_parameters", ListParameters, ListParameters.Request(prefixes=["name"], depth=1)),
    ("list_parameters", ListParameters, ListParameters.Request(prefixes=["nested"], depth=1)),
    ("list_parameters", ListParameters, ListParameters.Request(prefixes=["nested"], depth=0)),
    ("get_parameters", GetParameters, GetParameters.Request(names=["speed", "frame", "ids"])),
    ("get_parameters", GetParameters, GetParameters.Request(names=["speed", "missing"])),
    ("get_parameter_types", GetParameterTypes, GetParameterTypes.Request(names=["count", "name.first", "ids"])),
    ("get_parameter_types", GetParameterTypes, GetParameterTypes.Request(names=["missing"])),
    ("describe_parameters", DescribeParameters, DescribeParameters.Request(names=["speed", "count", "frame", "any"])),
    ("describe_parameters", DescribeParameters, DescribeParameters.Request(names=["count", "missing"])),
    ("describe_parameters", DescribeParameters,
     DescribeParameters.Request(names=["start_type_description_service", "use_sim_time"])),
    ("get_parameters", GetParameters, GetParameters.Request(names=["start_type_description_service"])),
    ("set_parameters", SetParameters, SetParameters.Request(parameters=[
        p("speed", D, 2.0), p("speed", D, 11.0), p("speed", D, 2.2), p("speed", D, 10.0), p("speed", D, 1e-9),
        p("speed", D, 7.5), p("speed", S, "fast"), p("count", I, 6), p("count", I, 3), p("count", I, -2),
        p("frame", S, "odom"), p("count", N), p("any", S, "now text"), p("any", B, True), p("ids", I, 1)])),
    ("set_parameters_atomically", SetParametersAtomically, SetParametersAtomically.Request(parameters=[
        p("speed", D, 3.0), p("count", I, 8)])),
    ("set_parameters_atomically", SetParametersAtomically, SetParametersAtomically.Request(parameters=[
        p("speed", D, 3.5), p("count", I, 5)])),
    ("set_parameters", SetParameters, SetParameters.Request(parameters=[p("any", N)])),
    ("get_parameters", GetParameters, GetParameters.Request(names=["speed", "count", "any"])),
    ("list_parameters", ListParameters, ListParameters.Request(prefixes=[], depth=0)),
]
UNDECLARED = [("set_parameters", SetParameters, SetParameters.Request(parameters=[p("missing", I, 1)]))]


def ask_rclpy(node, service, srv_type, request):
    callback = {
        "list_parameters": node._parameter_service._list_parameters_callback,
        "get_parameters": node._parameter_service._get_parameters_callback,
        "get_parameter_types": node._parameter_service._get_parameter_types_callback,
        "describe_parameters": node._parameter_service._describe_parameters_callback,
        "set_parameters": node._parameter_service._set_parameters_callback,
        "set_parameters_atomically": node._parameter_service._set_parameters_atomically_callback,
    }[service]
    return callback(request, srv_type.Response())


def main():
    rclpy.init()
    reference = rclpy_node()
    rclpy_events = []
    reference._parameter_event_publisher.publish = lambda event: rclpy_events.append(event)

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    proc = subprocess.Popen([str(BIN), endpoint], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    check(proc.stdout.readline().strip() == "ready", "interop_parameters did not start")
    session = open_session(endpoint, listen=False)
    our_events = []
    events = session.declare_subscriber(
        f"0/parameter_events/rcl_interfaces::msg::dds_::ParameterEvent_/{rosidl_hash('rcl_interfaces/msg/ParameterEvent')}",
        lambda s: our_events.append(deserialize_message(s.payload.to_bytes(), ParameterEvent)))
    token = f"@ros2_lv/0/{session.zid()}/0/1/NN/%/%/py_param_client"
    live = session.liveliness().declare_token(token)
    gid = gid_of(token)
    time.sleep(1.0)

    def ask_ours(service, srv_type, request, seq):
        name = srv_type.__name__
        key = f"0/demo/param_node/{service}/rcl_interfaces::srv::dds_::{name}_/{rosidl_hash('rcl_interfaces/srv/' + name)}"
        return call(session, key, request, srv_type.Response, seq, gid)

    compared = 0
    for seq, (service, srv_type, request) in enumerate(QUESTIONS, start=1):
        ours = ask_ours(service, srv_type, request, seq)
        theirs = ask_rclpy(reference, service, srv_type, request)
        if check(ours is not None, f"{service}: no reply from our node"):
            compared += check(ours == theirs, f"{service} {request}:\n  ours   {ours}\n  rclpy  {theirs}")
    for service, srv_type, request in UNDECLARED:
        ours = ask_ours(service, srv_type, request, 99)
        theirs = ask_rclpy(reference, service, srv_type, request)
        if check(ours is not None, f"{service}: no reply"):
            check([r.successful for r in ours.results] == [r.successful for r in theirs.results] == [False],
                  f"undeclared: ours {ours}, rclpy {theirs}")
            check("missing" in ours.results[0].reason, f"our reason does not name the parameter: {ours}")

    time.sleep(0.5)
    strip = lambda e: (e.new_parameters, e.changed_parameters, e.deleted_parameters)
    check([strip(e) for e in our_events] == [strip(e) for e in rclpy_events],
          f"/parameter_events differ:\n  ours   {[strip(e) for e in our_events]}\n  rclpy  {[strip(e) for e in rclpy_events]}")
    check(all(e.node == "/demo/param_node" for e in our_events), f"event node names {[e.node for e in our_events]}")

    events.undeclare()
    live.undeclare()
    session.close()
    proc.stdin.close()
    proc.wait(timeout=30)
    reference.destroy_node()
    rclpy.shutdown()
    print(f"parameters: {compared}/{len(QUESTIONS)} replies equal to rclpy's, "
          f"{len(our_events)} /parameter_events equal to rclpy's")
    if failures:
        for f in failures:
            print("FAIL:", f)
        sys.exit(1)


if __name__ == "__main__":
    main()
