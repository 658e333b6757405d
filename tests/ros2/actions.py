#!/usr/bin/env python3
"""Actions against real rcl_action and an independent implementation of
rmw_zenoh_cpp's action conventions, written here from its design: Python
eclipse-zenoh (and zenoh.ext's advanced publisher/subscriber for the
transient-local status topic), rclpy's serialization (real rosidl typesupport),
rosidl's `.json` hashes, python-xxhash GIDs. `test_msgs/action/Fibonacci`.

0. The goal state machine: every (state, event) pair applied to a goal handle
   of real rcl_action (through rclpy's binding, on rmw_fastrtps_cpp) must give
   the state, or the refusal, that `interop_action states` prints.
1. Python serves, Rust calls: three complete queryables and two publishers
   under `/py_fibonacci/_action/`, with tokens (and the node's), which the Rust
   side's graph must read back. `interop_action client` sends a
   goal of order 10 (9 feedbacks, then the result), one of order -1 (rejected)
   and one of order 1000 that it cancels after the first feedback. Every
   request must deserialize with rclpy; goal ids must be random version-4
   UUIDs; the cancel request must name the goal with a zero stamp.
2. Rust serves, Python calls: `interop_action server` serves `/rust_fibonacci`;
   its tokens must name the services, topics, types, rosidl's hashes and
   QoS (status: reliable, transient local, keep last 1); a goal of order 10
   gives 9 feedback messages and the status sequence accepted, executing,
   succeeded, then its result; order -1 is rejected; a long goal canceled
   mid-run ends CANCELED; an unknown id gets ERROR_UNKNOWN_GOAL_ID; a late
   transient-local subscriber gets the last status array; a truncated goal
   request gets an error reply.

    python tests/ros2/actions.py <dir with the interop_action binary>
"""
import json
import os
import subprocess
import sys
import threading
import time
import uuid
from pathlib import Path

os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")

import zenoh  # noqa: E402
import zenoh.ext  # noqa: E402
from action_msgs.msg import GoalInfo, GoalStatus, GoalStatusArray  # noqa: E402
from action_msgs.srv import CancelGoal  # noqa: E402
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402
from test_msgs.action import Fibonacci  # noqa: E402

from rmw_zenoh import attachment, free_port, gid_of, open_session, parse_attachment  # noqa: E402

BIN = Path(sys.argv[1] if len(sys.argv) > 1 else "target/release/examples") / "interop_action"
SHARE = Path(sys.prefix) / "share"
DEFAULT_QOS = "::,10:,:,:,,"  # reliable, volatile, keep last 10 (topics and services alike)
STATUS_QOS = ":1:,1:,:,:,,"  # reliable, transient local, keep last 1
SendGoal = Fibonacci.Impl.SendGoalService
GetResult = Fibonacci.Impl.GetResultService
FeedbackMessage = Fibonacci.Impl.FeedbackMessage
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
    return ok


def rosidl_hash(type_name, json_file):
    """The hash rosidl wrote for `type_name` into the interface's `.json`."""
    desc = json.loads((SHARE / json_file).read_text())
    return next(h["hash_string"] for h in desc["type_hashes"] if h["type_name"] == type_name)


FIB_JSON = "test_msgs/action/Fibonacci.json"
# (entity name under _action/, DDS type, ROS type, json) of each part.
PARTS = {
    "send_goal": ("test_msgs::action::dds_::Fibonacci_SendGoal_", "test_msgs/action/Fibonacci_SendGoal", FIB_JSON),
    "cancel_goal": ("action_msgs::srv::dds_::CancelGoal_", "action_msgs/srv/CancelGoal",
                    "action_msgs/srv/CancelGoal.json"),
    "get_result": ("test_msgs::action::dds_::Fibonacci_GetResult_", "test_msgs/action/Fibonacci_GetResult", FIB_JSON),
    "feedback": ("test_msgs::action::dds_::Fibonacci_FeedbackMessage_", "test_msgs/action/Fibonacci_FeedbackMessage",
                 FIB_JSON),
    "status": ("action_msgs::msg::dds_::GoalStatusArray_", "action_msgs/msg/GoalStatusArray",
               "action_msgs/msg/GoalStatusArray.json"),
}


