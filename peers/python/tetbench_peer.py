"""tetbench_peer: write a tetbench peer in Python (protocol 1.0, docs/peers.md). numpy only.

A peer subclasses `Peer`, fills in `prepare` and `render`, and calls `serve`:

    import numpy as np
    from tetbench_peer import Peer, serve

    class Silhouette(Peer):
        name, version, integrators = "silhouette", "0.1", ("average",)

        def prepare(self, scene):
            self.scene = scene

        def render(self, camera):
            return np.zeros((camera.height, camera.width, 4), np.float32)

    serve(Silhouette())

`serve` owns the protocol: it reads one JSON request a line from stdin, writes one reply a line
to the protocol channel (the process's stdout, kept private: whatever else the program prints
goes to stderr, which tetbench saves to the peer's log), maps the bulk files to numpy arrays,
writes the image and times `render` when the peer does not report its own `draw_ms`.
"""

import json
import os
import resource
import sys
import time
import traceback

import numpy as np

PROTOCOL = "1.0"
__version__ = "1.0.0"


class TransferFunction:
    """The transfer function's points (contract section 3), already in `s`: colour and
    extinction `tau` (per unit normalised length) are piecewise linear in `s` between points
    and constant beyond the end points."""

    def __init__(self, points):
        self.s = np.array([p["s"] for p in points], dtype=np.float64)
        self.rgb = np.array([p["rgb"] for p in points], dtype=np.float64).reshape(-1, 3)
        self.tau = np.array([p["tau"] for p in points], dtype=np.float64)

    def colour(self, s):
        """Linear RGB at `s` (any shape; the result has one more axis of 3)."""
        s = np.asarray(s, dtype=np.float64)
        return np.stack([np.interp(s, self.s, self.rgb[:, c]) for c in range(3)], axis=-1)

    def extinction(self, s):
        """`tau` at `s` (any shape)."""
        return np.interp(np.asarray(s, dtype=np.float64), self.s, self.tau)


class Scene:
    """What `prepare` gets: the mesh in the centred frame and the transfer function.

    positions: (n, 3) float64, centred on the bounding box; cells: (m, 4) uint32 vertex
    indices; scalars: (n,) float64, already the transfer function's `s`; diagonal: `L`, the
    bounding box's diagonal (optical length = world length / L); tf: TransferFunction;
    integrator: the contract's integrator name; params: the `--param` strings."""

    def __init__(self, msg):
        mesh = msg["mesh"]
        files = mesh["files"]
        self.positions = np.fromfile(files["positions"], dtype="<f8").reshape(-1, 3)
        self.cells = np.fromfile(files["cells"], dtype="<u4").reshape(-1, 4)
        self.scalars = np.fromfile(files["scalars"], dtype="<f8")
        if len(self.positions) != mesh["vertices"] or len(self.cells) != mesh["tets"]:
            raise ValueError("the mesh files do not hold the announced vertices and tets")
        self.diagonal = float(mesh["diagonal"])
        self.bbox_min = np.array(mesh["bbox_min"], dtype=np.float64)
        self.bbox_max = np.array(mesh["bbox_max"], dtype=np.float64)
        self.tf = TransferFunction(msg["tf"]["points"])
        self.integrator = msg["integrator"]
        self.params = dict(msg.get("params") or {})


class Camera:
    """What `render` gets: the contract's camera (section 2) in the centred frame.

    width, height; projection ("ortho" or "persp"); eye, target (the origin), up, right,
    forward (unit vectors); radius `R`; pixel_size `p`; ortho_scale (half the image height at
    the target plane, `H p / 2`); fov_y_deg (persp only, else None); near, far; view and proj:
    4x4 OpenGL-style matrices (row-major here, as numpy arrays)."""

    def __init__(self, msg):
        self.width = int(msg["width"])
        self.height = int(msg["height"])
        self.projection = msg["projection"]
        for k in ("eye", "target", "up", "right", "forward"):
            setattr(self, k, np.array(msg[k], dtype=np.float64))
        self.radius = float(msg["radius"])
        self.pixel_size = float(msg["pixel_size"])
        self.ortho_scale = float(msg["ortho_scale"])
        self.fov_y_deg = msg.get("fov_y_deg")
        self.near, self.far = float(msg["near"]), float(msg["far"])
        self.view = np.array(msg["view_matrix"], dtype=np.float64).reshape(4, 4)
        self.proj = np.array(msg["projection_matrix"], dtype=np.float64).reshape(4, 4)

    def plane_points(self):
        """(H, W, 3): each pixel centre's point on the plane through the target."""
        i = (np.arange(self.width) + 0.5 - self.width / 2) * self.pixel_size
        j = (self.height / 2 - np.arange(self.height) - 0.5) * self.pixel_size
        x, y = np.meshgrid(i, j)
        return self.target + x[..., None] * self.right + y[..., None] * self.up

    def rays(self):
        """(origins, directions), each (H, W, 3): one ray a pixel centre, directions unit."""
        on_plane = self.plane_points()
        if self.projection == "ortho":
            origins = on_plane + (self.eye - self.target)
            dirs = np.broadcast_to(self.forward, on_plane.shape).copy()
        else:
            origins = np.broadcast_to(self.eye, on_plane.shape).copy()
            dirs = on_plane - self.eye
            dirs /= np.linalg.norm(dirs, axis=-1, keepdims=True)
        return origins, dirs


