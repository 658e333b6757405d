#!/usr/bin/env python3
"""examples/zenoh-app as a user runs it: the camera, then the viewer, two
processes of one Zenoh application (its own lock file) that added ROS 2
through shm-runtime. Every image must arrive exact and in shared memory, the
application's own queryable must answer, and both must name the application's
Zenoh line.

    python3 tests/zenoh-lines/app.py <zenoh-app binary>
"""
import os
import re
import subprocess
import sys

APP = sys.argv[1]
COUNT = 40
HERE = os.path.dirname(os.path.abspath(__file__))


def locked_line():
    with open(os.path.join(HERE, "..", "..", "examples", "zenoh-app", "Cargo.lock")) as f:
        version = re.search(r'name = "zenoh"\nversion = "([^"]+)"', f.read()).group(1)
    return ".".join(version.split(".")[:2])


def main():
    env = dict(os.environ, ZENOH_APP_ENDPOINT="tcp/127.0.0.1:17641")
    camera = subprocess.Popen([APP, "camera", str(COUNT)], env=env, text=True,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    viewer = subprocess.run([APP, "viewer", str(COUNT)], env=env, text=True,
                            capture_output=True, timeout=120)
    camera_out, camera_err = camera.communicate(timeout=120)
    print(camera_out.strip())
    print(viewer.stdout.strip())
    line = locked_line()
    failures = []
    if camera.returncode != 0 or viewer.returncode != 0:
        failures.append(f"exit codes {camera.returncode}, {viewer.returncode}: {camera_err} {viewer.stderr}")
    want_viewer = f"viewer: Zenoh {line}, {COUNT}/{COUNT} images, {COUNT} in shared memory, {COUNT} exact; " \
                  "status: camera: running"
    if viewer.stdout.strip() != want_viewer:
        failures.append(f"viewer printed {viewer.stdout.strip()!r}, expected {want_viewer!r}")
    want_camera = f"camera: Zenoh {line} "
    if not camera_out.startswith(want_camera) or f"{COUNT} in shared memory, 0 copies" not in camera_out \
            or "subscribers: SharedMemory" not in camera_out:
        failures.append(f"camera printed {camera_out!r}")
    for failure in failures:
        print("FAIL:", failure)
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