def key(action, part):
    dds, ros, js = PARTS[part]
    return f"0/{action.strip('/')}/_action/{part}/{dds}/{rosidl_hash(ros, js)}"


def token(session, entity_id, kind, node, action, part, qos):
    dds, ros, js = PARTS[part]
    mangled = f"{action}/_action/{part}".replace("/", "%")
    return (f"@ros2_lv/0/{session.zid()}/0/{entity_id}/{kind}/%/%/{node}/{mangled}/{dds}/{rosidl_hash(ros, js)}/"
            f"{qos}")


def fib(order):
    seq = [0, 1]
    for i in range(1, max(order, 1)):
        seq.append((seq[i] + seq[i - 1] + 2**31) % 2**32 - 2**31)
    return seq


# ---------------------------------------------------------------- 0. states

STATE_NAMES = {1: "Accepted", 2: "Executing", 3: "Canceling", 4: "Succeeded", 5: "Canceled", 6: "Aborted"}


def rcl_state_table():
    """Apply every event to a real rcl_action goal handle in every state."""
    import rclpy
    from rclpy.action import ActionServer
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

    E = _rclpy.GoalEvent
    events = [("Execute", E.EXECUTE), ("CancelGoal", E.CANCEL_GOAL), ("Succeed", E.SUCCEED), ("Abort", E.ABORT),
              ("Canceled", E.CANCELED)]
    paths = {"Accepted": [], "Executing": [E.EXECUTE], "Canceling": [E.CANCEL_GOAL],
             "Succeeded": [E.EXECUTE, E.SUCCEED], "Canceled": [E.CANCEL_GOAL, E.CANCELED],
             "Aborted": [E.EXECUTE, E.ABORT]}
    rclpy.init()
    node = rclpy.create_node("state_table")
    server = ActionServer(node, Fibonacci, "state_table", execute_callback=lambda goal: Fibonacci.Result())
    table = []
    for state, path in paths.items():
        for event_name, event in events:
            info = GoalInfo()
            info.goal_id.uuid = list(uuid.uuid4().bytes)
            with server._handle:
                handle = _rclpy.ActionGoalHandle(server._handle, info)
            for step in path:
                handle.update_goal_state(step)
            check(STATE_NAMES[handle.get_status()] == state, f"rcl path to {state} ended {handle.get_status()}")
            try:
                handle.update_goal_state(event)
                outcome = STATE_NAMES[handle.get_status()]
            except Exception:  # rclpy's RCLError: the transition map has no entry
                outcome = "refused"
            table.append(f"{state} {event_name} {outcome}")
    server.destroy()
    node.destroy_node()
    rclpy.shutdown()
    return table


def state_machine():
    ours = subprocess.run([str(BIN), "states"], capture_output=True, text=True, timeout=60).stdout.split("\n")
    ours = [line for line in ours if line]
    theirs = rcl_state_table()
    for a, b in zip(ours, theirs):
        check(a == b, f"state machine: shm-runtime says {a!r}, rcl_action {b!r}")
    check(len(ours) == len(theirs) == 30, f"state table sizes {len(ours)} / {len(theirs)}")
    allowed = sum(1 for line in theirs if not line.endswith("refused"))
    print(f"state machine: {sum(a == b for a, b in zip(ours, theirs))}/{len(theirs)} (state, event) pairs as "
          f"rcl_action ({allowed} allowed)")


# ---------------------------------------------------------------- 1. Python serves

