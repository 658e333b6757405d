#!/usr/bin/env python3
"""Shared memory across Zenoh lines. Our side (examples/examples/zenoh_lines.rs,
a RosNode) built on each line the runtime accepts:

- Zenoh 1.8.0, what every rmw_zenoh_cpp release ships (tests/zenoh-lines/1.8,
  an outside project adding shm-runtime by path, with its own lock file),
- the workspace's own line (1.9),
- Zenoh 1.10.2, whose shared-memory protocol differs (tests/zenoh-lines/1.10),

against a plain Zenoh peer (examples/examples/zenoh_peer.rs) built on the
same three lines, both ways, and ours against ours. Images are
sensor_msgs/Image on rmw_zenoh_cpp's keys, attachments and liveliness tokens:
1 KiB, 1 MiB and 8 MiB where ours is on the workspace's line, 1 MiB on the
others. Each image is checked byte for byte by the side that receives it,
and counted as shared memory on arrival (`ZBytes::as_shm` at the peer,
`RosSample::is_shm` at ours). For our publisher, what the runtime reported is
checked too: its Zenoh line and shared-memory protocol (`ZenohLine`), the
subscriber's `Reach` (SharedMemoryUnprobed for the peer, SharedMemory for ours,
Bytes for a link without shared memory) and `PublishOutcome::copied_to` /
`ShmStats::copied` (every image, or none). Two lines share memory exactly
when their shared-memory protocols match (1 for 1.8 and 1.9, 2 for 1.10).

    python3 tests/zenoh-lines/check.py <examples dir> <lines target dir> [profile]

Our programs on this workspace's line are taken from <examples dir> (built
with or without optimization), the outside projects' from
<lines target dir>/<line>/<profile> (profile: release, the default, or debug).

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
PROFILE = sys.argv[3] if len(sys.argv) > 3 else "release"
if PROFILE not in ("release", "debug"):
    raise SystemExit(f"profile {PROFILE!r}: use release or debug")

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


def line_of(version):
    return ".".join(version.split(".")[:2])


def shm_protocol(version):
    """zenoh-shm's SHM_VERSION of a line (tests/zenoh-lines' lines only)."""
    return {"1.8": 1, "1.9": 1, "1.10": 2}[line_of(version)]


LINES = [
    # (Zenoh version, who ships it, plain peer binary, our binary)
    (locked_zenoh(os.path.join(HERE, "1.8/Cargo.lock")), "rmw_zenoh_cpp, every distribution",
     os.path.join(PEERS, "1.8", PROFILE, "zenoh_peer"), os.path.join(PEERS, "1.8", PROFILE, "zenoh_lines")),
    (locked_zenoh(os.path.join(ROOT, "Cargo.lock")), "this workspace",
     os.path.join(EXAMPLES, "zenoh_peer"), os.path.join(EXAMPLES, "zenoh_lines")),
    (locked_zenoh(os.path.join(HERE, "1.10/Cargo.lock")), "newer Zenoh",
     os.path.join(PEERS, "1.10", PROFILE, "zenoh_peer"), os.path.join(PEERS, "1.10", PROFILE, "zenoh_lines")),
]
WORKSPACE = LINES[1][0]

next_port = [17650]


def endpoint():
    next_port[0] += 1
    return f"tcp/127.0.0.1:{next_port[0]}"


def start_ours(ours_bin, args):
    """Start our side; return it with the key and the peer's token it printed."""
    ours = subprocess.Popen([ours_bin, *args],
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


def ours_to_peer(ours_bin, peer, data, count):
    ep = endpoint()
    ours, key, token = start_ours(ours_bin, ["publish", ep, str(data), str(count)])
    sub = subprocess.Popen([peer, "sub", ep, key, token, str(count), str(data), str(TIMEOUT)],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    got, _ = report(sub, "peer subscriber")
    sent, log = report(ours, "our publisher")
    return sent, got, log


def peer_to_ours(ours_bin, peer, data, count):
    ep = endpoint()
    ours, key, token = start_ours(ours_bin, ["subscribe", ep, str(data), str(count), str(TIMEOUT)])
    pub = subprocess.Popen([peer, "pub", ep, key, token, str(count), str(data)],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    sent, _ = report(pub, "peer publisher")
    got, _ = report(ours, "our subscriber")
    return sent, got


def ours_to_ours(publisher_bin, subscriber_bin, data, count):
    ep = endpoint()
    pub, _, _ = start_ours(publisher_bin, ["publish", ep, str(data), str(count)])
    sub, _, _ = start_ours(subscriber_bin, ["subscribe", "connect:" + ep, str(data), str(count), str(TIMEOUT)])
    got, _ = report(sub, "our subscriber")
    sent, log = report(pub, "our publisher")
    return sent, got, log


def check_sent(failures, case, sent, log, count, ours_version, shares, want_shared_reach):
    want_reach = want_shared_reach if shares else "Bytes"
    want_copied = 0 if shares else count
    if sent["zenoh_line"] != line_of(ours_version) or sent["shm_protocol"] != shm_protocol(ours_version):
        failures.append(f"{case}: our publisher said Zenoh {sent['zenoh_line']} protocol {sent['shm_protocol']}, "
                        f"built on {ours_version}")
    if sent["kinds"] != {"Shm": count}:
        failures.append(f"{case}: our publisher wrote {sent['kinds']}, expected {count} into shared memory")
    if sent["reach"] != want_reach or sent["copied_to"] != want_copied or sent["stats_copied"] != want_copied:
        failures.append(f"{case}: our publisher reported {sent}, expected reach {want_reach} "
                        f"and {want_copied} copied")
    if not shares and "linked without shared memory" not in log:
        failures.append(f"{case}: our publisher did not warn of the copies")
    if not shares and f"Zenoh {line_of(ours_version)} (protocol" not in log:
        failures.append(f"{case}: our publisher's warning does not name its own line: {log}")


def check_got(failures, case, got, count, shares):
    want_shm = count if shares else 0
    if got["received"] != count or got["exact"] != count or got.get("attachments", count) != count:
        failures.append(f"{case}: {got}")
    if got["shm"] != want_shm:
        failures.append(f"{case}: {got['shm']} of {count} in shared memory, expected {want_shm}")


def main():
    failures = []
    checks = 0
    for _, _, peer, ours in LINES:
        for binary in (peer, ours):
            if not os.path.exists(binary):
                raise SystemExit(f"{binary} is missing: build it first (see .ci/run)")
    print("| our Zenoh | peer's Zenoh | shipped by | image | ours → peer: received / in shared memory | "
          "our publisher reported | peer → ours: received / in shared memory |")
    print("|---|---|---|---|---|---|---|")
    for ours_version, _, _, ours_bin in LINES:
        sizes = SIZES if ours_version == WORKSPACE else [size for size in SIZES if size[0] == "1 MiB"]
        for version, who, peer, _ in LINES:
            shares = shm_protocol(ours_version) == shm_protocol(version)
            for label, data, count in sizes:
                case = f"ours on {ours_version}, peer on {version}, {label}"
                sent, got, log = ours_to_peer(ours_bin, peer, data, count)
                check_got(failures, case + ", ours → peer", got, count, shares)
                check_sent(failures, case, sent, log, count, ours_version, shares, "SharedMemoryUnprobed")
                back_sent, back = peer_to_ours(ours_bin, peer, data, count)
                if back_sent["shm"] != count:
                    failures.append(f"{case}, peer → ours: the peer wrote {back_sent}")
                check_got(failures, case + ", peer → ours", back, count, shares)
                checks += 2
                copies = f"{sent['copied_to']} copied" if sent["copied_to"] else "0 copied"
                print(f"| {ours_version} | {version} | {who} | {label} | {got['received']}/{count} received, "
                      f"{got['shm']} in shared memory | {sent['reach']}, {copies} | {back['received']}/{count} "
                      f"received, {back['shm']} in shared memory |", flush=True)
    print()
    print("| our publisher's Zenoh | our subscriber's Zenoh | image | received / in shared memory | publisher reported |")
    print("|---|---|---|---|---|")
    label, data, count = next(size for size in SIZES if size[0] == "1 MiB")
    pairs = [(a, b) for a in LINES for b in LINES
             if a[0] == b[0] or {line_of(a[0]), line_of(b[0])} == {line_of(WORKSPACE), "1.10"}]
    for (pub_version, _, _, pub_bin), (sub_version, _, _, sub_bin) in pairs:
        shares = shm_protocol(pub_version) == shm_protocol(sub_version)
        case = f"ours on {pub_version} → ours on {sub_version}, {label}"
        sent, got, log = ours_to_ours(pub_bin, sub_bin, data, count)
        check_got(failures, case, got, count, shares)
        check_sent(failures, case, sent, log, count, pub_version, shares, "SharedMemory")
        checks += 1
        copies = f"{sent['copied_to']} copied" if sent["copied_to"] else "0 copied"
        print(f"| {pub_version} | {sub_version} | {label} | {got['received']}/{count} received, "
              f"{got['shm']} in shared memory | {sent['reach']}, {copies} |", flush=True)
    for failure in failures:
        print("FAIL:", failure)
    print(f"zenoh-lines: {checks} pairings, {len(failures)} failures" if failures
          else f"zenoh-lines: all {checks} pairings as expected")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
