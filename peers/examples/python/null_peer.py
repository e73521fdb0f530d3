"""null-python: a peer that draws nothing (a transparent image), to measure what the protocol
and the Python SDK cost per frame (docs/peers.md, "Overhead")."""

import numpy as np

from tetbench_peer import Frame, Peer, serve


class NullPeer(Peer):
    name = "null-python"
    version = "1.0"
    integrators = ("average", "partial", "preint", "exact")

    def prepare(self, scene):
        pass

    def render(self, camera):
        return Frame(np.zeros((camera.height, camera.width, 4), np.float32), draw_ms=0.0)


if __name__ == "__main__":
    serve(NullPeer())