class PythonServer:
    """Fibonacci over rmw_zenoh_cpp's action conventions, one thread per goal."""

    def __init__(self, session, action):
        self.session, self.action = session, action
        self.lock = threading.Lock()
        self.goals = {}  # id -> dict(stamp, status, result, waiting, cancel)
        self.order = []
        self.requests = {"send_goal": [], "cancel_goal": [], "get_result": []}
        node = "py_action_server"
        self.node_token = session.liveliness().declare_token(f"@ros2_lv/0/{session.zid()}/0/0/NN/%/%/{node}")
        self.tokens = [session.liveliness().declare_token(token(session, 10 + i, "SS", node, action, part, DEFAULT_QOS))
                       for i, part in enumerate(["send_goal", "cancel_goal", "get_result"])]
        fb_token = token(session, 20, "MP", node, action, "feedback", DEFAULT_QOS)
        st_token = token(session, 21, "MP", node, action, "status", STATUS_QOS)
        self.tokens += [session.liveliness().declare_token(t) for t in (fb_token, st_token)]
        self.feedback_gid, self.status_gid = gid_of(fb_token), gid_of(st_token)
        self.feedback_seq = self.status_seq = 0
        self.feedback_pub = session.declare_publisher(key(action, "feedback"))
        self.status_pub = zenoh.ext.declare_advanced_publisher(
            session, key(action, "status"), cache=zenoh.ext.CacheConfig(1), publisher_detection=True,
            sample_miss_detection=zenoh.ext.MissDetectionConfig(heartbeat=None, sporadic_heartbeat=0.5))
        self.queryables = [session.declare_queryable(key(action, part), getattr(self, "on_" + part), complete=True)
                           for part in ("send_goal", "cancel_goal", "get_result")]

    def publish_status(self):
        msg = GoalStatusArray()
        for gid in self.order:
            g = self.goals[gid]
            s = GoalStatus(status=g["status"])
            s.goal_info.goal_id.uuid = list(gid)
            s.goal_info.stamp.sec, s.goal_info.stamp.nanosec = g["stamp"]
            msg.status_list.append(s)
        self.status_seq += 1
        self.status_pub.put(serialize_message(msg), attachment=attachment(self.status_seq, self.status_gid))

    def on_send_goal(self, query):
        att = parse_attachment(None if query.attachment is None else query.attachment.to_bytes())
        req = deserialize_message(query.payload.to_bytes(), SendGoal.Request)
        gid = bytes(req.goal_id.uuid)
        self.requests["send_goal"].append((att, gid, req.goal.order))
        resp = SendGoal.Response()
        if req.goal.order >= 0 and gid not in self.goals:
            now = time.time_ns()
            resp.accepted = True
            resp.stamp.sec, resp.stamp.nanosec = now // 10**9, now % 10**9
            with self.lock:
                self.goals[gid] = dict(stamp=(resp.stamp.sec, resp.stamp.nanosec), status=1, result=None, waiting=[],
                                       cancel=False)
                self.order.append(gid)
        query.reply(query.key_expr, serialize_message(resp), attachment=attachment(att[0], att[2]))
        if resp.accepted:
            with self.lock:
                self.publish_status()
            threading.Thread(target=self.execute, args=(gid, req.goal.order)).start()

    def execute(self, gid, order):
        with self.lock:
            self.goals[gid]["status"] = 2
            self.publish_status()
        seq = [0, 1]
        final = 4
        for i in range(1, max(order, 1)):
            with self.lock:
                if self.goals[gid]["cancel"]:
                    final = 5
                    break
            seq.append((seq[i] + seq[i - 1] + 2**31) % 2**32 - 2**31)
            fb = FeedbackMessage()
            fb.goal_id.uuid = list(gid)
            fb.feedback.sequence = seq
            self.feedback_seq += 1
            self.feedback_pub.put(serialize_message(fb), attachment=attachment(self.feedback_seq, self.feedback_gid))
            time.sleep(0.005)
        with self.lock:
            g = self.goals[gid]
            g["status"], g["result"] = final, seq
            waiting, g["waiting"] = g["waiting"], []
            for q in waiting:
                self.reply_result(q, gid)
            self.publish_status()

    def reply_result(self, query, gid):
        g = self.goals.get(gid)
        resp = GetResult.Response()
        if g is not None:
            resp.status = g["status"]
            resp.result.sequence = g["result"]
        att = parse_attachment(query.attachment.to_bytes())
        query.reply(query.key_expr, serialize_message(resp), attachment=attachment(att[0], att[2]))

    def on_get_result(self, query):
        req = deserialize_message(query.payload.to_bytes(), GetResult.Request)
        gid = bytes(req.goal_id.uuid)
        self.requests["get_result"].append(gid)
        with self.lock:
            g = self.goals.get(gid)
            if g is not None and g["result"] is None:
                g["waiting"].append(query)
                return
            self.reply_result(query, gid)

    def on_cancel_goal(self, query):
        req = deserialize_message(query.payload.to_bytes(), CancelGoal.Request)
        gid = bytes(req.goal_info.goal_id.uuid)
        stamp = (req.goal_info.stamp.sec, req.goal_info.stamp.nanosec)
        self.requests["cancel_goal"].append((gid, stamp))
        resp = CancelGoal.Response()
        with self.lock:
            g = self.goals.get(gid)
            if g is None:
                resp.return_code = CancelGoal.Response.ERROR_UNKNOWN_GOAL_ID
            elif g["status"] not in (1, 2):
                resp.return_code = CancelGoal.Response.ERROR_GOAL_TERMINATED
            else:
                g["status"], g["cancel"] = 3, True
                info = GoalInfo()
                info.goal_id.uuid = list(gid)
                info.stamp.sec, info.stamp.nanosec = g["stamp"]
                resp.goals_canceling.append(info)
                self.publish_status()
        att = parse_attachment(query.attachment.to_bytes())
        query.reply(query.key_expr, serialize_message(resp), attachment=attachment(att[0], att[2]))

    def close(self):
        for q in self.queryables:
            q.undeclare()
        for t in self.tokens:
            t.undeclare()
        self.node_token.undeclare()
        self.status_pub.undeclare()
        self.feedback_pub.undeclare()


