#!/usr/bin/env python3
"""Lifecycle, differential against rclpy: the same managed node (`/demo/lc_node`,
`on_configure` fails the first time, `on_activate` errs the first time,
`on_cleanup` raises the first time, `on_error` recovers) as an rclpy lifecycle
node (the Kilted wheels, in this process) and as our node (`interop_lifecycle`),
driven through the same sequence of requests to the five `lifecycle_msgs`
services: transitions by id and by label, ones the state does not offer, unknown
labels, every kind of callback result, and the queries in between. The replies
must be equal, and so must the `~/transition_event`s both publish. Our lifecycle
publisher must publish while the node is active and only then.

    python tests/ros2/lifecycle.py <dir with the interop_lifecycle binary>

With `ROS_DISTRO=jazzy` (and Jazzy's wheels), our node speaks Jazzy and is
compared with Jazzy's rclpy, which raises `RCLError` for a transition id the
state does not offer (Kilted's rclpy answers `success=False`). There the
answer expected is rclcpp's in every distribution, `success=False`
(`LifecycleNode::change_state` logs "Unable to start transition" and the
service replies false), and the state must not move.
"""
import os
import subprocess
import sys
import time
from pathlib import Path

import rclpy
from lifecycle_msgs.msg import Transition, TransitionEvent
from lifecycle_msgs.srv import ChangeState, GetAvailableStates, GetAvailableTransitions, GetState
from rclpy.lifecycle import LifecycleNode, TransitionCallbackReturn
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.serialization import deserialize_message

from rmw_zenoh import call, free_port, gid_of, open_session, rosidl_hash

DISTRO = os.environ.get("ROS_DISTRO", "kilted")
BIN = Path(sys.argv[1] if len(sys.argv) > 1 else "target/release/examples") / "interop_lifecycle"
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
    return ok


class Driver(LifecycleNode):
    """rclpy's side of `interop_lifecycle`'s `Driver`."""

    def __init__(self):
        super().__init__("lc_node", namespace="/demo")
        self.configured = self.activated = self.cleaned = 0

    def on_configure(self, state):
        self.configured += 1
        return TransitionCallbackReturn.FAILURE if self.configured == 1 else TransitionCallbackReturn.SUCCESS

    def on_activate(self, state):
        self.activated += 1
        return TransitionCallbackReturn.ERROR if self.activated == 1 else TransitionCallbackReturn.SUCCESS

    def on_cleanup(self, state):
        self.cleaned += 1
        if self.cleaned == 1:
            raise RuntimeError("the first cleanup fails")
        return TransitionCallbackReturn.SUCCESS


T = Transition
SERVICES = {
    "change_state": ChangeState,
    "get_state": GetState,
    "get_available_states": GetAvailableStates,
    "get_available_transitions": GetAvailableTransitions,
    "get_transition_graph": GetAvailableTransitions,
}


def change(id=0, label=""):
    return ("change_state", ChangeState.Request(transition=Transition(id=id, label=label)))


def query(service):
    return (service, SERVICES[service].Request())


# Asked of both nodes in this order; ("active", ...) marks where our heartbeat is checked.
QUESTIONS = [
    query("get_state"),
    query("get_available_states"),
    query("get_available_transitions"),
    query("get_transition_graph"),
    change(T.TRANSITION_ACTIVATE),
    change(label="transition_success"),
    change(label="configure"),
    change(T.TRANSITION_CONFIGURE),
    query("get_available_transitions"),
    change(label="activate"),
    query("get_state"),
    change(T.TRANSITION_CONFIGURE),
    change(T.TRANSITION_ACTIVATE),
    query("get_state"),
    "active",
    change(label="bogus"),
    change(T.TRANSITION_DEACTIVATE),
    "inactive",
    change(label="cleanup"),
    query("get_available_transitions"),
    change(label="shutdown"),
    query("get_state"),
    query("get_available_transitions"),
    change(T.TRANSITION_CONFIGURE),
]


def ask_rclpy(node, service, request):
    handler = getattr(node, f"_LifecycleNodeMixin__on_{service}")
    return handler(request, SERVICES[service].Response())


def event_tuple(e):
    return (e.timestamp, e.transition.id, e.transition.label, e.start_state.id, e.start_state.label,
            e.goal_state.id, e.goal_state.label)


