#!/usr/bin/env python3
"""A peer that misbehaves on purpose, for harness/tests/harness/peers.rs (plain Python, no numpy).

Usage: fault_peer.py MODE TAG [STATE_DIR], or with FAULT_MODE, FAULT_TAG (and FAULT_STATE) in
the environment (as a stand-in for TETBENCH_VTK_PYTHON, whose arguments it then ignores). TAG
only marks the process (and its children) so that a test can look for survivors in /proc.

Modes: good; crash (exits during render); hang (sleeps in render); hang-hello; hang-prepare;
garbage (a line that is not JSON); endless (a reply line that never ends); wrong-size (an image
16 bytes short); nan (NaN pixels); die-mid-frame (SIGKILL on itself half-way through writing
the image); close-stdin (closes stdin, then answers hello: the next request cannot be written);
child (starts a grandchild, then hangs in render); flaky (crashes on its first render only,
remembered in STATE_DIR); v2 (speaks protocol 2.0); refuse-prepare (answers prepare with an
error reply on two lines, which must arrive as one).
"""

import json
import os
import signal
import struct
import subprocess
import sys
import time

args = sys.argv[1:]
if os.environ.get("FAULT_MODE"):
    mode, tag, state = os.environ["FAULT_MODE"], os.environ.get("FAULT_TAG", ""), os.environ.get("FAULT_STATE")
else:
    mode, tag = args[0], args[1]
    state = args[2] if len(args) > 2 else None

proto = os.fdopen(os.dup(1), "w")
os.dup2(2, 1)


def reply(**fields):
    proto.write(json.dumps(fields) + "\n")
    proto.flush()


def sleep_forever():
    while True:
        time.sleep(3600)


if mode == "child":
    subprocess.Popen([sys.executable, "-c", "import time; time.sleep(3600)", tag])

for line in sys.stdin:
    m = json.loads(line)
    kind = m["type"]
    if kind == "hello":
        if mode == "hang-hello":
            sleep_forever()
        if mode == "close-stdin":
            os.close(0)
        protocol = "2.0" if mode == "v2" else "1.0"
        reply(ok=True, protocol=protocol, name="fault-" + mode, version="1",
              integrators=["average", "partial", "preint"], projections=["ortho", "persp"])
        if mode == "close-stdin":
            sleep_forever()
    elif kind == "prepare":
        if mode == "hang-prepare":
            sleep_forever()
        if mode == "refuse-prepare":
            reply(ok=False, error="no mesh\nfor me")
            continue
        reply(ok=True)
    elif kind == "render":
        w, h = m["width"], m["height"]
        if mode == "crash":
            print("fault_peer: crashing as asked", file=sys.stderr, flush=True)
            os._exit(3)
        if mode in ("hang", "child"):
            sleep_forever()
        if mode == "garbage":
            proto.write("this is not a reply\n")
            proto.flush()
            continue
        if mode == "endless":
            chunk = "x" * 65536
            while True:
                proto.write(chunk)
        if mode == "flaky" and not os.path.exists(os.path.join(state, "crashed")):
            open(os.path.join(state, "crashed"), "w").close()
            os._exit(3)
        value = float("nan") if mode == "nan" else 0.25
        pixel = struct.pack("<4f", value, value, value, 0.5)
        data = pixel * (w * h)
        if mode == "wrong-size":
            data = data[:-16]
        with open(m["image"], "wb") as f:
            if mode == "die-mid-frame":
                f.write(data[: len(data) // 2])
                f.flush()
                os.kill(os.getpid(), signal.SIGKILL)
            f.write(data)
        reply(ok=True, draw_ms=1.0, counters={"fault_frames": 1})
    elif kind == "bye":
        reply(ok=True)
        break
    else:
        reply(ok=False, error="unknown request type " + kind)