def is_uuid4(gid):
    return len(gid) == 16 and gid[6] >> 4 == 4 and gid[8] >> 6 == 2


def python_serves_rust_calls():
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    session = open_session(endpoint, listen=True)
    server = PythonServer(session, "/py_fibonacci")
    proc = subprocess.run([str(BIN), "client", endpoint], capture_output=True, text=True, timeout=120)
    lines = proc.stdout.strip().split("\n")
    check(proc.returncode == 0 and len(lines) == 4,
          f"Rust client: exit {proc.returncode}, {proc.stdout.strip()!r} {proc.stderr.strip()[-800:]!r}")
    sent = server.requests["send_goal"]
    check([order for _, _, order in sent] == [10, -1, 1000], f"goal orders {[o for _, _, o in sent]}")
    check([att[0] for att, _, _ in sent] == [1, 2, 3], f"send_goal sequence numbers {[a for a, _, _ in sent]}")
    check(len({att[2] for att, _, _ in sent}) == 1, "one send_goal client GID")
    ids = [gid for _, gid, _ in sent]
    check(all(is_uuid4(g) for g in ids) and len(set(ids)) == 3, f"goal ids {[g.hex() for g in ids]}")
    if len(lines) == 4 and len(ids) == 3:
        expected = f"goal {ids[0].hex()} Succeeded {fib(10)} feedback 9"
        check(lines[0] == expected, f"first goal: {lines[0]!r} != {expected!r}")
        check(lines[1] == "rejected", f"second goal: {lines[1]!r}")
        check(lines[2] == f"goal {ids[2].hex()} cancel code 0 canceling 1 Canceled", f"third goal: {lines[2]!r}")
        # Our graph reads this peer's tokens back: its node, action and status QoS.
        graph = ('graph node true action {"test_msgs/action/Fibonacci"} servers 1 status publishers 1 '
                 'qos Some(Qos { reliability: Reliable, durability: TransientLocal, history: KeepLast(1), '
                 'deadline: None, lifespan: None, liveliness: Automatic, liveliness_lease: None })')
        check(lines[3] == graph, f"graph of the Python peer: {lines[3]!r}")
    check(server.requests["cancel_goal"] == [(ids[2], (0, 0))] if len(ids) == 3 else False,
          f"cancel requests {server.requests['cancel_goal']}")
    check(server.requests["get_result"] == [ids[0], ids[2]] if len(ids) == 3 else False,
          f"get_result requests {[g.hex() for g in server.requests['get_result']]}")
    server.close()
    session.close()
    print(f"python serves, rust calls: {len(sent)} goals sent (uuid4 ids, seq 1..{len(sent)}), "
          f"{len(server.requests['get_result'])} results asked, {len(server.requests['cancel_goal'])} cancel; "
          f"client saw: {' | '.join(line[:60] for line in lines)}")