def main():
    rclpy.init()
    reference = Driver()
    observer = rclpy.create_node("lc_observer")
    rclpy_events = []
    observer.create_subscription(TransitionEvent, "/demo/lc_node/transition_event",
                                 lambda e: rclpy_events.append(event_tuple(e)), 100)
    deadline = time.time() + 10
    while observer.count_publishers("/demo/lc_node/transition_event") < 1 and time.time() < deadline:
        rclpy.spin_once(observer, timeout_sec=0.1)

    def spin(seconds=0.3):
        end = time.time() + seconds
        while time.time() < end:
            rclpy.spin_once(observer, timeout_sec=0.05)

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    proc = subprocess.Popen([str(BIN), endpoint], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    check(proc.stdout.readline().strip() == "ready", "interop_lifecycle did not start")
    session = open_session(endpoint, listen=False)
    our_events = []
    events = session.declare_subscriber(
        f"0/demo/lc_node/transition_event/lifecycle_msgs::msg::dds_::TransitionEvent_/"
        f"{rosidl_hash('lifecycle_msgs/msg/TransitionEvent')}",
        lambda s: our_events.append(event_tuple(deserialize_message(s.payload.to_bytes(), TransitionEvent))))
    heartbeats = []
    beats = session.declare_subscriber(
        f"0/demo/heartbeat/std_msgs::msg::dds_::String_/{rosidl_hash('std_msgs/msg/String')}",
        lambda s: heartbeats.append(time.time()))
    token = f"@ros2_lv/0/{session.zid()}/0/1/NN/%/%/py_lifecycle_manager"
    live = session.liveliness().declare_token(token)
    gid = gid_of(token)
    time.sleep(1.0)

    def ask_ours(service, request, seq):
        name = SERVICES[service].__name__
        key = (f"0/demo/lc_node/{service}/lifecycle_msgs::srv::dds_::{name}_/"
               f"{rosidl_hash('lifecycle_msgs/srv/' + name)}")
        return call(session, key, request, SERVICES[service].Response, seq, gid)

    compared = asked = raised = 0
    for seq, question in enumerate(QUESTIONS, start=1):
        if question == "active":
            before = len(heartbeats)
            time.sleep(0.5)
            check(len(heartbeats) > before, "no heartbeat while active")
            continue
        if question == "inactive":
            time.sleep(0.3)
            before = len(heartbeats)
            time.sleep(0.5)
            check(len(heartbeats) == before, f"{len(heartbeats) - before} heartbeats while inactive")
            continue
        service, request = question
        asked += 1
        ours = ask_ours(service, request, seq)
        try:
            theirs = ask_rclpy(reference, service, request)
        except _rclpy.RCLError as e:
            if not check(DISTRO == "jazzy" and service == "change_state",
                         f"{service} {request}: rclpy raised {e}"):
                continue
            theirs = ChangeState.Response(success=False)
            raised += 1
        spin(0.05)
        if check(ours is not None, f"{service}: no reply from our node"):
            compared += check(ours == theirs, f"{service} {request}:\n  ours   {ours}\n  rclpy  {theirs}")

    spin(1.0)
    time.sleep(0.5)
    check(len(rclpy_events) > 0, "rclpy's transition events were not observed")
    check(our_events == rclpy_events,
          f"transition events differ:\n  ours   {our_events}\n  rclpy  {rclpy_events}")

    events.undeclare()
    beats.undeclare()
    live.undeclare()
    session.close()
    proc.stdin.close()
    summary = proc.stdout.read().strip()
    proc.wait(timeout=30)
    check(proc.returncode == 0, f"interop_lifecycle exited with {proc.returncode}")
    check(summary.startswith("state finalized"), f"interop_lifecycle ended with: {summary!r}")
    observer.destroy_node()
    reference.destroy_node()
    rclpy.shutdown()
    print(f"lifecycle ({DISTRO}): {compared}/{asked} replies equal to rclpy's"
          f"{f' ({raised} where rclpy raised: rclcpp answers success=False)' if raised else ''}, "
          f"{len(our_events)} transition events equal to rclpy's, {len(heartbeats)} heartbeats received "
          f"({summary})")
    if failures:
        for f in failures:
            print("FAIL:", f)
        sys.exit(1)


if __name__ == "__main__":
    main()