class Frame:
    """A rendered image with the peer's own measurements. `image`: (H, W, 4), premultiplied
    linear RGBA, row 0 at the top. Times in milliseconds; absent ones are not reported (a
    missing `draw_ms` becomes the time `render` took)."""

    def __init__(self, image, draw_ms=None, project_ms=None, sort_ms=None, readback_ms=None,
                 counters=None, gpu_bytes=None):
        self.image = image
        self.draw_ms, self.project_ms = draw_ms, project_ms
        self.sort_ms, self.readback_ms = sort_ms, readback_ms
        self.counters = dict(counters or {})
        self.gpu_bytes = gpu_bytes


class Peer:
    """Base class of a peer: set the class attributes, override `prepare` and `render`
    (and `hello` to add fields such as `device` to the hello reply)."""

    name = "python-peer"
    version = "0"
    family = "other"
    integrators = ("average",)
    projections = ("ortho", "persp")

    def hello(self, msg):
        """Extra fields for the hello reply (e.g. {"device": "..."}); may load libraries."""
        return {}

    def prepare(self, scene):
        raise NotImplementedError("prepare")

    def render(self, camera):
        """Returns an (H, W, 4) array or a Frame."""
        raise NotImplementedError("render")

    def prepare_counters(self):
        """Counters for the prepare reply (e.g. cells dropped)."""
        return {}


def peak_rss_bytes():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # KiB on Linux


def _major(version):
    return str(version).split(".")[0]


def _handle(peer, msg):
    kind = msg.get("type")
    if kind == "hello":
        if _major(msg.get("protocol", "")) != _major(PROTOCOL):
            raise ValueError(
                f"protocol {msg.get('protocol')} not supported (this peer speaks {PROTOCOL})")
        reply = {
            "protocol": PROTOCOL,
            "name": peer.name,
            "version": str(peer.version),
            "family": peer.family,
            "integrators": list(peer.integrators),
            "projections": list(peer.projections),
        }
        reply.update(peer.hello(msg))
        return reply
    if kind == "prepare":
        if msg["integrator"] not in peer.integrators:
            raise ValueError(f"integrator {msg['integrator']} not supported")
        peer.prepare(Scene(msg))
        return {"counters": peer.prepare_counters()}
    if kind == "render":
        camera = Camera(msg)
        if camera.projection not in peer.projections:
            raise ValueError(f"projection {camera.projection} not supported")
        t0 = time.perf_counter()
        out = peer.render(camera)
        elapsed = (time.perf_counter() - t0) * 1e3
        frame = out if isinstance(out, Frame) else Frame(out)
        image = np.ascontiguousarray(frame.image, dtype="<f4")
        if image.shape != (camera.height, camera.width, 4):
            raise ValueError(
                f"image shape {image.shape}, expected ({camera.height}, {camera.width}, 4)")
        image.tofile(msg["image"])
        reply = {"draw_ms": elapsed if frame.draw_ms is None else frame.draw_ms}
        for k in ("project_ms", "sort_ms", "readback_ms", "gpu_bytes"):
            if getattr(frame, k) is not None:
                reply[k] = getattr(frame, k)
        reply["counters"] = {k: float(v) for k, v in frame.counters.items()}
        return reply
    raise ValueError(f"unknown request type {kind!r}")


def serve(peer, stdin=None):
    """Answers tetbench's requests until `bye` or the end of stdin."""
    # The protocol channel is a private copy of fd 1; fd 1 itself (what C libraries and print
    # write to) goes to stderr, so that nothing else can end up between two replies.
    proto = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    stdin = stdin or sys.stdin
    for line in stdin:
        line = line.strip()
        if not line:
            continue
        msg = None
        try:
            msg = json.loads(line)
            if not isinstance(msg, dict):
                raise ValueError("a request must be a JSON object")
            if msg.get("type") == "bye":
                proto.write(json.dumps({"ok": True}) + "\n")
                break
            reply = _handle(peer, msg)
            reply["ok"] = True
        except Exception as e:
            traceback.print_exc(file=sys.stderr)
            text = f"{type(e).__name__}: {e}" if str(e) else type(e).__name__
            reply = {"ok": False, "error": " ".join(text.split())}
        reply["peak_rss_bytes"] = peak_rss_bytes()
        proto.write(json.dumps(reply) + "\n")
        proto.flush()
