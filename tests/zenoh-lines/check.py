#!/usr/bin/env python3
"""Shared memory across Zenoh lines: our RosNode (the workspace's Zenoh)
against a plain Zenoh peer (examples/examples/zenoh_peer.rs) built on

- Zenoh 1.8.0, what every rmw_zenoh_cpp release ships (tests/zenoh-lines/1.8),
- the workspace's own line (the zenoh_peer example),
- Zenoh 1.10.2, whose shared-memory protocol differs (tests/zenoh-lines/1.10),

both ways, with sensor_msgs/Image of 1 KiB, 1 MiB and 8 MiB on rmw_zenoh_cpp's
keys, attachments and liveliness tokens. Each image is checked byte for byte by
the side that receives it, and counted as shared memory on arrival
(`ZBytes::as_shm` at the peer, `RosSample::is_shm` at ours). For our
publisher, what the runtime reported is checked too: the peer's `Reach`
(SharedMemoryUnprobed, or Bytes for a link without shared memory) and
`PublishOutcome::copied_to` / `ShmStats::copied` (every image, or none).

    python3 tests/zenoh-lines/check.py <release examples dir> <peers target dir>

Exit status 1 if any pairing does not do what the table says it should.
"""
import json
import os
import re
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
EXAMPLES = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "target/release/examples")
PEERS = sys.argv[2] if len(sys.argv) > 2 else os.path.join(ROOT, "target/zenoh-lines")

SIZES = [("1 KiB", 1 << 10, 20), ("1 MiB", 1 << 20, 20), ("8 MiB", 8 << 20, 10)]
TIMEOUT = 60


def locked_zenoh(lock_file):
    """The zenoh version a Cargo.lock pins."""
    with open(lock_file) as f:
        text = f.read()
    found = re.search(r'name = "zenoh"\nversion = "([^"]+)"', text)
    if not found:
        raise SystemExit(f"{lock_file}: no zenoh package")
    return found.group(1)


LINES = [
    # (Zenoh version, who ships it, peer binary, shares memory with ours)
    (locked_zenoh(os.path.join(HERE, "1.8/Cargo.lock")), "rmw_zenoh_cpp, every distribution",
     os.path.join(PEERS, "1.8/release/zenoh_peer"), True),
    (locked_zenoh(os.path.join(ROOT, "Cargo.lock")), "this workspace",
     os.path.join(EXAMPLES, "zenoh_peer"), True),
    (locked_zenoh(os.path.join(HERE, "1.10/Cargo.lock")), "newer Zenoh",
     os.path.join(PEERS, "1.10/release/zenoh_peer"), False),
]

next_port = [17650]


def endpoint():
    next_port[0] += 1
    return f"tcp/127.0.0.1:{next_port[0]}"


def start_ours(args):
    """Start our side; return it with the key and the peer's token it printed."""
    ours = subprocess.Popen([os.path.join(EXAMPLES, "zenoh_lines"), *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    key = ours.stdout.readline().split()
    token = ours.stdout.readline().split()
    if key[:1] != ["KEY"] or token[:1] != ["PEER_TOKEN"]:
        ours.kill()
        raise RuntimeError(f"zenoh_lines {args[0]}: {key} {token} {ours.stderr.read()}")
    return ours, key[1], token[1]


def report(process, what):
    try:
        out, err = process.communicate(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        process.kill()
        out, err = process.communicate()
    lines = [line for line in out.splitlines() if line.startswith("{")]
    if process.returncode != 0 or not lines:
        raise RuntimeError(f"{what} failed ({process.returncode}): {out} {err}")
    return json.loads(lines[-1]), err


def ours_to_peer(peer, data, count):
    ep = endpoint()
    ours, key, token = start_ours(["publish", ep, str(data), str(count)])
    sub = subprocess.Popen([peer, "sub", ep, key, token, str(count), str(data), str(TIMEOUT)],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    got, _ = report(sub, "peer subscriber")
    sent, log = report(ours, "our publisher")
    return sent, got, log


def peer_to_ours(peer, data, count):
    ep = endpoint()
    ours, key, token = start_ours(["subscribe", ep, str(data), str(count), str(TIMEOUT)])
    pub = subprocess.Popen([peer, "pub", ep, key, token, str(count), str(data)],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    sent, _ = report(pub, "peer publisher")
    got, _ = report(ours, "our subscriber")
    return sent, got


def main():
    failures = []
    print("| peer's Zenoh | shipped by | image | ours → peer: received / in shared memory | "
          "our publisher reported | peer → ours: received / in shared memory |")
    print("|---|---|---|---|---|---|")
    for version, who, peer, shares in LINES:
        if not os.path.exists(peer):
            raise SystemExit(f"{peer} is missing: build it first (see .ci/run)")
        for label, data, count in SIZES:
            case = f"Zenoh {version}, {label}"
            sent, got, log = ours_to_peer(peer, data, count)
            want_shm = count if shares else 0
            want_reach = "SharedMemoryUnprobed" if shares else "Bytes"
            want_copied = 0 if shares else count
            if got["received"] != count or got["exact"] != count or got["attachments"] != count:
                failures.append(f"{case}, ours → peer: {got}")
            if got["shm"] != want_shm:
                failures.append(f"{case}, ours → peer: {got['shm']} of {count} in shared memory, expected {want_shm}")
            if sent["kinds"] != {"Shm": count}:
                failures.append(f"{case}: our publisher wrote {sent['kinds']}, expected {count} into shared memory")
            if sent["reach"] != want_reach or sent["copied_to"] != want_copied \
                    or sent["stats_copied"] != want_copied:
                failures.append(f"{case}: our publisher reported {sent}, expected reach {want_reach} "
                                f"and {want_copied} copied")
            if not shares and "linked without shared memory" not in log:
                failures.append(f"{case}: our publisher did not warn of the copies")
            back_sent, back = peer_to_ours(peer, data, count)
            if back["received"] != count or back["exact"] != count or back_sent["shm"] != count:
                failures.append(f"{case}, peer → ours: sent {back_sent}, received {back}")
            if back["shm"] != want_shm:
                failures.append(f"{case}, peer → ours: {back['shm']} of {count} in shared memory, expected {want_shm}")
            copies = f"{sent['copied_to']} copied" if sent["copied_to"] else "0 copied"
            print(f"| {version} | {who} | {label} | {got['received']}/{count} received, {got['shm']} in shared memory "
                  f"| {sent['reach']}, {copies} | {back['received']}/{count} received, {back['shm']} in shared memory |",
                  flush=True)
    for failure in failures:
        print("FAIL:", failure)
    print(f"zenoh-lines: {len(LINES) * len(SIZES) * 2 - len(failures)} checks passed, {len(failures)} failed"
          if failures else f"zenoh-lines: all {len(LINES) * len(SIZES) * 2} pairings as expected")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
