#!/usr/bin/env python3
"""Every distribution with an rmw_zenoh_cpp release, two ways.

1. Interfaces: the RIHS01 hash of every standard message, as each
   distribution defines it in rosbags' type stores (Humble, Jazzy, Kilted,
   Lyrical; Rolling's rcl_interfaces and common_interfaces define the same
   fields as Lyrical's), equals the hash our node uses in that distribution
   (`shm_cdr::msgs`, or `shm_cdr::distro_msgs` where the distribution differs).
   Humble has no hashes on the wire; there the hash stands for the
   definition, so an unlisted change of fields fails too.

2. Conventions: `distro_node` started with each distribution is checked
   against a model of that distribution's rmw_zenoh_cpp, written from its
   release (`ros2-gbp/rmw_zenoh-release`, tag
   `release/<distro>/rmw_zenoh_cpp/<version>`, `liveliness_utils.cpp`,
   `qos.cpp`, `attachment_helpers.cpp`, `rmw_*_data.cpp`): every liveliness
   token (fields, hash field, QoS text), the data key it publishes on (read
   here with the modelled key), the key it subscribes on (written here), the
   service key (called here), an action server's five endpoints (a goal sent
   and its result asked for here) and the 33-byte attachment with the GID of
   the publisher's token; a Humble node has no `~/get_type_description`.

3. Buffer-aware endpoints (Lyrical, Rolling): a peer that behaves as
   0.10.5's buffer-aware publisher and subscriber of `sensor_msgs/Image`
   (`rmw_publisher_data.cpp`: per-subscriber keys `<topic key>/_buf/<GID>`,
   `_buf_cpu` for CPU-only buffer-aware subscribers, the base key only while
   it has matched more subscribers than it has discovered; a subscriber once
   discovered is never forgotten) exchanges Images with our node both ways;
   the keys it sends on grow by our subscriber's own when `shm-ros2 topic
   echo` joins, and keep it after it leaves.

    python tests/ros2/distros.py <dir with ros2_types and distro_node> [<dir with shm-ros2>]
"""
import subprocess
import sys
import time
from pathlib import Path

import zenoh

from rclpy.serialization import deserialize_message, serialize_message
from rosbags.typesys import Stores, get_typestore
from sensor_msgs.msg import Image
from std_msgs.msg import String
from std_srvs.srv import Trigger
from unique_identifier_msgs.msg import UUID

from rmw_zenoh import attachment, call, free_port, gid_of, open_session, parse_attachment, rosidl_hash

BIN = Path(sys.argv[1] if len(sys.argv) > 1 else "target/release/examples")
CLI = Path(sys.argv[2] if len(sys.argv) > 2 else BIN.parent) / "shm-ros2"
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
    return ok


# What differs per release, read from each release's source.
RELEASES = {
    # rmw_zenoh_cpp, hashes in keys and tokens, ~/get_type_description, rosbags' store
    "humble": ("0.1.9", False, False, Stores.ROS2_HUMBLE),
    "jazzy": ("0.2.10", True, True, Stores.ROS2_JAZZY),
    "kilted": ("0.6.7", True, True, Stores.ROS2_KILTED),
    "lyrical": ("0.10.5", True, True, Stores.ROS2_LYRICAL),
    "rolling": ("0.12.0", True, True, Stores.ROS2_LYRICAL),
}
TYPE_HASH_NOT_SUPPORTED = "TypeHashNotSupported"


def our_hashes(mode):
    out = subprocess.run([BIN / "ros2_types", mode], check=True, capture_output=True, text=True).stdout
    return [line.split() for line in out.splitlines()]


