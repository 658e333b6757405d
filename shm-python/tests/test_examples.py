"""The quick start (examples/talker.py and listener.py, two processes) runs as
the guide shows it, and every Python snippet of the guide and READMEs is
either run here or taken word for word from a file that is."""

import os
import re
import subprocess
import sys
import textwrap

from conftest import free_port, session_env, shm_ros2

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
EXAMPLES = os.path.join(HERE, "..", "examples")


def quick_start(listener_env, talker_env):
    listener = subprocess.Popen(
        [sys.executable, os.path.join(EXAMPLES, "listener.py"), "5"],
        env=listener_env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    talker = subprocess.Popen(
        [sys.executable, os.path.join(EXAMPLES, "talker.py")],
        env=talker_env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        out, err = listener.communicate(timeout=60)
    finally:
        talker.kill()
    assert listener.returncode == 0, err
    lines = out.splitlines()
    assert len(lines) == 5, out
    frames = [re.match(r"frame (\d+): 640x480, mean (\d+), in shared memory: (\w+)", l) for l in lines]
    assert all(frames), out
    for f in frames:
        assert int(f.group(2)) == int(f.group(1)) % 256
    # The first may go by the network while the talker learns that the
    # listener maps its pool; the rest are in place.
    assert [f.group(3) for f in frames[1:]] == ["True"] * 4, out


def test_the_quick_start_through_a_router_as_the_guide_runs_it():
    port = free_port()
    router = subprocess.Popen([shm_ros2(), "router", "--listen", f"tcp/127.0.0.1:{port}"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        # rmw_zenoh_cpp's session configuration, its router on this port.
        env = dict(os.environ)
        env.pop("ZENOH_ROUTER_CHECK_ATTEMPTS", None)
        env["ZENOH_CONFIG_OVERRIDE"] = f'connect/endpoints=["tcp/127.0.0.1:{port}"]'
        quick_start(env, env)
    finally:
        router.kill()


def test_the_quick_start_between_two_peers():
    port = free_port()
    quick_start(session_env(listen=port), session_env(connect=port))


def python_blocks(path):
    text = open(path, encoding="utf-8").read()
    lines = text.splitlines()
    # Fences may be indented (a snippet inside a list item).
    for m in re.finditer(r"^( *)```python\n(.*?)^\1```$", text, re.S | re.M):
        line = text[: m.start()].count("\n")
        note = lines[line - 1].strip() if line > 0 else ""
        yield path, line + 1, note, textwrap.dedent(m.group(2))


def test_every_python_snippet_runs_or_is_from_a_file_that_does():
    documents = [
        os.path.join(ROOT, "docs", "src", "python.md"),
        os.path.join(ROOT, "shm-python", "README.md"),
        os.path.join(ROOT, "README.md"),
        os.path.join(ROOT, "docs", "src", "coming-from.md"),
    ]
    seen = 0
    for path, line, note, body in (b for d in documents for b in python_blocks(d)):
        seen += 1
        at = f"{path}:{line}"
        if "shm_cdr" not in body:
            continue  # another library's code, shown for comparison (rclpy's)
        if note.startswith("<!-- from ") and note.endswith(" -->"):
            source = open(os.path.join(ROOT, note[len("<!-- from "):-len(" -->")])).read()
            assert body.strip() in source, f"{at}: not word for word in its file"
        else:
            # A snippet that stands alone runs, in a process of its own.
            run = subprocess.run([sys.executable, "-c", body], env=session_env(listen=free_port()),
                                 capture_output=True, text=True, timeout=60)
            assert run.returncode == 0, f"{at}: {run.stderr}"
    assert seen >= 8, seen
