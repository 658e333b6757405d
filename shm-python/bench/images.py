"""How long a big message takes from a frame in a numpy array in one Python
process to a numpy array of its data in another: shm_cdr (the frame set on a
message, or copied into a loan), rclpy (rmw_fastrtps_cpp), eclipse-zenoh's
Python put of bytes, iceoryx2's Python publish of a loaned slice of bytes
(shared memory, no ROS message), and the same between two Rust nodes
(`examples/examples/image_latency.rs`, a loan), one path after the other in
one run, medians.

    python shm-python/bench/images.py [--rounds 40] [--paths shm_cdr,shm_cdr_loan,rust,rclpy,zenoh,iceoryx2]

Each path sends the same frame at 20 Hz (so nothing queues), as a program
with a new frame each time would: taken into the message (`msg.data = frame`;
`numpy.copyto(loan.data, frame)` for a loan and for iceoryx2's slice;
`bytes` for rclpy and Zenoh),
then published. The subscriber stamps each message's arrival once it holds
the numpy array; the latency is that stamp minus the time taken before the
frame went into the message (both CLOCK_REALTIME, one machine). A path whose
package is missing is reported as such and the run goes on.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
# The Rust path: `cargo build --release -p shm-cdr-examples --example image_latency`.
RUST = os.environ.get("SHM_CDR_IMAGE_LATENCY") or os.path.join(
    ROOT, "target", "release", "examples", "image_latency")

PAYLOADS = {
    # name: (message type, bytes of data)
    "Image 8 MiB": ("sensor_msgs/msg/Image", 8 * 1024 * 1024),
    "PointCloud2 1 MiB": ("sensor_msgs/msg/PointCloud2", 1024 * 1024),
}

# Run as a child: `images.py <role> <path> <payload> <rounds> <port>`.
def child(role, path, payload, rounds, port):
    import numpy as np

    ty, size = PAYLOADS[payload]
    data = np.arange(size, dtype=np.uint64).astype(np.uint8)
    period = 0.05
    out = []
    if path in ("shm_cdr", "shm_cdr_loan"):
        import shm_cdr

        node = shm_cdr.Node(role)
        if role == "pub":
            pub = node.create_publisher(ty, "/bench")
            pub.wait_for_subscribers(30.0)
            msg = shm_cdr.message_type(ty)()
            for _ in range(rounds + 1):  # the first may go while the pool is probed
                t = time.time_ns()
                if path == "shm_cdr_loan":
                    msg = pub.loan(zeroed=False, data=size)
                    np.copyto(msg.data, data)
                else:
                    msg.data = data
                msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t, 10**9)
                pub.publish(msg)
                if path == "shm_cdr_loan":
                    msg = None  # its buffer goes back to the pool once the subscriber lets go
                time.sleep(period)
        else:
            sub = node.create_subscription(ty, "/bench")
            print("ready", flush=True)
            for _ in range(rounds + 1):
                msg = array = None  # let the previous sample go back to the pool
                msg = sub.recv(timeout=60.0)
                array = msg.data
                now = time.time_ns()
                stamp = msg.header.stamp
                assert array.size == size and int(array[-1]) == (size - 1) % 256
                out.append((now - (stamp.sec * 10**9 + stamp.nanosec), msg.memory.is_shm))
            out = out[1:]
    elif path == "rclpy":
        import rclpy
        from rclpy.node import Node
        from rclpy.qos import QoSProfile

        import importlib
        pkg, _, name = ty.split("/")
        Msg = getattr(importlib.import_module(f"{pkg}.msg"), name)
        rclpy.init()
        node = Node(role)
        qos = QoSProfile(depth=5)
        if role == "pub":
            pub = node.create_publisher(Msg, "/bench", qos)
            while pub.get_subscription_count() == 0:
                time.sleep(0.05)
            time.sleep(1.0)
            msg = Msg()
            for _ in range(rounds):
                t = time.time_ns()
                msg.data = data.tobytes()
                msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t, 10**9)
                pub.publish(msg)
                time.sleep(period)
        else:
            def on_msg(msg):
                array = np.frombuffer(msg.data, dtype=np.uint8)
                now = time.time_ns()
                assert array.size == size
                out.append((now - (msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec), False))

            node.create_subscription(Msg, "/bench", on_msg, qos)
            print("ready", flush=True)
            deadline = time.monotonic() + 120
            while len(out) < rounds and time.monotonic() < deadline:
                rclpy.spin_once(node, timeout_sec=0.5)
        rclpy.shutdown()
    elif path == "zenoh":
        import zenoh

        conf = zenoh.Config()
        conf.insert_json5("scouting/multicast/enabled", "false")
        if role == "pub":
            conf.insert_json5("connect/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
            session = zenoh.open(conf)
            pub = session.declare_publisher("bench")
            time.sleep(1.0)
            for _ in range(rounds):
                payload = time.time_ns().to_bytes(8, "little") + data.tobytes()
                pub.put(payload)
                time.sleep(period)
            time.sleep(0.5)
        else:
            conf.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
            session = zenoh.open(conf)
            received = []
            sub = session.declare_subscriber("bench", lambda s: received.append(s))
            print("ready", flush=True)
            deadline = time.monotonic() + 120
            while len(out) < rounds and time.monotonic() < deadline:
                if received:
                    sample = received.pop(0)
                    raw = sample.payload.to_bytes()
                    array = np.frombuffer(raw, dtype=np.uint8, offset=8)
                    now = time.time_ns()
                    assert array.size == size
                    out.append((now - int.from_bytes(raw[:8], "little"), False))
                else:
                    time.sleep(0.0005)
    elif path == "iceoryx2":
        import ctypes

        import iceoryx2 as iox2

        iox2.set_log_level_from_env_or(iox2.LogLevel.Warn)
        node = iox2.NodeBuilder.new().create(iox2.ServiceType.Ipc)
        service = (
            node.service_builder(iox2.ServiceName.new(f"shm_cdr_bench_{port}"))
            .publish_subscribe(iox2.Slice[ctypes.c_uint8])
            .open_or_create()
        )
        if role == "pub":
            pub = service.publisher_builder().initial_max_slice_len(8 + size).create()
            time.sleep(1.0)
            for _ in range(rounds):
                t = time.time_ns()
                sample = pub.loan_slice_uninit(8 + size)
                view = np.frombuffer(sample.payload().as_memory_view(), dtype=np.uint8)
                view[:8] = np.frombuffer(t.to_bytes(8, "little"), dtype=np.uint8)
                np.copyto(view[8:], data)
                sample.assume_init().send()
                time.sleep(period)
            time.sleep(0.5)
        else:
            sub = service.subscriber_builder().create()
            print("ready", flush=True)
            deadline = time.monotonic() + 120
            while len(out) < rounds and time.monotonic() < deadline:
                sample = sub.receive()
                if sample is None:
                    time.sleep(0.0005)
                    continue
                raw = np.frombuffer(sample.payload().as_memory_view(), dtype=np.uint8)
                array = raw[8:]
                now = time.time_ns()
                assert array.size == size
                out.append((now - int.from_bytes(raw[:8].tobytes(), "little"), True))
                del raw, array, sample
    if role == "sub":
        print(json.dumps(out), flush=True)


def run(path, payload, rounds):
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = dict(os.environ)
    if path in ("shm_cdr", "shm_cdr_loan", "rust"):
        # Room for several 8 MiB images in flight (the default pool holds one).
        env["ZENOH_SHM_ALLOC_SIZE"] = str(64 * 1024 * 1024)
        env["ZENOH_ROUTER_CHECK_ATTEMPTS"] = "-1"
        env["ZENOH_CONFIG_OVERRIDE"] = f'listen/endpoints=["tcp/127.0.0.1:{port}"]'
    me = [sys.executable, __file__]
    args = lambda role: me + [role, path, payload, str(rounds), str(port)]
    if path == "rust":
        if not os.path.exists(RUST):
            return None, (f"no {RUST}: cargo build --release -p shm-cdr-examples "
                          "--example image_latency (or set SHM_CDR_IMAGE_LATENCY)")
        ty, size = PAYLOADS[payload]
        args = lambda role: [RUST, role, ty.rsplit("/", 1)[-1], str(size), str(rounds)]
    sub = subprocess.Popen(args("sub"), env=env,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if sub.stdout.readline().strip() != "ready":
        sub.kill()
        return None, sub.stderr.read()[-400:]
    if path in ("shm_cdr", "shm_cdr_loan", "rust"):
        env["ZENOH_CONFIG_OVERRIDE"] = f'connect/endpoints=["tcp/127.0.0.1:{port}"]'
    pub = subprocess.Popen(args("pub"), env=env,
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        out, err = sub.communicate(timeout=180)
    except subprocess.TimeoutExpired:
        sub.kill()
        return None, "timed out"
    finally:
        pub.kill()
    if sub.returncode != 0:
        return None, err[-400:]
    return json.loads(out.strip().splitlines()[-1]), ""


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=40)
    parser.add_argument("--paths", default="shm_cdr,shm_cdr_loan,rust,rclpy,zenoh,iceoryx2")
    args = parser.parse_args()
    paths = args.paths.split(",")
    print(f"{args.rounds} messages per path and payload, 20 Hz; latency frame -> numpy array, medians")
    for payload in PAYLOADS:
        results = {}
        for path in paths:
            got, why = run(path, payload, args.rounds)
            if got is None:
                print(f"  {payload:18} {path:12} failed: {why.strip().splitlines()[-1] if why.strip() else '?'}")
                continue
            latencies = [ns for ns, _ in got]
            results[path] = statistics.median(latencies) / 1e6
            shm = sum(1 for _, s in got if s)
            print(f"  {payload:18} {path:12} median {results[path]:8.3f} ms  "
                  f"(p10 {sorted(latencies)[len(latencies) // 10] / 1e6:.3f}, "
                  f"p90 {sorted(latencies)[len(latencies) * 9 // 10] / 1e6:.3f}; "
                  f"{len(got)} received, {shm} in shared memory)")
        for base in ("shm_cdr", "shm_cdr_loan"):
            if base not in results:
                continue
            for other, ms in results.items():
                if other != base and not (base == "shm_cdr_loan" and other == "shm_cdr"):
                    print(f"  {payload:18} {other} / {base}: {ms / results[base]:.2f}x")

if __name__ == "__main__":
    if len(sys.argv) == 6 and sys.argv[1] in ("pub", "sub"):
        child(sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5]))
    else:
        main()
