#!/usr/bin/env python3
"""Print the README table from criterion's results: the median of each benchmark,
its throughput, and its ratio to the memcpy of the same bytes in the same run."""
import json
import pathlib
import sys

root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "target/criterion")
ops = ["memcpy", "encode_into", "to_vec", "encoded_size", "decode_owned", "decode_borrowed"]
groups = ["PointCloud2 1MiB", "PointCloud2 8MiB", "JointState 40", "PoseArray 10k"]


def median_ns(group, op):
    hits = list((root / group / op).glob("*/new/estimates.json"))
    if not hits:
        return None, None
    size = int(hits[0].parent.parent.name)
    return json.loads(hits[0].read_text())["median"]["point_estimate"], size


print("| message | bytes | " + " | ".join(ops) + " |")
print("|---|---:|" + "---:|" * len(ops))
for group in groups:
    copy_ns, size = median_ns(group.replace(" ", "_"), "memcpy")
    if copy_ns is None:
        copy_ns, size = median_ns(group, "memcpy")
    if copy_ns is None:
        continue
    cells = []
    for op in ops:
        ns, _ = median_ns(group.replace(" ", "_"), op)
        if ns is None:
            ns, _ = median_ns(group, op)
        gbps = size / ns
        ratio = "" if op == "memcpy" else f", {ns / copy_ns:.2f}×"
        time = f"{ns / 1000:.1f} µs" if ns >= 1000 else f"{ns:.0f} ns"
        cells.append(f"{time} ({gbps:.2f} GB/s{ratio})")
    print(f"| {group} | {size} | " + " | ".join(cells) + " |")
