#!/usr/bin/env python3
"""`shm-ros2 bag record` against software this project did not write.

An independent rmw_zenoh-convention peer (eclipse-zenoh, rclpy's
serialization, rosidl's hashes; cli.py's Peer) publishes rclpy-serialized
random values of several standard types, and this project's own
`shm-ros2 topic pub` publishes beside it. `shm-ros2 bag record -a` records
them; the recording is then read by:

- the `mcap` Python library with `mcap-ros2-support`'s decoder, which builds
  its decoders from the recording's `ros2msg` schemas: every message's bytes
  equal to what was published, and every decoded value equal to rclpy's;
- `rosbags`' rosbag2 reader (metadata.yaml, the MCAP storage), with types
  registered from the recording's own definitions: every message's bytes
  equal, each one deserialized to the values rclpy has.

Then `shm-ros2 bag info` is compared with the facts, and `shm-ros2 bag play`
publishes the recording to the peer, which reads it with rclpy; with
`--clock`, the peer reads the recording's timeline on `/clock`. Last,
`bag play -p` and `bag record --start-paused` run in a pseudo-terminal and
are steered by their keys and by rosbag2's services, called at keys made
with the hashes rosidl's own tools compute for rosbag2_interfaces (and
every such type they announce in the graph carries that hash); `bag record
--snapshot-mode` writes on `~/snapshot`; `bag play` in a terminal's
background runs to its end.

    python tests/ros2/bag.py <dir with the shm-ros2 binary>
"""
import dataclasses
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rclpy.serialization import deserialize_message, serialize_message
from rmw_zenoh import free_port, rosidl_hash

from cli import BIN, Peer, cli, random_value

failures = []
COUNT = 30


def check(ok, what):
    if not ok:
        failures.append(what)
    return ok


PLACEHOLDER = "structure_needs_at_least_one_member"  # an empty message's stand-in field


def plain(value):
    """A message value as plain Python data, whoever decoded it."""
    if isinstance(value, dict):
        return {k: v for k, v in value.items() if k != PLACEHOLDER}
    if hasattr(value, "get_fields_and_field_types"):
        return plain({name: plain(getattr(value, name)) for name in value.get_fields_and_field_types()})
    if hasattr(value, "__slots__") and not isinstance(value, (bytes, str)):
        return plain({name: plain(getattr(value, name)) for name in value.__slots__})
    if dataclasses.is_dataclass(value):
        # rosbags lists constants as fields too; rosidl names fields in lower
        # case and constants in upper case.
        return plain({f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)
                      if f.name != "__msgtype__" and not f.name.isupper()})
    if hasattr(value, "tolist"):
        return plain(value.tolist())
    if isinstance(value, (bytes, bytearray)):
        # rclpy holds a `byte` as a one-byte bytes object.
        return value[0] if len(value) == 1 else list(value)
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


def first_difference(a, b, path=""):
    """Where two plain values differ first, for the failure message."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in a:
            if k not in b or not same(a[k], b[k]):
                return first_difference(a[k], b.get(k), f"{path}.{k}")
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            if not same(x, y):
                return first_difference(x, y, f"{path}[{i}]")
    return f"{path}: {a!r} vs {b!r}"


def same(a, b):
    """Equal, with one-character `byte`/`char` strings and their numbers alike."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, (bytes, str)) and len(a) == 1 and isinstance(b, int):
        return ord(a) == b
    if isinstance(b, (bytes, str)) and len(b) == 1 and isinstance(a, int):
        return ord(b) == a
    if isinstance(a, float) and isinstance(b, float) and a != a and b != b:
        return True
    if isinstance(a, int) and isinstance(b, int) and min(a, b) < 0 <= max(a, b) < 256:
        # A .msg `char` is uint8 in ROS 2; mcap-ros2-support reads it signed.
        return (a - b) % 256 == 0
    return a == b


def wait_subscribed(endpoint, topics, timeout=60):
    waiting = list(topics)
    deadline = time.time() + timeout
    while waiting and time.time() < deadline:
        waiting = [t for t in waiting if "Subscription count: 1" not in cli(endpoint, "topic", "info", t).stdout]
        time.sleep(0.2)
    return not waiting