# ---------------------------------------------------------------- 2. Rust serves

def call(session, k, payload, seq, gid, timeout=10.0):
    replies = list(session.get(k, payload=payload, attachment=attachment(seq, gid),
                               target=zenoh.QueryTarget.ALL_COMPLETE, consolidation=zenoh.ConsolidationMode.NONE,
                               timeout=timeout))
    oks = [r.ok for r in replies if r.ok is not None]
    errs = [r.err.payload.to_string() for r in replies if r.err is not None]
    if len(oks) == 1:
        att = parse_attachment(None if oks[0].attachment is None else oks[0].attachment.to_bytes())
        check(att is not None and att[0] == seq and att[2] == gid, f"reply attachment {att} for call {seq}")
        return oks[0].payload.to_bytes(), errs
    return None, errs


def rust_serves_python_calls():
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    action = "/rust_fibonacci"
    proc = subprocess.Popen([str(BIN), "server", endpoint], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    check(proc.stdout.readline().strip() == "ready", "Rust action server did not start")
    session = open_session(endpoint, listen=False)

    expected = {
        token(session, 0, "SS", "rust_action_server", action, p, DEFAULT_QOS).split("/SS/")[1]
        for p in ("send_goal", "cancel_goal", "get_result")
    } | {
        token(session, 0, "MP", "rust_action_server", action, "feedback", DEFAULT_QOS).split("/MP/")[1],
        token(session, 0, "MP", "rust_action_server", action, "status", STATUS_QOS).split("/MP/")[1],
    }
    found = set()
    deadline = time.time() + 20
    while len(found) < 5 and time.time() < deadline:
        for r in session.liveliness().get("@ros2_lv/0/**", timeout=5):
            # The action's own endpoints; the node also has what every ROS 2 node
            # declares (parameter services, ~/get_type_description, /parameter_events).
            own = f"/rust_action_server/{action.replace('/', '%')}%_action%"
            if r.ok is not None and own in str(r.ok.key_expr):
                k = str(r.ok.key_expr)
                for kind in ("/SS/", "/MP/"):
                    if kind in k:
                        found.add(k.split(kind)[1])
    check(found == expected, f"tokens: missing {expected - found}, unexpected {found - expected}")

    feedback, statuses = [], []
    fb_sub = session.declare_subscriber(
        key(action, "feedback"), lambda s: feedback.append(deserialize_message(s.payload.to_bytes(), FeedbackMessage)))
    st_sub = zenoh.ext.declare_advanced_subscriber(
        session, key(action, "status"),
        lambda s: statuses.append(deserialize_message(s.payload.to_bytes(), GoalStatusArray)),
        history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=1), subscriber_detection=True)
    time.sleep(0.5)

    my_gid = gid_of(f"@ros2_lv/0/{session.zid()}/0/2/SC/%/%/py_action_client/x")
    seq = 0

    def send_goal(order):
        nonlocal seq
        seq += 1
        req = SendGoal.Request()
        gid = uuid.uuid4().bytes
        req.goal_id.uuid = list(gid)
        req.goal.order = order
        raw, errs = call(session, key(action, "send_goal"), serialize_message(req), seq, my_gid)
        check(raw is not None, f"send_goal {order}: {errs}")
        return gid, (deserialize_message(raw, SendGoal.Response) if raw else None)

    def get_result(gid):
        nonlocal seq
        seq += 1
        req = GetResult.Request()
        req.goal_id.uuid = list(gid)
        raw, errs = call(session, key(action, "get_result"), serialize_message(req), seq, my_gid, timeout=60)
        check(raw is not None, f"get_result: {errs}")
        return deserialize_message(raw, GetResult.Response) if raw else None

    def cancel(gid):
        nonlocal seq
        seq += 1
        req = CancelGoal.Request()
        req.goal_info.goal_id.uuid = list(gid)
        raw, errs = call(session, key(action, "cancel_goal"), serialize_message(req), seq, my_gid)
        check(raw is not None, f"cancel_goal: {errs}")
        return deserialize_message(raw, CancelGoal.Response) if raw else None

    first, accepted = send_goal(10)
    check(accepted is not None and accepted.accepted and accepted.stamp.sec > 0, f"goal of order 10: {accepted}")
    result = get_result(first)
    check(result is not None and result.status == GoalStatus.STATUS_SUCCEEDED and list(result.result.sequence) == fib(10),
          f"result of order 10: {result}")
    time.sleep(0.3)
    mine = [f for f in feedback if bytes(f.goal_id.uuid) == first]
    check([len(f.feedback.sequence) for f in mine] == list(range(3, 12)),
          f"feedback of order 10: {[list(f.feedback.sequence) for f in mine]}")
    codes = [s.status for a in statuses for s in a.status_list if bytes(s.goal_info.goal_id.uuid) == first]
    check(codes == [1, 2, 4], f"status of the first goal: {codes}")

    rejected_id, rejected = send_goal(-1)
    check(rejected is not None and not rejected.accepted, f"goal of order -1: {rejected}")

    long_id, long_accepted = send_goal(1000)
    check(long_accepted is not None and long_accepted.accepted, "long goal accepted")
    deadline = time.time() + 10
    while not any(bytes(f.goal_id.uuid) == long_id for f in feedback) and time.time() < deadline:
        time.sleep(0.01)
    canceled = cancel(long_id)
    check(canceled is not None and canceled.return_code == CancelGoal.Response.ERROR_NONE
          and [bytes(g.goal_id.uuid) for g in canceled.goals_canceling] == [long_id], f"cancel: {canceled}")
    long_result = get_result(long_id)
    check(long_result is not None and long_result.status == GoalStatus.STATUS_CANCELED, f"canceled: {long_result}")
    unknown = cancel(uuid.uuid4().bytes)
    check(unknown is not None and unknown.return_code == CancelGoal.Response.ERROR_UNKNOWN_GOAL_ID,
          f"cancel of an unknown goal: {unknown}")
    expired = get_result(rejected_id)
    check(expired is not None and expired.status == GoalStatus.STATUS_UNKNOWN, f"result of a rejected goal: {expired}")

    # A late transient-local subscriber gets the last status array: both goals, finished.
    late = []
    late_sub = zenoh.ext.declare_advanced_subscriber(
        session, key(action, "status"),
        lambda s: late.append(deserialize_message(s.payload.to_bytes(), GoalStatusArray)),
        history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=1), subscriber_detection=True)
    deadline = time.time() + 5
    while not late and time.time() < deadline:
        time.sleep(0.05)
    last = [(bytes(s.goal_info.goal_id.uuid), s.status) for s in late[0].status_list] if late else None
    check(last == [(first, 4), (long_id, 5)], f"late status subscriber got {late[:1]}")

    truncated = serialize_message(SendGoal.Request())[:10]
    raw, errs = call(session, key(action, "send_goal"), truncated, seq + 1, my_gid)
    check(raw is None and len(errs) == 1 and "at byte" in errs[0], f"truncated goal request: {raw} {errs}")

    late_sub.undeclare()
    st_sub.undeclare()
    fb_sub.undeclare()
    session.close()
    out, _ = proc.communicate("", timeout=30)
    check(proc.returncode == 0 and out.strip() == "succeeded 1 canceled 1",
          f"Rust server: exit {proc.returncode}, {out.strip()!r}")
    print(f"rust serves, python calls: tokens {len(found)}/5, order 10 -> {len(mine)} feedback, status {codes}, "
          f"result {'ok' if result and result.status == 4 else result}; rejected {not rejected.accepted if rejected else '?'}; "
          f"cancel -> status {long_result.status if long_result else '?'}; late subscriber {last}")


def main():
    state_machine()
    python_serves_rust_calls()
    rust_serves_python_calls()
    for f in failures:
        print("  FAIL " + f)
    print(f"actions: {len(failures)} failures")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