def check_interfaces():
    standard = {name: h for kind, name, h in our_hashes("hashes") if kind == "message"}
    variants = {(d, name): h for d, name, h in our_hashes("distro-hashes")}
    # rosbags reads `char` as `uint8`, so its hash of a type with a `char`
    # field is not rosidl's: those types are compared by their fields with
    # Kilted's, whose hash rosidl gives (check.py proves ours equal to it).
    kilted = get_typestore(Stores.ROS2_KILTED)
    installed = {name for name in standard
                 if (Path(sys.prefix) / "share" / name.split("/")[0]).is_dir()}
    by_fields = {name for name in installed
                 if name in kilted.fielddefs and kilted.hash_rihs01(name) != rosidl_hash(name)}
    for distro, (_, _, _, store) in RELEASES.items():
        types = get_typestore(store)
        compared = 0
        for name in sorted(types.fielddefs):
            if name not in standard:
                continue
            ours = variants.get((distro, name), standard[name])
            compared += 1
            if name in by_fields:
                check(types.fielddefs[name] == kilted.fielddefs[name] and ours == rosidl_hash(name),
                      f"{distro}: {name}: fields differ from Kilted's, or ours {ours} is not rosidl's")
                continue
            theirs = types.hash_rihs01(name)
            check(ours == theirs, f"{distro}: {name}: ours {ours}, rosbags' {theirs}")
        own = sorted(name for d, name in variants if d == distro)
        print(f"interfaces {distro}: {compared} standard messages equal to rosbags' {store.name} "
              f"({len(by_fields)} of them by fields: {', '.join(sorted(by_fields))}); "
              f"its own definitions: {', '.join(own) or 'none'}")
        check(compared > 100, f"{distro}: only {compared} messages compared")


# --- rmw_zenoh_cpp's conventions, as each release writes them ---------------

def mangle(name):
    return name.replace("/", "%") if name else "%"


def qos_text(reliability=1, durability=2, history=1, depth=10):
    """`qos_to_keyexpr`: each policy empty when it is rmw_zenoh's default
    (reliable, volatile, keep last 42, infinite durations, automatic
    liveliness); the same function and defaults in all five releases."""
    return ":".join([
        "" if reliability == 1 else str(reliability),
        "" if durability == 2 else str(durability),
        ("" if history == 1 else str(history)) + "," + ("" if depth == 42 else str(depth)),
        ",", ",", ",,",
    ])


def hash_field(distro, type_name, kind="msg"):
    """The type-hash field: `TypeHashNotSupported` on Humble (its
    `rmw_*_data.cpp`), else the RIHS01 hash as that distribution defines the
    type."""
    _, hashes, _, store = RELEASES[distro]
    if not hashes:
        return TYPE_HASH_NOT_SUPPORTED
    if kind == "msg":
        return get_typestore(store).hash_rihs01(type_name)
    # Services are defined alike in every release with hashes.
    return rosidl_hash(type_name)


def dds_name(type_name):
    pkg, kind, name = type_name.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def data_key(distro, name, type_name, kind="msg"):
    return f"0/{name.strip('/')}/{dds_name(type_name)}/{hash_field(distro, type_name, kind)}"


def tokens_of(session, zid):
    replies = session.liveliness().get(f"@ros2_lv/0/{zid}/**", timeout=3)
    return sorted(str(r.ok.key_expr) for r in replies if r.ok is not None)