def main():
    # The programs started here stop on SIGINT as from a terminal, also where
    # this script was started with SIGINT ignored (a background job of a
    # non-interactive shell), which they would inherit: a handler is not.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    from geometry_msgs.msg import PoseStamped
    from sensor_msgs.msg import Image, JointState
    from std_msgs.msg import String
    from test_msgs.msg import Arrays
    cases = [("/chatter", "std_msgs/msg/String", String), ("/joints", "sensor_msgs/msg/JointState", JointState),
             ("/pose", "geometry_msgs/msg/PoseStamped", PoseStamped), ("/arrays", "test_msgs/msg/Arrays", Arrays),
             ("/camera", "sensor_msgs/msg/Image", Image)]
    classes = {type_name: cls for _, type_name, cls in cases}
    classes["std_msgs/msg/String"] = String
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    peer = Peer(endpoint, "/demo", "py_node")
    publishers = {topic: peer.publisher(topic, type_name) for topic, type_name, _ in cases}
    work = Path(tempfile.mkdtemp(prefix="shm_bag_"))
    bag = work / "recording"
    # Our own traffic beside the peer's: a Rust publisher of this project.
    ours = subprocess.Popen([str(BIN), "--connect", endpoint, "--domain-id", "0", "topic", "pub", "-r", "20",
                             "/ours", "std_msgs/msg/String", "data: from shm-ros2"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    recorder = subprocess.Popen([str(BIN), "--connect", endpoint, "--domain-id", "0", "--timeout", "10",
                                 "bag", "record", "-a", "-o", str(bag), "--no-progress"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        if not wait_subscribed(endpoint, [t for t, _, _ in cases] + ["/ours"]):
            recorder.send_signal(signal.SIGINT)
            _, err = recorder.communicate(timeout=60)
            infos = [cli(endpoint, "topic", "info", t).stdout for t, _, _ in cases]
            check(False, f"the recorder did not subscribe to every topic: {infos} {err[-1000:]}")
            return
        sent = {topic: [] for topic, _, _ in cases}
        for i in range(COUNT):
            for topic, type_name, cls in cases:
                message = random_value(cls)
                if cls is Image:
                    message.height, message.width, message.step = 256, 1024, 1024
                    message.encoding = "mono8"
                    message.data = bytes((i + j) % 256 for j in range(256 * 1024))
                # Serialized once: rclpy leaves padding bytes unset, so two
                # serializations of one message can differ there.
                data = serialize_message(message)
                publishers[topic](message, data)
                sent[topic].append(data)
            time.sleep(0.01)
        time.sleep(1.0)
    finally:
        recorder.send_signal(signal.SIGINT)
        out, err = recorder.communicate(timeout=60)
        ours.send_signal(signal.SIGINT)
        ours.wait(timeout=30)
    check(recorder.returncode == 0, f"bag record: exit {recorder.returncode} {err[-500:]!r}")
    summary = [line for line in err.splitlines() if line.startswith("Recorded ")]
    check(len(summary) == 1 and "dropped 0, missed 0" in summary[0], f"bag record's summary: {err[-500:]!r}")
    print(f"bag record: {summary[0] if summary else '?'}")

    # The mcap library, decoding with mcap-ros2-support from the schemas.
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    files = sorted(bag.glob("*.mcap"))
    seen = {}
    decoded_equal = decoded_total = 0
    with open(files[0], "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        check(header.profile == "ros2", f"profile {header.profile!r}")
        records = [m for m in reader.iter_metadata() if m.name == "rosbag2"]
        # As rosbag2's MCAP storage writes it: the metadata's fields at the top.
        import yaml
        serialized = yaml.safe_load(records[0].metadata.get("serialized_metadata", "")) if records else None
        check(len(records) == 1 and isinstance(serialized, dict) and serialized.get("version") == 9
              and serialized.get("storage_identifier") == "mcap",
              f"the rosbag2 metadata record: {records!r}")
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            check(schema.encoding == "ros2msg" and channel.message_encoding == "cdr",
                  f"{channel.topic}: schema {schema.encoding}, messages {channel.message_encoding}")
            check(channel.metadata.get("topic_type_hash") == rosidl_hash(schema.name),
                  f"{channel.topic}: hash {channel.metadata.get('topic_type_hash')} is not rosidl's")
            seen.setdefault(channel.topic, []).append(message.data)
            cls = classes.get(schema.name)
            if cls is not None:
                decoded_total += 1
                reference = plain(deserialize_message(message.data, cls))
                if check(same(plain(decoded), reference),
                         f"{channel.topic}: mcap-ros2-support decodes "
                         f"{first_difference(plain(decoded), reference)} (rclpy's second)"):
                    decoded_equal += 1
    for topic, messages in sent.items():
        got = seen.get(topic, [])
        for i, (a, b) in enumerate(zip(got, messages)):
            if a != b:
                at = next(j for j, (x, y) in enumerate(zip(a + b"\0", b + b"\0")) if x != y)
                print(f"  {topic}[{i}]: recorded {len(a)} bytes, sent {len(b)}; differ at {at}: "
                      f"{a[max(0, at - 8):at + 8].hex()} vs {b[max(0, at - 8):at + 8].hex()}")
                break
    identical = sum(seen.get(topic) == messages for topic, messages in sent.items())
    check(identical == len(sent), "bytes differ on " + ", ".join(t for t in sent if seen.get(t) != sent[t])
          + f" (counts {[(t, len(seen.get(t, []))) for t in sent]})")
    check(len(seen.get("/ours", [])) > 0 and all(
        deserialize_message(d, String).data == "from shm-ros2" for d in seen["/ours"]),
        f"/ours: {len(seen.get('/ours', []))} messages")
    print(f"mcap + mcap-ros2-support: {identical}/{len(sent)} peer topics byte-identical "
          f"({COUNT} messages each), {decoded_equal}/{decoded_total} decoded values equal to rclpy's, "
          f"{len(seen.get('/ours', []))} messages of shm-ros2's own publisher")

    # rosbags: metadata.yaml, the MCAP storage, types from the recording.
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore, get_types_from_msg
    store = get_typestore(Stores.EMPTY)
    rb_equal = rb_total = rb_refused = 0
    with Reader(bag) as reader:
        types = {}
        for connection in reader.connections:
            types.update(get_types_from_msg(connection.msgdef.data, connection.msgtype))
        store.register(types)
        rb_seen = {}
        for connection, _, raw in reader.messages():
            rb_seen.setdefault(connection.topic, []).append(bytes(raw))
            cls = classes.get(connection.msgtype)
            if cls is not None:
                rb_total += 1
                try:
                    value = store.deserialize_cdr(raw, connection.msgtype)
                except Exception:  # noqa: BLE001 - rosbags' own refusal, counted below
                    # The bytes are rclpy's, unchanged (compared above): rosbags
                    # refuses some of rclpy's own serializations (Fast-CDR aligns
                    # an empty float64 sequence, rosbags does not expect it).
                    rb_refused += 1
                    continue
                reference = plain(deserialize_message(bytes(raw), cls))
                if check(same(plain(value), reference),
                         f"{connection.topic}: rosbags reads {first_difference(plain(value), reference)}"):
                    rb_equal += 1
        rb_identical = sum(rb_seen.get(t) == m for t, m in sent.items())
        check(rb_identical == len(sent), "rosbags: bytes differ")
        counts = {c.topic: c.msgcount for c in reader.connections}
        check(all(counts.get(t) == COUNT for t in sent), f"rosbags counts {counts}")
    check(rb_equal + rb_refused == rb_total and rb_equal > rb_total // 2, f"rosbags: {rb_equal}/{rb_total}")
    print(f"rosbags: {rb_identical}/{len(sent)} topics byte-identical, {rb_equal}/{rb_total} values "
          f"deserialized from the recording's definitions equal to rclpy's ({rb_refused} refused by rosbags' "
          f"deserializer, which refuses the same bytes straight from rclpy too)")

    # bag info: ros2bag's format, with the facts.
    proc = subprocess.run([str(BIN), "bag", "info", str(bag)], capture_output=True, text=True, timeout=60)
    lines = proc.stdout.splitlines()
    check(proc.returncode == 0 and lines[0] == "" and lines[1] == f"Files:             {files[0].name}"
          and "Storage id:        mcap" in lines
          and f"Topic information: Topic: /arrays | Type: test_msgs/msg/Arrays | Count: {COUNT} | "
              "Serialization Format: cdr" in lines,
          f"bag info: {proc.stdout!r} {proc.stderr[-300:]!r}")
    print("bag info: ros2bag's format")

    # bag play: the peer reads what is played with rclpy.
    received = []
    peer.subscriber("/chatter_replay", "std_msgs/msg/String", received.append)
    del received[:]
    got = []
    peer.subscriber("/chatter", "std_msgs/msg/String", got.append)
    proc = subprocess.run([str(BIN), "--connect", endpoint, "--domain-id", "0", "bag", "play", str(bag),
                           "--topics", "/chatter", "-r", "5", "-d", "2"],
                          capture_output=True, text=True, timeout=120)
    deadline = time.time() + 5
    while len(got) < COUNT and time.time() < deadline:
        time.sleep(0.05)
    check(proc.returncode == 0 and got == sent["/chatter"],
          f"bag play: exit {proc.returncode} {proc.stderr[-300:]!r}, the peer read {len(got)} of {COUNT}")
    print(f"bag play: the peer read {len(got)}/{COUNT} /chatter messages, byte-identical: {got == sent['/chatter']}")

    # bag play --clock: the recording's timeline on /clock, from the start
    # offset on, as rclpy reads rosgraph_msgs/Clock.
    from rosgraph_msgs.msg import Clock
    starts, ends = [], []
    for path in files:
        with open(path, "rb") as f:
            stats = make_reader(f).get_summary().statistics
            starts.append(stats.message_start_time)
            ends.append(stats.message_end_time)
    begin, end = min(starts) + 200_000_000, max(ends)
    ticks = []
    peer.subscriber("/clock", "rosgraph_msgs/msg/Clock", ticks.append)
    proc = subprocess.run([str(BIN), "--connect", endpoint, "--domain-id", "0", "bag", "play", str(bag),
                           "--topics", "/chatter", "--clock", "100", "--start-offset", "0.2", "-r", "5", "-d", "1"],
                          capture_output=True, text=True, timeout=120)
    time.sleep(0.5)
    times = [c.clock.sec * 1_000_000_000 + c.clock.nanosec
             for c in (deserialize_message(t, Clock) for t in list(ticks))]
    check(proc.returncode == 0 and len(times) >= 20 and times == sorted(times)
          and all(begin <= t <= end + 200_000_000 for t in times) and times[-1] > begin,
          f"bag play --clock: exit {proc.returncode} {proc.stderr[-300:]!r}, {len(times)} ticks "
          f"{times[:3]}..{times[-3:]} against {begin}..{end}")
    print(f"bag play --clock: {len(times)} /clock ticks read with rclpy, from the start offset "
          f"({(times[0] - begin) / 1e6 if times else 0:.0f} ms after it) to "
          f"{(end - times[-1]) / 1e6 if times else 0:.0f} ms before the recording's end, never going back")
    hashes = rosbag2_interfaces_hashes()
    check_player_control(endpoint, peer, bag, got, sent["/chatter"], hashes)
    check_recorder_control(endpoint, peer, work, hashes)
    check_snapshot(endpoint, peer, work, hashes)
    check_background_playback(endpoint, bag)
    check_stops(endpoint, peer, work)
    check_rosbags_bags(endpoint, peer, work)
    check_service_events(endpoint, peer, work)
    if not failures:
        shutil.rmtree(work, ignore_errors=True)


CDR_HEADER = b"\0\1\0\0"  # CDR, little-endian
EMPTY_REQUEST = CDR_HEADER + b"\0"  # an empty request's placeholder byte


def rosbag2_interfaces_hashes():
    """rosidl's hashes of this project's copy of rosbag2_interfaces, from rosidl's own tools."""
    from rmw_zenoh import package_hashes
    source = Path(__file__).resolve().parents[2] / "shm-codegen" / "interfaces" / "rosbag2_interfaces"
    return package_hashes(source, "rosbag2_interfaces", ["builtin_interfaces", "service_msgs"])


def asker(peer, node, hashes):
    """Calls of `node`'s rosbag2 services, with CDR written by the caller:
    `ask(service, Srv, payload)` is the reply's CDR body, or None."""
    from rmw_zenoh import call_raw
    seq = [0]
    gid = os.urandom(16)

    def ask(service, srv, payload=EMPTY_REQUEST):
        seq[0] += 1
        key = f"0/{node}/{service}/rosbag2_interfaces::srv::dds_::{srv}_/" \
              f"{hashes[f'rosbag2_interfaces/srv/{srv}']}"
        reply = call_raw(peer.session, key, payload, seq[0], gid, tries=200)
        return None if reply is None else reply[4:]
    return ask


def check_announced_hashes(peer, node, hashes, expected):
    """Every rosbag2_interfaces type `node` announces in the graph (its
    liveliness tokens: `…/<kind>/<enclave>/<ns>/<node>/<name>/<dds type>/<hash>/…`)
    carries rosidl's hash; `expected` of them are there."""
    announced = {}
    deadline = time.time() + 20
    while len(announced) < expected and time.time() < deadline:
        for reply in peer.session.liveliness().get("@ros2_lv/0/**", timeout=5):
            if reply.ok is None:
                continue
            parts = str(reply.ok.key_expr).split("/")
            if len(parts) > 11 and parts[8] == node and parts[10].startswith("rosbag2_interfaces::"):
                pkg, kind, _, name = parts[10].split("::")
                announced[f"{pkg}/{kind}/{name.rstrip('_')}"] = parts[11]
    wrong = {t: h for t, h in announced.items() if hashes.get(t) != h}
    check(len(announced) == expected and not wrong,
          f"{node} announces {len(announced)} of {expected} rosbag2_interfaces types, wrong hashes: {wrong}")
    return len(announced) - len(wrong)


def check_player_control(endpoint, peer, bag, got, sent, hashes):
    """`bag play --start-paused` in a terminal: rosbag2's player services,
    called with rosidl's hashes of rosbag2_interfaces in their keys and CDR
    written here, and the keys of `ros2 bag play` pressed on the terminal."""
    import pty
    import struct
    header = CDR_HEADER
    ask = asker(peer, "rosbag2_player", hashes)

    def wait_for(count, timeout=20):
        deadline = time.time() + timeout
        while len(got) < count and time.time() < deadline:
            time.sleep(0.02)
        return len(got)

    del got[:]
    terminal, child = pty.openpty()
    proc = subprocess.Popen([str(BIN), "--connect", endpoint, "--domain-id", "0", "bag", "play", str(bag),
                             "--topics", "/chatter", "--start-paused"],
                            stdin=child, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    os.close(child)
    try:
        paused = ask("is_paused", "IsPaused")
        check(paused == b"\1", f"is_paused: {paused!r}")
        # Ten services and /events/read_split.
        same = check_announced_hashes(peer, "rosbag2_player", hashes, 11)
        time.sleep(0.5)
        check(not got, f"paused, yet {len(got)} messages came")
        os.write(terminal, b"\x1b[C")  # cursor right: the next message
        check(wait_for(1) == 1, f"cursor right: {len(got)} messages")
        burst = ask("burst", "Burst", header + struct.pack("<Q", 2))
        check(burst == struct.pack("<Q", 2) and wait_for(3) == 3, f"burst 2: {burst!r}, {len(got)} messages")
        check(ask("set_rate", "SetRate", header + struct.pack("<d", 0.0)) == b"\0", "set_rate 0 accepted")
        check(ask("set_rate", "SetRate", header + struct.pack("<d", 5.0)) == b"\1", "set_rate 5 refused")
        os.write(terminal, b"\x1b[A")  # cursor up: the rate 0.1 higher
        deadline = time.time() + 10
        rate = None
        while time.time() < deadline:
            rate = struct.unpack("<d", ask("get_rate", "GetRate")[:8])[0]
            if rate != 5.0:
                break
            time.sleep(0.05)
        check(rate == 5.1, f"get_rate after cursor up: {rate}")
        time.sleep(0.3)
        check(len(got) == 3, f"still paused, yet {len(got)} messages")
        os.write(terminal, b" ")  # space: resume
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        os.close(terminal)
    wait_for(len(sent), timeout=5)
    check(proc.returncode == 0 and got == sent,
          f"bag play --start-paused: exit {proc.returncode}, the peer read {len(got)} of {len(sent)} "
          f"{err[-500:]!r}")
    said = ["Press SPACE for Pause/Resume", "Played the next message.", "Set rate to 5.1", "Resuming play."]
    check(all(line in err.splitlines() for line in said), f"bag play's terminal: {err[-500:]!r}")
    print(f"bag play --start-paused: {same}/11 rosbag2_interfaces types announced with rosidl's hashes; "
          f"is_paused, burst, set_rate and get_rate answered at keys made with rosidl's hashes; cursor right, cursor up and space acted; the peer read {len(got)}/{len(sent)} messages "
          f"in order")



def cdr_strings(body, count):
    """`count` CDR strings from a message body (each 4-aligned)."""
    import struct
    out, at = [], 0
    for _ in range(count):
        at += -at % 4
        (n,) = struct.unpack_from("<I", body, at)
        out.append(body[at + 4:at + 4 + n - 1].decode())
        at += 4 + n
    return out


def interrupt(proc):
    """Ctrl-C to `proc` (killed if it has not ended a minute later); its stderr."""
    proc.send_signal(signal.SIGINT)
    try:
        return proc.communicate(timeout=60)[1]
    except subprocess.TimeoutExpired:
        proc.kill()
        return proc.communicate()[1]


def check_recorder_control(endpoint, peer, work, hashes):
    """`bag record --start-paused` in a terminal: space resumes it,
    rosbag2's `~/is_paused` and `~/split_bagfile` answer at keys made with
    rosidl's hashes, and the split is announced on `/events/write_split` as
    a WriteSplitEvent of rosidl's hash, read here from its CDR."""
    import pty
    from mcap.reader import make_reader
    from rclpy.serialization import serialize_message
    from std_msgs.msg import String
    ask = asker(peer, "rosbag2_recorder", hashes)
    publish = peer.publisher("/paced", "std_msgs/msg/String")
    events = []
    event_key = "0/events/write_split/rosbag2_interfaces::msg::dds_::WriteSplitEvent_/" \
                + hashes["rosbag2_interfaces/msg/WriteSplitEvent"]
    peer.keep.append(peer.session.declare_subscriber(event_key, lambda s: events.append(s.payload.to_bytes())))
    sent = [serialize_message(String(data=f"paced {i}")) for i in range(9)]
    bag = work / "paused"
    terminal, child = pty.openpty()
    proc = subprocess.Popen([str(BIN), "--connect", endpoint, "--domain-id", "0", "bag", "record", "/paced",
                             "-o", str(bag), "--start-paused", "--no-progress"],
                            stdin=child, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    os.close(child)
    err = ""
    try:
        check(wait_subscribed(endpoint, ["/paced"]), "bag record did not subscribe to /paced")
        check(ask("is_paused", "IsPaused") == b"\1", "bag record --start-paused is not paused")
        for data in sent[:3]:
            publish(None, data)
        time.sleep(0.5)
        os.write(terminal, b" ")  # space: resume
        deadline = time.time() + 10
        while ask("is_paused", "IsPaused") != b"\0" and time.time() < deadline:
            time.sleep(0.05)
        for data in sent[3:7]:
            publish(None, data)
        time.sleep(0.5)
        check(ask("split_bagfile", "SplitBagfile") is not None, "split_bagfile: no answer")
        deadline = time.time() + 10
        while not events and time.time() < deadline:
            time.sleep(0.05)
        split = cdr_strings(events[0][4:], 3) if events else None
        check(split == [str((bag / "paused_0.mcap").resolve()), str((bag / "paused_1.mcap").resolve()),
                        "/rosbag2_recorder"], f"the split event: {split}")
        for data in sent[7:]:
            publish(None, data)
        time.sleep(0.5)
    finally:
        err = interrupt(proc)
        os.close(terminal)
    files = []
    for name in ("paused_0.mcap", "paused_1.mcap"):
        with open(bag / name, "rb") as f:
            files.append([m.data for _, _, m in make_reader(f).iter_messages()])
    check(proc.returncode == 0 and files == [sent[3:7], sent[7:]],
          f"bag record --start-paused: exit {proc.returncode}, files hold {[len(f) for f in files]} messages "
          f"{err[-500:]!r}")
    check(all(line in err.splitlines() for line in ["Press SPACE for pausing/resuming", "Resuming recording."]),
          f"bag record's terminal: {err[-500:]!r}")
    print(f"bag record --start-paused: space resumed it, split_bagfile split it ({len(events)} WriteSplitEvent "
          f"read), the two files hold the {len(files[0])} + {len(files[1])} messages sent while recording "
          f"and none of the 3 sent while paused")



def read_back(bag):
    """Every message of a bag directory as rosbags and as the mcap library
    (through each file's summary and index) read it: two lists of bytes."""
    from mcap.reader import make_reader
    from rosbags.rosbag2 import Reader
    with Reader(bag) as reader:
        by_rosbags = [data for _, _, data in reader.messages()]
    by_mcap = []
    for path in sorted(bag.glob("*.mcap")):
        with open(path, "rb") as f:
            by_mcap += [m.data for _, _, m in make_reader(f).iter_messages()]
    return by_rosbags, by_mcap


def check_stops(endpoint, peer, work):
    """What `docker stop`, systemd and a closed terminal send stops a
    recording cleanly; `kill -9` loses at most the last chunk interval once
    `bag reindex` has run. Both bags are read by rosbags and the mcap library."""
    import threading
    from std_msgs.msg import String
    publish = peer.publisher("/steady", "std_msgs/msg/String")
    sent = []
    running = threading.Event()
    running.set()

    def talk():
        i = 0
        while running.is_set():
            data = serialize_message(String(data=f"steady {i}"))
            publish(None, data)
            sent.append(data)
            i += 1
            time.sleep(0.02)  # 50 Hz

    talker = threading.Thread(target=talk)
    talker.start()
    try:
        for how in (signal.SIGTERM, signal.SIGHUP, signal.SIGKILL):
            bag = work / f"stopped_{how.name}"
            proc = subprocess.Popen([str(BIN), "--connect", endpoint, "--domain-id", "0", "bag", "record",
                                     "/steady", "-o", str(bag), "--no-progress", "--disable-keyboard-controls",
                                     "--compression-format", "zstd"],
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            check(wait_subscribed(endpoint, ["/steady"]), "bag record did not subscribe to /steady")
            time.sleep(3)
            counted = 0
            if how == signal.SIGKILL:
                # What metadata.yaml, refreshed at each chunk, counted on disk.
                import yaml
                counted = yaml.safe_load((bag / "metadata.yaml").read_text())[
                    "rosbag2_bagfile_information"]["message_count"]
            proc.send_signal(how)
            _, err = proc.communicate(timeout=60)
            if how == signal.SIGKILL:
                check(proc.returncode == -signal.SIGKILL, f"kill -9: exit {proc.returncode}")
                fixed = cli(endpoint, "bag", "reindex", str(bag))
                check(fixed.returncode == 0 and "rewritten with" in fixed.stdout,
                      f"bag reindex: {fixed.returncode} {fixed.stdout} {fixed.stderr}")
            else:
                check(proc.returncode == 0 and "Recorded " in err,
                      f"SIG{how.name}: exit {proc.returncode} {err[-300:]!r}")
            by_rosbags, by_mcap = read_back(bag)
            in_order = by_mcap == sent[sent.index(by_mcap[0]):][:len(by_mcap)] if by_mcap else False
            check(by_rosbags == by_mcap and len(by_mcap) >= max(counted, 100) and in_order,
                  f"{how.name}: rosbags read {len(by_rosbags)}, mcap {len(by_mcap)} (counted before: {counted}), "
                  f"consecutive messages as sent: {in_order}")
            print(f"bag record stopped by {how.name}: {len(by_mcap)} messages read by rosbags and mcap, "
                  f"consecutive as sent" + (f" (metadata.yaml had counted {counted} before the kill; "
                                            f"bag reindex rebuilt the file)" if counted else ""))
    finally:
        running.clear()
        talker.join()
    check_full_disk(endpoint, peer, work)
    check_sync(endpoint, work)


def check_sync(endpoint, work):
    """A recording is on the disk, not only in the page cache, once a second:
    strace sees the MCAP file synced while it is recorded, and metadata.yaml
    and the directory with it."""
    import re
    if not shutil.which("strace"):
        check(False, "strace is not installed (.ci/run installs it)")
        return
    publisher = subprocess.Popen([str(BIN), "--connect", endpoint, "--domain-id", "0", "topic", "pub", "-r", "50",
                                  "/synced", "std_msgs/msg/String", "data: kept"],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    bag = work / "synced"
    trace = work / "synced.strace"
    try:
        proc = subprocess.Popen(["strace", "-f", "-y", "-qq", "-e", "trace=fsync,fdatasync", "-o", str(trace),
                                 str(BIN), "--connect", endpoint, "--domain-id", "0", "bag", "record", "/synced",
                                 "-o", str(bag), "--no-progress", "--disable-keyboard-controls"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(6)
        # The recorder is strace's child; strace itself would only detach.
        children = Path(f"/proc/{proc.pid}/task/{proc.pid}/children").read_text().split()
        for child in children:
            os.kill(int(child), signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        publisher.send_signal(signal.SIGINT)
        publisher.wait(timeout=30)
    text = trace.read_text() if trace.exists() else ""
    if proc.returncode != 0 and "ptrace" in (err + text):
        check(False, f"strace could not trace the recorder here: {err[-300:]!r}")
        return
    syncs = re.findall(r"(fsync|fdatasync)\(\d+<([^>]*)>\) = 0", text)
    data = [p for call, p in syncs if p == str((bag / "synced_0.mcap").resolve()) and call == "fdatasync"]
    metadata = [p for _, p in syncs if p.endswith(".metadata.yaml.partial")]
    directory = [p for _, p in syncs if p == str(bag.resolve())]
    check(proc.returncode == 0 and len(data) >= 3 and metadata and directory,
          f"syncs while recording for 6 s: {len(data)} of the MCAP file, {len(metadata)} of metadata.yaml, "
          f"{len(directory)} of the directory; exit {proc.returncode} {err[-300:]!r}")
    print(f"bag record synced to the disk: the MCAP file {len(data)} times in 6 s of recording, "
          f"metadata.yaml {len(metadata)} times, the directory {len(directory)} times")


def check_full_disk(endpoint, peer, work):
    """A recording onto a 3 MiB tmpfs fills it: the recorder says the OS's
    words, stops, prints its totals and exits 1; what it wrote reads back
    after `bag reindex`. Skipped where tmpfs cannot be mounted (not root)."""
    from sensor_msgs.msg import Image
    mount = work / "small_disk"
    mount.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=3m", "tmpfs", str(mount)],
                      capture_output=True).returncode != 0:
        print("bag record onto a full disk: skipped (mounting a tmpfs is not permitted here)")
        return
    try:
        publish = peer.publisher("/frames", "sensor_msgs/msg/Image")
        bag = mount / "bag"
        proc = subprocess.Popen([str(BIN), "--connect", endpoint, "--domain-id", "0", "bag", "record",
                                 "/frames", "-o", str(bag), "--no-progress", "--disable-keyboard-controls"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        check(wait_subscribed(endpoint, ["/frames"]), "bag record did not subscribe to /frames")
        frame = Image(height=256, width=1024, step=1024, encoding="mono8", data=bytes(256 * 1024))
        data = serialize_message(frame)
        for _ in range(40):  # 10 MiB into 3 MiB
            publish(None, data)
            time.sleep(0.05)
            if proc.poll() is not None:
                break
        try:
            _, err = proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            err = interrupt(proc)
        check(proc.returncode == 1 and "No space left on device" in err and "before writing failed" in err,
              f"bag record onto a full disk: exit {proc.returncode} {err[-600:]!r}")
        # The user makes room (reindex writes a new copy of the file), then reindexes.
        subprocess.run(["mount", "-o", "remount,size=16m", str(mount)], check=True)
        fixed = cli(endpoint, "bag", "reindex", str(bag))
        by_rosbags, by_mcap = read_back(bag) if fixed.returncode == 0 else ([], [])
        check(fixed.returncode == 0 and len(by_mcap) > 0 and by_rosbags == by_mcap
              and all(m == data for m in by_mcap),
              f"after the full disk: reindex {fixed.returncode} {fixed.stdout} {fixed.stderr}, "
              f"read {len(by_rosbags)} / {len(by_mcap)}")
        said = [line for line in err.splitlines() if "No space left" in line][-1:] or [""]
        said = said[0]
        print(f"bag record onto a full 3 MiB disk: exit {proc.returncode}, said {said.strip()[-160:]!r}; "
              f"{len(by_mcap)} frames read back by rosbags and mcap after bag reindex")
    finally:
        subprocess.run(["umount", str(mount)], capture_output=True)


def check_snapshot(endpoint, peer, work, hashes):
    """`bag record --snapshot-mode`: its six rosbag2_interfaces types carry
    rosidl's hashes, `~/snapshot` writes what was held, and what is held at
    the end is reported, not written."""
    from mcap.reader import make_reader
    from rclpy.serialization import serialize_message
    from std_msgs.msg import String
    ask = asker(peer, "rosbag2_recorder", hashes)
    publish = peer.publisher("/snapped", "std_msgs/msg/String")
    sent = [serialize_message(String(data=f"snapped {i}")) for i in range(7)]
    bag = work / "snapshots"
    proc = subprocess.Popen([str(BIN), "--connect", endpoint, "--domain-id", "0", "bag", "record", "/snapped",
                             "-o", str(bag), "--snapshot-mode", "--no-progress"],
                            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    err = ""
    try:
        check(wait_subscribed(endpoint, ["/snapped"]), "bag record --snapshot-mode did not subscribe")
        # pause, resume, is_paused, split_bagfile, snapshot; /events/write_split.
        same = check_announced_hashes(peer, "rosbag2_recorder", hashes, 6)
        for data in sent[:5]:
            publish(None, data)
        time.sleep(0.5)
        check(ask("snapshot", "Snapshot") == b"\1", "snapshot: not a success")
        for data in sent[5:]:
            publish(None, data)
        time.sleep(0.5)
    finally:
        err = interrupt(proc)
    with open(bag / "snapshots_0.mcap", "rb") as f:
        written = [m.data for _, _, m in make_reader(f).iter_messages()]
    check(proc.returncode == 0 and written == sent[:5]
          and "Not written: 2 messages held for a snapshot that was not taken" in err,
          f"bag record --snapshot-mode: exit {proc.returncode}, {len(written)} written {err[-500:]!r}")
    print(f"bag record --snapshot-mode: {same}/6 rosbag2_interfaces types announced with rosidl's hashes; "
          f"~/snapshot wrote the {len(written)} messages held, the 2 after it reported as not written")


def played_to_peer(endpoint, bag, got, sent, what, rate="10"):
    """`bag play` of `bag` at `rate` to the peer subscribed into `got`:
    checks that it read `sent`, in order, byte for byte."""
    got.clear()
    played = cli(endpoint, "bag", "play", str(bag), "-r", rate, "-d", "1", timeout=120)
    deadline = time.time() + 5
    while len(got) < len(sent) and time.time() < deadline:
        time.sleep(0.05)
    check(played.returncode == 0 and got == sent,
          f"bag play of {what}: exit {played.returncode} {played.stderr[-300:]!r}, "
          f"the peer read {len(got)} of {len(sent)}, in order: {got == sorted(got, key=sent.index)}")


def check_rosbags_bags(endpoint, peer, work):
    """Bags rosbags writes: format version 8 (offered QoS as one YAML text,
    as rosbag2 wrote it through Iron) in MCAP storage is read and played byte
    for byte with its QoS; rosbags' default storage, sqlite3, is refused
    naming the storage."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.interfaces import (Qos, QosDurability, QosHistory, QosLiveliness, QosReliability,
                                    QosTime)
    from rosbags.typesys import Stores, get_typestore
    from std_msgs.msg import String
    store = get_typestore(Stores.ROS2_HUMBLE)
    sent = [serialize_message(String(data=f"old {i}")) for i in range(20)]
    old = work / "version_8"
    with Writer(old, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        zero = QosTime(sec=0, nsec=0)
        qos = Qos(history=QosHistory.KEEP_LAST, depth=7, reliability=QosReliability.RELIABLE,
                  durability=QosDurability.TRANSIENT_LOCAL, deadline=zero, lifespan=zero,
                  liveliness=QosLiveliness.AUTOMATIC, liveliness_lease_duration=zero,
                  avoid_ros_namespace_conventions=False)
        connection = writer.add_connection("/old", "std_msgs/msg/String", typestore=store,
                                           offered_qos_profiles=[qos])
        for i, data in enumerate(sent):
            writer.write(connection, 1_700_000_000_000_000_000 + i * 10_000_000, data)
    import yaml
    written = yaml.safe_load((old / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    offered = written["topics_with_message_count"][0]["topic_metadata"]["offered_qos_profiles"]
    check(written["version"] == 8 and isinstance(offered, str) and "depth: 7" in offered,
          f"rosbags did not write a version-8 metadata.yaml with QoS as text: {written}")
    info = cli(endpoint, "bag", "info", str(old))
    check(info.returncode == 0 and "/old" in info.stdout and "Count: 20" in info.stdout,
          f"bag info of a version-8 bag: {info.returncode} {info.stdout[-400:]} {info.stderr[-300:]}")
    got = []
    peer.subscriber("/old", "std_msgs/msg/String", got.append)
    played_to_peer(endpoint, old, got, sent, "a version-8 bag")

    # sqlite3 (rosbags' default storage, rosbag2's through Humble), in both
    # metadata versions, the messages written out of time order: played in
    # time order, byte for byte.
    for version in (8, 9):
        sqlite = work / f"sqlite3_v{version}"
        with Writer(sqlite, version=version) as writer:
            connection = writer.add_connection("/old", "std_msgs/msg/String", typestore=store)
            for i in reversed(range(len(sent))):
                writer.write(connection, 1_700_000_000_000_000_000 + i * 10_000_000, sent[i])
        info = cli(endpoint, "bag", "info", str(sqlite))
        check(info.returncode == 0 and "Storage id:        sqlite3" in info.stdout and "Count: 20" in info.stdout,
              f"bag info of a sqlite3 bag: {info.returncode} {info.stdout[-400:]} {info.stderr[-300:]}")
        played_to_peer(endpoint, sqlite, got, sent, f"a sqlite3 bag (version {version})")
    check_older_metadata(endpoint, peer, work, sqlite, sent, got)
    check_compressed_bags(endpoint, work, store, sent, got)
    # Converted to MCAP: every message, in time order, read by rosbags and
    # the mcap library.
    converted = work / "converted"
    done = cli(endpoint, "bag", "convert", "-i", str(sqlite), "-o", str(converted), "--compression-format", "zstd")
    check(done.returncode == 0 and "Converted 20 messages on 1 topic " in done.stdout,
          f"bag convert: {done.returncode} {done.stdout[-300:]} {done.stderr[-300:]}")
    by_rosbags, by_mcap = read_back(converted)
    check(by_rosbags == sent and by_mcap == sent,
          f"the converted bag: rosbags {len(by_rosbags)}, mcap {len(by_mcap)} of {len(sent)} in order")
    print(f"rosbags' bags: a version-8 MCAP bag (QoS as text) read by bag info and played byte for byte "
          f"({len(sent)}/{len(sent)}); sqlite3 bags (versions 8 and 9, written out of time order) played "
          f"in time order byte for byte; converted to MCAP (zstd) and read back by rosbags and mcap")
    check_out_of_order_mcap(endpoint, peer, work, store)


def check_compressed_bags(endpoint, work, store, sent, got):
    """Bags rosbag2 compressed itself (`--compression-mode file|message`,
    zstd), written by rosbags in both storages, play byte for byte."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.enums import CompressionFormat, CompressionMode
    played_bags = []
    for plugin in (StoragePlugin.SQLITE3, StoragePlugin.MCAP):
        for mode in (CompressionMode.FILE, CompressionMode.MESSAGE):
            bag = work / f"compressed_{plugin.name.lower()}_{mode.name.lower()}"
            writer = Writer(bag, version=9, storage_plugin=plugin)
            writer.set_compression(mode, CompressionFormat.ZSTD)
            writer.open()
            connection = writer.add_connection("/old", "std_msgs/msg/String", typestore=store)
            for i, data in enumerate(sent):
                writer.write(connection, 1_700_000_000_000_000_000 + i * 10_000_000, data)
            writer.close()
            played_to_peer(endpoint, bag, got, sent, bag.name, rate="20")
            leftovers = [p.name for p in bag.iterdir() if p.name.startswith(".decompressed-")]
            check(not leftovers, f"bag play left {leftovers} in {bag}")
            played_bags.append(bag.name)
    print(f"bags compressed by rosbag2's file and message modes (sqlite3 and MCAP, zstd): "
          f"{len(played_bags)} played byte for byte ({len(sent)}/{len(sent)} each), no copy left behind")


def foxy_qos():
    """Offered QoS as rosbag2 on Foxy wrote it: rmw's numbers, 32-bit
    infinite durations, one YAML text."""
    import yaml

    def forever():
        return {"sec": 2147483647, "nsec": 4294967295}
    return yaml.safe_dump([{"history": 3, "depth": 0, "reliability": 1, "durability": 2, "deadline": forever(),
                            "lifespan": forever(), "liveliness": 1, "liveliness_lease_duration": forever(),
                            "avoid_ros_namespace_conventions": False}], sort_keys=False)


def older_metadata(version, meta):
    """`metadata.yaml` of format `version` (4: Foxy, 5: Galactic and Humble,
    6 and 7 before Iron's 8) for the bag `meta` describes, with only the
    fields that version has, and QoS as Foxy wrote it (rmw's numbers,
    32-bit infinite durations)."""
    import yaml
    qos = foxy_qos()
    topics = []
    for t in meta["topics_with_message_count"]:
        topic = {k: t["topic_metadata"][k] for k in ("name", "type", "serialization_format")}
        topic["offered_qos_profiles"] = qos
        if version >= 7:
            topic["type_description_hash"] = ""
        topics.append({"topic_metadata": topic, "message_count": t["message_count"]})
    info = {k: meta[k] for k in ("storage_identifier", "relative_file_paths", "duration", "starting_time",
                                 "message_count", "compression_format", "compression_mode")}
    info = {"version": version, **info, "topics_with_message_count": topics}
    if version >= 5:
        info["files"] = meta["files"]
    if version >= 6:
        info["custom_data"] = None
    return yaml.safe_dump({"rosbag2_bagfile_information": info}, sort_keys=False)


def check_older_metadata(endpoint, peer, work, bag, sent, got):
    """The same sqlite3 bag, its database as rosbag2 made it before Iron (no
    type hashes, no definitions), described by `metadata.yaml` of each older
    format version, is read by rosbags (the reference) and by this tool."""
    import sqlite3
    import yaml
    from rosbags.rosbag2 import Reader
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    for version in (4, 5, 6, 7):
        old = work / f"metadata_v{version}"
        shutil.copytree(bag, old)
        (old / "metadata.yaml").write_text(older_metadata(version, meta))
        for db in old.glob("*.db3"):
            with sqlite3.connect(db) as conn:
                conn.executescript("ALTER TABLE topics DROP COLUMN type_description_hash; "
                                   "DROP TABLE message_definitions; DROP TABLE schema; DROP TABLE metadata;")
                conn.execute("UPDATE topics SET offered_qos_profiles = ?", (foxy_qos(),))
        with Reader(old) as reader:
            by_rosbags = [data for _, _, data in reader.messages()]
        check(by_rosbags == sent, f"rosbags read {len(by_rosbags)} of a version-{version} bag")
        info = cli(endpoint, "bag", "info", str(old))
        check(info.returncode == 0 and f"Count: {len(sent)}" in info.stdout,
              f"bag info of a version-{version} bag: {info.returncode} {info.stdout[-300:]} {info.stderr[-300:]}")
        played_to_peer(endpoint, old, got, sent, f"a version-{version} bag", rate="20")
    print(f"metadata.yaml of format versions 4 to 7 (Foxy's QoS): read by rosbags and by bag info, "
          f"played byte for byte ({len(sent)}/{len(sent)} each)")


def check_out_of_order_mcap(endpoint, peer, work, store):
    """An MCAP file whose messages are not in time order in the file (written
    so by rosbags) plays in time order and over its recorded span, as
    `ros2 bag play` plays it."""
    import random
    from rosbags.rosbag2 import StoragePlugin, Writer
    from std_msgs.msg import String
    count, spacing = 100, 10_000_000  # 1 s
    sent = [serialize_message(String(data=f"shuffled {i}")) for i in range(count)]
    order = list(range(count))
    random.Random(7).shuffle(order)
    bag = work / "shuffled"
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection("/shuffled", "std_msgs/msg/String", typestore=store)
        for i in order:
            writer.write(connection, 1_700_000_000_000_000_000 + i * spacing, sent[i])
    got, arrivals = [], []

    def received(data):
        got.append(data)
        arrivals.append(time.monotonic())
    peer.subscriber("/shuffled", "std_msgs/msg/String", received)
    played = cli(endpoint, "bag", "play", str(bag), "-d", "1", timeout=120)
    deadline = time.time() + 5
    while len(got) < count and time.time() < deadline:
        time.sleep(0.05)
    span = arrivals[-1] - arrivals[0] if arrivals else 0
    check(played.returncode == 0 and got == sent,
          f"bag play of an out-of-order MCAP: exit {played.returncode} {played.stderr[-300:]!r}, "
          f"the peer read {len(got)} of {count}, in time order: {got == sent}")
    # Paced by the recorded times (a lower bound: load only lengthens it).
    check(span >= 0.9 * (count - 1) * spacing / 1e9, f"played over {span:.3f} s, recorded over 0.99 s")
    print(f"an MCAP written out of time order: {len(got)}/{count} played in time order over {span:.2f} s "
          f"(recorded over 0.99 s)")


def check_service_events(endpoint, peer, work):
    """Service events (introspection: `<service>/_service_event`, what rclpy
    and rclcpp publish for a service with introspection on) are recorded by
    --all-services and --services as rosbag2 records them, not by -a; bag
    info lists them as services with their event, request and response
    counts; rosbags reads them back."""
    from std_srvs.srv import SetBool
    from service_msgs.msg import ServiceEventInfo
    from std_msgs.msg import String
    event_type = "std_srvs/srv/SetBool_Event"
    publish = peer.publisher("/switch/_service_event", event_type)
    chatter = peer.publisher("/plain", "std_msgs/msg/String")
    sent = []
    for seq in range(1, 4):
        gid = [seq] * 16
        request = SetBool.Request(data=seq % 2 == 1)
        response = SetBool.Response(success=True, message=f"done {seq}")
        for kind in (ServiceEventInfo.REQUEST_SENT, ServiceEventInfo.REQUEST_RECEIVED,
                     ServiceEventInfo.RESPONSE_SENT, ServiceEventInfo.RESPONSE_RECEIVED):
            event = SetBool.Event()
            event.info.event_type = kind
            event.info.client_gid = gid
            event.info.sequence_number = seq
            if kind in (ServiceEventInfo.REQUEST_SENT, ServiceEventInfo.REQUEST_RECEIVED):
                event.request = [request]
            else:
                event.response = [response]
            sent.append(serialize_message(event))
    results = {}
    for flags in (["--all-services"], ["--services", "switch"], ["-a"]):
        bag = work / ("services" + "".join(f.strip("-") for f in flags))
        proc = subprocess.Popen([str(BIN), "--connect", endpoint, "--domain-id", "0", "--timeout", "10",
                                 "bag", "record", *flags, "-o", str(bag), "--no-progress",
                                 "--disable-keyboard-controls"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(4)
        for data in sent:
            publish(None, data)
            chatter(None, serialize_message(String(data="not a service")))
            time.sleep(0.02)
        time.sleep(1.5)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        check(proc.returncode == 0, f"bag record {flags}: exit {proc.returncode} {err[-400:]!r}")
        results[flags[0]] = bag
    import yaml
    for flags in ("--all-services", "--services"):
        bag = results[flags]
        meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
        topics = {t["topic_metadata"]["name"]: (t["topic_metadata"]["type"], t["message_count"])
                  for t in meta["topics_with_message_count"]}
        check(topics == {"/switch/_service_event": (event_type, len(sent))},
              f"bag record {flags} recorded {topics}")
        by_rosbags, by_mcap = read_back(bag)
        check(by_rosbags == sent and by_mcap == sent,
              f"{flags}: rosbags read {len(by_rosbags)}, mcap {len(by_mcap)} of {len(sent)} events")
    meta = yaml.safe_load((results["-a"] / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    names = [t["topic_metadata"]["name"] for t in meta["topics_with_message_count"]]
    check("/switch/_service_event" not in names and "/plain" in names, f"bag record -a recorded {names}")
    info = cli(endpoint, "bag", "info", str(results["--all-services"]))
    check(info.returncode == 0 and "Service:           1\n" in info.stdout
          and f"Service: /switch | Type: std_srvs/srv/SetBool | Event Count: {len(sent)} | Serialization Format: cdr"
          in info.stdout and "Topic: /switch" not in info.stdout,
          f"bag info of service events: {info.stdout[-600:]} {info.stderr[-300:]}")
    verbose = cli(endpoint, "bag", "info", "-v", str(results["--all-services"]))
    check(verbose.returncode == 0 and "Service: /switch | Type: std_srvs/srv/SetBool | Request Count: 3 | "
          "Response Count: 3 | Serialization Format: cdr" in verbose.stdout,
          f"bag info -v of service events: {verbose.stdout[-600:]} {verbose.stderr[-300:]}")
    print(f"service events: --all-services and --services recorded {len(sent)}/{len(sent)} events "
          f"(read back by rosbags and mcap), -a left them out; bag info: 1 service, -v: 3 requests, 3 responses")


def check_background_playback(endpoint, bag):
    """`bag play` started in the background of a terminal (`… &` in a shell)
    leaves the terminal alone and runs to its end: reading keys there would
    have the kernel stop it (SIGTTIN, SIGTTOU)."""
    import fcntl
    import pty
    import termios
    terminal, child = pty.openpty()
    pid = os.fork()
    if pid == 0:
        # A session with the pty as its controlling terminal, this process's
        # group in the foreground and the player in a group of its own.
        code = 2
        try:
            os.setsid()
            fcntl.ioctl(child, termios.TIOCSCTTY, 0)
            player = subprocess.Popen([str(BIN), "--connect", endpoint, "--domain-id", "0", "bag", "play", str(bag),
                                       "--topics", "/chatter", "-r", "20"],
                                      stdin=child, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                      process_group=0)
            try:
                code = player.wait(timeout=60)
            except subprocess.TimeoutExpired:
                player.kill()
                code = 3
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    os.close(child)
    os.close(terminal)
    code = os.waitstatus_to_exitcode(status)
    check(code == 0, f"bag play in the background: exit {code} (3: stopped by its terminal)")
    print(f"bag play in a terminal's background: exit {code} (0: it ran to its end, its terminal left alone)")


if __name__ == "__main__":
    try:
        main()
    except BaseException:
        import traceback
        traceback.print_exc()
        failures.append("exception")
    for f in failures:
        print("  FAIL", f)
    sys.stdout.flush()
    # Zenoh's threads would keep the interpreter from exiting.
    os._exit(1 if failures else 0)
