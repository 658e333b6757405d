#!/usr/bin/env python3
"""Print the README table from criterion's results (run `cargo bench -p
shm-cdr-tests --bench cdr` first): the median of every benchmark, and for the
byte-moving operations the throughput and the ratio to a memcpy of the same
number of bytes measured in the same run. With `--bench dynamic` run too, a
second table: run-time typed messages against the generated code."""
import json
import pathlib
import sys

root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "target/criterion")
groups = ["PointCloud2 1MiB", "PointCloud2 8MiB", "JointState 40", "PoseArray 10k"]
moving = ["encode_into", "to_vec", "decode_owned"]
fixed = ["encoded_size", "decode_borrowed"]


def median(group, op):
    for name in (group, group.replace(" ", "_")):
        hits = list((root / name / op).glob("*/new/estimates.json"))
        if hits:
            size = int(hits[0].parent.parent.name)
            return json.loads(hits[0].read_text())["median"]["point_estimate"], size
    return None, None


def fmt_time(ns):
    return f"{ns / 1000:.1f} µs" if ns >= 1000 else f"{ns:.0f} ns"


print("| message | bytes | memcpy | " + " | ".join(moving + fixed) + " |")
print("|---|---:|---:|" + "---:|" * (len(moving) + len(fixed)))
for group in groups:
    copy_ns, size = median(group, "memcpy")
    if copy_ns is None:
        continue
    cells = [f"{fmt_time(copy_ns)} ({size / copy_ns:.1f} GB/s)"]
    for op in moving:
        ns, _ = median(group, op)
        cells.append(f"{fmt_time(ns)} ({size / ns:.1f} GB/s, **{ns / copy_ns:.2f}×**)")
    for op in fixed:
        ns, _ = median(group, op)
        cells.append(fmt_time(ns))
    print(f"| {group} | {size:,} | " + " | ".join(cells) + " |")


dynamic_groups = ["dynamic PointCloud2 1MiB", "dynamic Imu", "dynamic JointState 40", "dynamic StringList 1000"]
if any(median(g, "dynamic_decode")[0] for g in dynamic_groups):
    print()
    print("| message | generated decode (borrowed) | dynamic view | dynamic view, every field read | dynamic decode | generated encode_into | dynamic encode_into |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for group in dynamic_groups:
        cells = []
        for generated, dynamics in (("generated_decode_borrowed", ("dynamic_view", "dynamic_view_read_all", "dynamic_decode")),
                                    ("generated_encode_into", ("dynamic_encode_into",))):
            g, _ = median(group, generated)
            cells.append(fmt_time(g) if g is not None else "—")
            for dynamic in dynamics:
                d, _ = median(group, dynamic)
                cells.append("—" if g is None or d is None else f"{fmt_time(d)} (**{d / g:.2f}×**)")
        print(f"| {group.removeprefix('dynamic ')} | " + " | ".join(cells) + " |")
