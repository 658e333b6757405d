#!/usr/bin/env python3
"""Cross-host check: two network namespaces joined by a veth pair.

Host A runs the publisher (shared-memory pool, 256 KiB point clouds) and a
local subscriber; host B runs a remote subscriber that cannot see A's
/dev/shm (its own mount namespace with a private tmpfs there), as on a second
machine. Expected: B receives every message as plain network bytes, A's local
subscriber as shared memory, and all bytes are identical to what was sent.

Usage: check.py <dir with netns_node>. Needs root and iproute2 (`ip`) and
util-linux (`unshare`); where the machine does not permit namespaces it prints
why and exits 0 (skipped), so CI elsewhere is not blocked.
"""
import os
import shutil
import subprocess
import sys
import uuid

COUNT = 20
SUFFIX = uuid.uuid4().hex[:6]
NS_A, NS_B = f"shmcdr-a-{SUFFIX}", f"shmcdr-b-{SUFFIX}"
VETH_A, VETH_B = f"sca{SUFFIX}", f"scb{SUFFIX}"
ADDR_A, ADDR_B = "10.211.0.1", "10.211.0.2"
ENDPOINT = f"tcp/{ADDR_A}:7447"


def run(*cmd):
    subprocess.run(cmd, check=True, capture_output=True, text=True)


def skip(why):
    print(f"netns: SKIPPED ({why})")
    sys.exit(0)


def setup():
    if os.geteuid() != 0:
        skip("needs root to create network namespaces")
    for tool in ("ip", "unshare"):
        if shutil.which(tool) is None:
            skip(f"`{tool}` not installed (iproute2 / util-linux)")
    try:
        run("ip", "netns", "add", NS_A)
    except subprocess.CalledProcessError as e:
        skip(f"`ip netns add` not permitted here: {e.stderr.strip()}")
    run("ip", "netns", "add", NS_B)
    run("ip", "link", "add", VETH_A, "type", "veth", "peer", "name", VETH_B)
    run("ip", "link", "set", VETH_A, "netns", NS_A)
    run("ip", "link", "set", VETH_B, "netns", NS_B)
    for ns, dev, addr in ((NS_A, VETH_A, ADDR_A), (NS_B, VETH_B, ADDR_B)):
        run("ip", "-n", ns, "addr", "add", f"{addr}/24", "dev", dev)
        run("ip", "-n", ns, "link", "set", dev, "up")
        run("ip", "-n", ns, "link", "set", "lo", "up")


def teardown():
    for ns in (NS_A, NS_B):
        subprocess.run(["ip", "netns", "delete", ns], capture_output=True)


def parse(lines, tag):
    out = {}
    for line in lines:
        parts = line.split()
        if parts and parts[0] == tag:
            out[int(parts[1])] = parts[2:]
    return out


def main():
    node = os.path.join(sys.argv[1], "netns_node")
    setup()
    try:
        local = subprocess.Popen(
            ["ip", "netns", "exec", NS_A, node, "sub", ENDPOINT, str(COUNT), "local"],
            stdout=subprocess.PIPE, text=True)
        # Host B: its own /dev/shm, as a second machine would have.
        remote = subprocess.Popen(
            ["ip", "netns", "exec", NS_B, "unshare", "--mount", "--propagation", "private",
             "sh", "-c", f"mount -t tmpfs tmpfs /dev/shm && exec {node} sub {ENDPOINT} {COUNT} remote"],
            stdout=subprocess.PIPE, text=True)
        publisher = subprocess.run(
            ["ip", "netns", "exec", NS_A, node, "pub", ENDPOINT, str(COUNT), "2"],
            capture_output=True, text=True, timeout=120)
        local_out, _ = local.communicate(timeout=60)
        remote_out, _ = remote.communicate(timeout=60)
    finally:
        teardown()

    if publisher.returncode != 0:
        print(publisher.stderr)
        print("netns: FAILED (publisher)")
        return 1
    sent = parse(publisher.stdout.splitlines(), "sent")
    results = {}
    for name, text in (("local", local_out), ("remote", remote_out)):
        got = parse(text.splitlines(), "got")
        identical = sum(1 for i, (length, _, digest) in got.items()
                        if i in sent and sent[i][0] == length and sent[i][2] == digest)
        shm = sum(1 for _, flag, _ in got.values() if flag == "shm=1")
        results[name] = (len(got), identical, shm)
    sent_shm = sum(1 for v in sent.values() if v[1] == "Shm")
    print(f"netns: published {len(sent)} clouds of {sent[0][0] if sent else 0} bytes "
          f"from host A, {sent_shm} encoded into shared memory")
    for name, host in (("local", "A"), ("remote", "B")):
        received, identical, shm = results[name]
        print(f"netns: {name} subscriber (host {host}): {received}/{COUNT} received, "
              f"{identical} byte-identical, {shm} as shared memory, {COUNT - received} lost")
    ok = (len(sent) == COUNT and sent_shm == COUNT
          and results["local"] == (COUNT, COUNT, COUNT)
          and results["remote"] == (COUNT, COUNT, 0))
    print("netns: OK" if ok else "netns: FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