def start_node(distro):
    """`distro_node` speaking `distro`, once it is ready: its port and process."""
    port = free_port()
    proc = subprocess.Popen([BIN / "distro_node", f"tcp/127.0.0.1:{port}", distro],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "ready"
    return port, proc


def check_node(distro):
    version, hashes, type_description, _ = RELEASES[distro]
    port, proc = start_node(distro)
    try:
        session = open_session(f"tcp/127.0.0.1:{port}", listen=False)
        deadline = time.time() + 10
        tokens = []
        while time.time() < deadline:
            tokens = tokens_of(session, "*")
            if any("/MP/" in t and "%chatter" in t for t in tokens):
                break
            time.sleep(0.1)
        nodes = [t for t in tokens if "/NN/" in t]
        check(len(nodes) == 1 and nodes[0].endswith("/NN/%/%demo/distro_node"),
              f"{distro}: node token {nodes}")
        prefix = "/".join(nodes[0].split("/")[:4]) if nodes else "?"
        endpoints = [t.split("/") for t in tokens if "/NN/" not in t]
        for parts in endpoints:
            token = "/".join(parts)
            if not check(len(parts) == 13, f"{distro}: {len(parts)} fields in {token}"):
                continue
            kind, enclave, ns, node, name, dds, hash_, qos = parts[5:]
            check((enclave, ns, node) == ("%", "%demo", "distro_node"), f"{distro}: node part of {token}")
            pkg, ikind, rest = dds.split("::", 2)
            type_name = f"{pkg}/{ikind}/{rest.removeprefix('dds_::').removesuffix('_')}"
            expected = hash_field(distro, type_name, ikind)
            check(hash_ == expected, f"{distro}: {token}: hash field {hash_}, {expected} expected")
        expected_tokens = {
            ("MP", "%chatter", qos_text(durability=1, depth=7)),
            ("MS", "%echo", qos_text(reliability=2, depth=5)),
            ("SS", "%trigger", qos_text()),
            # An action server: three services and two publishers.
            ("SS", "%fibonacci%_action%send_goal", qos_text()),
            ("SS", "%fibonacci%_action%cancel_goal", qos_text()),
            ("SS", "%fibonacci%_action%get_result", qos_text()),
            ("MP", "%fibonacci%_action%feedback", qos_text()),
            ("MP", "%fibonacci%_action%status", qos_text(durability=1, depth=1)),
        }
        seen = {(p[5], p[9], p[12]) for p in endpoints if len(p) == 13}
        for entity in sorted(expected_tokens):
            check(entity in seen, f"{distro}: no {entity} token among {sorted(seen)}")
        services = {p[9] for p in endpoints if len(p) == 13 and p[5] == "SS"}
        check(("%demo%distro_node%get_type_description" in services) == type_description,
              f"{distro}: ~/get_type_description served: {'%demo%distro_node%get_type_description' in services}")
        check("%demo%distro_node%change_state" in services, f"{distro}: no lifecycle services")

        # Data on the modelled key, with the attachment of the publisher's token.
        publisher = next(("/".join(p) for p in endpoints if len(p) == 13 and p[5] == "MP" and p[9] == "%chatter"), None)
        received = []
        sub = session.declare_subscriber(data_key(distro, "/chatter", "std_msgs/msg/String"),
                                         lambda s: received.append((s.payload.to_bytes(), parse_attachment(
                                             None if s.attachment is None else s.attachment.to_bytes()))))
        deadline = time.time() + 10
        while len(received) < 5 and time.time() < deadline:
            time.sleep(0.05)
        sub.undeclare()
        texts = [deserialize_message(payload, String).data for payload, _ in received]
        check(len(received) >= 5 and all(t.startswith(f"{distro} ") for t in texts),
              f"{distro}: /chatter on the modelled key: {texts[:3]}")
        gids = {a[2] for _, a in received if a is not None}
        check(publisher is not None and gids == {gid_of(publisher)},
              f"{distro}: attachment GIDs {gids}, the publisher token's is {publisher and gid_of(publisher)}")
        seqs = [a[0] for _, a in received if a is not None]
        check(seqs == sorted(seqs) and len(set(seqs)) == len(seqs), f"{distro}: sequence numbers {seqs}")

        # Data into the key it subscribes on.
        me = gid_of(f"{prefix}/python")
        put = session.declare_publisher(data_key(distro, "/echo", "std_msgs/msg/String"))
        line = ""
        for seq in range(1, 40):
            put.put(serialize_message(String(data=f"to {distro}")), attachment=attachment(seq, me))
            time.sleep(0.05)
        put.undeclare()
        # Service on the modelled key.
        reply = call(session, data_key(distro, "/trigger", "std_srvs/srv/Trigger", "srv"),
                     Trigger.Request(), Trigger.Response, 1, me, tries=20)
        check(reply is not None and reply.message == distro, f"{distro}: /trigger reply {reply}")
        # The action: a goal sent and its result asked for on the modelled keys.
        from test_msgs.action import Fibonacci
        goal_id = UUID(uuid=list(range(16)))
        accepted = call(session, data_key(distro, "/fibonacci/_action/send_goal",
                                          "test_msgs/action/Fibonacci_SendGoal", "action"),
                        Fibonacci.Impl.SendGoalService.Request(goal_id=goal_id, goal=Fibonacci.Goal(order=6)),
                        Fibonacci.Impl.SendGoalService.Response, 2, me, tries=20)
        result = call(session, data_key(distro, "/fibonacci/_action/get_result",
                                        "test_msgs/action/Fibonacci_GetResult", "action"),
                      Fibonacci.Impl.GetResultService.Request(goal_id=goal_id),
                      Fibonacci.Impl.GetResultService.Response, 3, me, tries=20)
        action_ok = accepted is not None and accepted.accepted and result is not None \
            and result.status == 4 and list(result.result.sequence) == [0, 1, 1, 2, 3, 5, 8]
        check(action_ok, f"{distro}: /fibonacci goal {accepted}, result {result}")
        proc.stdin.close()
        rest = proc.stdout.read()
        line = next((l for l in rest.splitlines() if l.startswith("echo ")), "")
        check(line == f"echo to {distro}", f"{distro}: /echo written on the modelled key: {line!r}")

        session.close()
        print(f"conventions {distro} (rmw_zenoh_cpp {version}): {len(endpoints)} endpoint tokens as modelled, "
              f"{len(received)} messages read and 1 written on the modelled keys, service answered: "
              f"{reply is not None and reply.message == distro}, action goal and result: {action_ok}; hashes {'RIHS01' if hashes else TYPE_HASH_NOT_SUPPORTED}")
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait()


class BufferAwarePublisher:
    """0.10.5's buffer-aware publisher of a type with `uint8[]` fields, CPU
    buffers: it discovers every subscriber of its topic (the graph calls
    `on_subscriber_discovered` for each, announced buffer-aware or not) and,
    while it has matched no more subscribers than it has discovered, sends
    each message to each one's own key instead of the topic's key:
    `<key>/_buf_cpu` for those whose only backend is `cpu`, else
    `<key>/_buf/<GID in hex>`. A CPU buffer is serialized as the `uint8[]`
    it holds, so the payload is plain CDR. The graph calls it when a
    subscriber appears, never when one leaves: `discovered_subscribers_` and
    `endpoints_` only grow (`on_subscriber_discovered`), so it keeps sending
    to a subscriber that left until it is itself destroyed."""

    def __init__(self, session, prefix, key, token_pattern):
        self.session, self.key = session, key
        self.token = f"{prefix}/901/MP/%/%/lyrical_camera/%image/sensor_msgs::msg::dds_::Image_/" \
                     f"{key.rsplit('/', 1)[1]}/::,10:,:,:,,/backends:cpu:"
        self._token = session.liveliness().declare_token(self.token)
        self.gid = gid_of(self.token)
        self.subscribers = {}  # token -> the key it is sent to
        self.watch = session.liveliness().declare_subscriber(token_pattern, history=True, handler=self.seen)
        self.publishers = {}
        self.seq = 0

    def seen(self, sample):
        token = str(sample.key_expr)
        if sample.kind == zenoh.SampleKind.DELETE:
            return  # never forgotten, as in 0.10.5 and 0.12.0
        parts = token.split("/")
        backends = parts[13] if len(parts) > 13 else ""
        cpu_only = backends.removeprefix("backends:").split(";") == ["cpu:"]
        self.subscribers[token] = f"{self.key}/_buf_cpu" if cpu_only else f"{self.key}/_buf/{gid_of(token).hex()}"

    def publish(self, payload):
        """The keys this message went out on."""
        keys = sorted(set(self.subscribers.values())) if self.subscribers else []
        self.seq += 1
        for key in keys:
            if key not in self.publishers:
                self.publishers[key] = self.session.declare_publisher(key)
            self.publishers[key].put(payload, attachment=attachment(self.seq, self.gid))
        return keys


def check_buffer_aware(distro):
    """A buffer-aware Lyrical peer and our node (`distro_node`, `shm-ros2`)."""
    port, proc = start_node(distro)
    try:
        session = open_session(f"tcp/127.0.0.1:{port}", listen=False)
        zid = str(session.info.zid())
        prefix = f"@ros2_lv/0/{zid}/900"
        hash_ = hash_field(distro, "sensor_msgs/msg/Image")
        image_key = f"0/image/sensor_msgs::msg::dds_::Image_/{hash_}"

        # Ours -> a buffer-aware subscriber: it keeps the topic's key.
        camera_key = f"0/camera/sensor_msgs::msg::dds_::Image_/{hash_}"
        sub_token = f"{prefix}/902/MS/%/%/lyrical_viewer/%camera/sensor_msgs::msg::dds_::Image_/{hash_}/" \
                    f"::,10:,:,:,,/backends:cpu:"
        viewer = session.liveliness().declare_token(sub_token)
        frames = []
        base_sub = session.declare_subscriber(camera_key, lambda s: frames.append(s.payload.to_bytes()))
        cpu_sub = session.declare_subscriber(f"{camera_key}/_buf_cpu", lambda s: frames.append(s.payload.to_bytes()))
        deadline = time.time() + 10
        while len(frames) < 5 and time.time() < deadline:
            time.sleep(0.05)
        images = [deserialize_message(f, Image) for f in frames]
        check(len(images) >= 5 and all(i.width == 4 and len(i.data) == 8 for i in images),
              f"{distro}: buffer-aware subscriber got {len(images)} of our Images")
        for s in (base_sub, cpu_sub, viewer):
            s.undeclare()

        # A buffer-aware publisher -> ours: the keys it sends on as our
        # subscriber joins and leaves. A CPU-only buffer-aware subscriber of
        # its own is there throughout.
        other = session.liveliness().declare_token(
            f"{prefix}/903/MS/%/%/lyrical_viewer/%image/sensor_msgs::msg::dds_::Image_/{hash_}/::,10:,:,:,,/backends:cpu:")
        publisher = BufferAwarePublisher(
            session, prefix, image_key,
            f"@ros2_lv/0/*/*/*/MS/*/*/*/%image/sensor_msgs::msg::dds_::Image_/{hash_}/**")
        payload = serialize_message(Image(height=1, width=3, encoding="mono8", step=3, data=[7, 8, 9]))
        phases = []

        def publish_for(seconds):
            seen = set()
            end = time.time() + seconds
            while time.time() < end:
                seen.add(tuple(k.removeprefix(image_key) for k in publisher.publish(payload)))
                time.sleep(0.05)
            return seen

        deadline = time.time() + 10
        while not publisher.subscribers and time.time() < deadline:
            time.sleep(0.05)
        phases.append(publish_for(0.5))

        # Control: told Kilted, whose publishers have no such keys, our
        # subscriber does not read its own key, and gets nothing.
        control = subprocess.Popen([CLI, "--connect", f"tcp/127.0.0.1:{port}", "--distro", "kilted",
                                    "topic", "echo", "/image", "--once"],
                                   stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        publish_for(3)
        control.kill()
        control_out, _ = control.communicate()
        check("data:" not in control_out, f"{distro}: a Kilted subscriber read a buffer-aware publisher: {control_out!r}")
        time.sleep(0.5)

        echo = subprocess.Popen([CLI, "--connect", f"tcp/127.0.0.1:{port}", "--distro", distro,
                                 "topic", "echo", "/image", "--once"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        joined = set()
        try:
            end = time.time() + 15
            while echo.poll() is None and time.time() < end:
                joined |= publish_for(0.1)
            out, err = echo.communicate(timeout=5)
        finally:
            if echo.poll() is None:
                echo.kill()
        phases.append(joined)
        time.sleep(0.5)
        phases.append(publish_for(0.5))
        check("data:\n- 7\n- 8\n- 9" in out, f"{distro}: shm-ros2 topic echo from a buffer-aware publisher: {out!r} {err[-300:]!r}")
        ours = [k for keys in phases[1] for k in keys if k.startswith("/_buf/")]
        kept = {keys for keys in phases[2] if any(k in ours for k in keys)}
        check(phases[0] == {("/_buf_cpu",)} and ours and kept == phases[2],
              f"{distro}: the publisher's keys before, while and after our subscriber: {phases}")
        other.undeclare()
        session.close()
        print(f"buffer-aware {distro}: our Images reached a buffer-aware subscriber ({len(images)} on the topic's key); "
              f"a buffer-aware publisher sent on {sorted(phases[0])}, then {sorted(joined)} while shm-ros2 subscribed "
              f"(its echo: {'ok' if 'data:' in out else 'nothing'}; told kilted: "
              f"{'nothing' if 'data:' not in control_out else 'read'}), then, after it left, still "
              f"{sorted(phases[2])}")
    finally:
        proc.stdin.close()
        if proc.poll() is None:
            proc.kill()
        proc.wait()


def main():
    check_interfaces()
    for distro in RELEASES:
        check_node(distro)
    for distro in ("lyrical", "rolling"):
        check_buffer_aware(distro)
    for f in failures:
        print("FAIL", f)
    sys.exit(1 if failures else 0)


main()
