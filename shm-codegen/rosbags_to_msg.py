#!/usr/bin/env python3
"""Write .msg files for packages that have no ROS 2 wheel on PyPI, from the
message definitions in rosbags' ros2_jazzy type store.

usage: rosbags_to_msg.py OUT_DIR PKG...

rosbags keeps fields and constants, not comments or default values; the
packages exported this way (tf2_msgs) have no default values.
"""
import sys
from pathlib import Path

from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.base import Nodetype


def type_text(node, own_pkg):
    kind, detail = node
    if kind == Nodetype.BASE:
        name, bound = detail
        return f"{name}<={bound}" if bound else name
    if kind == Nodetype.NAME:
        pkg, _, name = detail.split("/")
        return name if pkg == own_pkg else f"{pkg}/{name}"
    inner, size = detail
    inner = type_text(inner, own_pkg)
    if kind == Nodetype.ARRAY:
        return f"{inner}[{size}]"
    return f"{inner}[<={size}]" if size else f"{inner}[]"


def main():
    out, packages = Path(sys.argv[1]), sys.argv[2:]
    store = get_typestore(Stores.ROS2_JAZZY)
    for full, (consts, fields) in sorted(store.fielddefs.items()):
        pkg, ns, name = full.split("/")
        if pkg not in packages or ns != "msg":
            continue
        lines = [f"# {full}, exported from rosbags' ros2_jazzy type store."]
        lines += [f"{ctype} {cname}={value}" for cname, ctype, value in consts]
        lines += [f"{type_text(node, pkg)} {fname}" for fname, node in fields]
        path = out / pkg / "msg" / f"{name}.msg"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
