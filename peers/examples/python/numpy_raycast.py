"""numpy-raycast: a ray caster in numpy, as a tetbench peer written with the Python SDK.

Every (cell, pixel) pair whose pixel lies in the cell's projected bounding box is intersected
exactly: the ray against the cell's four face planes gives the entry and exit distances, the
scalar's linear gradient in the cell gives `s` at both ends. The segments are then sorted along
each ray (np.lexsort by pixel, then distance), which gives the exact visibility order on any
mesh, convex or not, and composited front to back with a segmented cumulative sum of optical
depth. Integrators (contract section 4): `average` (Shirley-Tuchman on the segment) and
`partial` (Moreland-Angel, Psi by 16-point Gauss-Legendre quadrature).

Run by tetbench (peers/examples/peers.toml); needs numpy and the SDK (peers/python) on the
path. Expected error against `reference`: docs/peers.md, "Example peers".
"""

import time

import numpy as np

from tetbench_peer import Frame, Peer, serve

# Gauss-Legendre nodes and weights on [0, 1] for Psi.
_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)
_GL_U = 0.5 * (_GL_X + 1.0)
_GL_W = 0.5 * _GL_W

# Pairs handled at once (bounds the memory of one frame to ~ 100 bytes x this).
_CHUNK = 1 << 20


class NumpyRaycast(Peer):
    name = "numpy-raycast"
    version = "1.0"
    family = "raycasting"
    integrators = ("average", "partial")
    projections = ("ortho", "persp")

    def hello(self, msg):
        return {"device": f"cpu (numpy {np.__version__})"}

    def prepare(self, scene):
        self.scene = scene
        p = scene.positions
        c = scene.cells.astype(np.int64)
        v = p[c]  # (m, 4, 3)
        e = v[:, 1:] - v[:, :1]  # (m, 3, 3): edges from vertex 0
        vol = np.linalg.det(e) / 6.0
        L = scene.diagonal
        keep = np.abs(vol) > 1e-14 * L * L * L
        self.dropped = int((~keep).sum())
        v, e, c = v[keep], e[keep], c[keep]
        # Face k is opposite vertex k; its normal points away from vertex k: inside is
        # n_k . x <= h_k for all four faces.
        normals = np.empty((len(v), 4, 3))
        offsets = np.empty((len(v), 4))
        for k in range(4):
            a, b, d = [v[:, i] for i in range(4) if i != k]
            n = np.cross(b - a, d - a)
            flip = np.einsum("ij,ij->i", n, v[:, k] - a) > 0
            n[flip] = -n[flip]
            normals[:, k] = n
            offsets[:, k] = np.einsum("ij,ij->i", n, a)
        # s is linear in a cell: s(x) = s0 + g . (x - v0), with e g = ds.
        s = scene.scalars[c]
        grad = np.linalg.solve(e, (s[:, 1:] - s[:, :1])[..., None])[..., 0]
        # A ray that runs inside a face's plane belongs to the one of the two cells sharing the
        # face whose outward normal is lexicographically positive (a fixed infinitesimal shift
        # of every ray): each such ray is counted once, as a watertight caster must.
        nx, ny, nz = normals[..., 0], normals[..., 1], normals[..., 2]
        self.claims = (nx > 0) | ((nx == 0) & ((ny > 0) | ((ny == 0) & (nz > 0))))
        self.verts, self.normals, self.offsets = v, normals, offsets
        self.grad, self.s0, self.v0 = grad, s[:, 0], v[:, 0]

    def prepare_counters(self):
        return {"dropped_cells": self.dropped}

    def _pixel_boxes(self, cam):
        """Each cell's projected pixel bounding box (i0, j0, i1, j1), inclusive, clipped."""
        rel = self.verts - cam.eye
        x, y = rel @ cam.right, rel @ cam.up
        if cam.projection == "persp":
            # Onto the plane through the target (3R from the eye, contract section 2).
            dist = np.linalg.norm(cam.target - cam.eye)
            scale = dist / np.maximum(rel @ cam.forward, 1e-30)
            x, y = x * scale, y * scale
        px = x / cam.pixel_size + cam.width / 2 - 0.5
        py = cam.height / 2 - 0.5 - y / cam.pixel_size
        i0 = np.clip(np.floor(px.min(1)), 0, cam.width).astype(np.int64)
        i1 = np.clip(np.ceil(px.max(1)), -1, cam.width - 1).astype(np.int64)
        j0 = np.clip(np.floor(py.min(1)), 0, cam.height).astype(np.int64)
        j1 = np.clip(np.ceil(py.max(1)), -1, cam.height - 1).astype(np.int64)
        return i0, j0, i1, j1

    def _segments(self, cam, origins, dirs):
        """All ray segments: pixel, entry distance, s at entry and exit, optical length."""
        i0, j0, i1, j1 = self._pixel_boxes(cam)
        w = np.maximum(i1 - i0 + 1, 0)
        counts = w * np.maximum(j1 - j0 + 1, 0)
        cell_ends = np.cumsum(counts)
        out = []
        start = 0
        while start < len(counts):
            # The cells whose pairs fit in one chunk (at least one cell).
            base = cell_ends[start - 1] if start else 0
            stop = max(start + 1, int(np.searchsorted(cell_ends, base + _CHUNK, "right")))
            cells = np.arange(start, stop)
            n = counts[cells]
            cell = np.repeat(cells, n)
            local = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
            i = i0[cell] + local % w[cell]
            j = j0[cell] + local // w[cell]
            pix = j * cam.width + i
            o, d = origins[pix], dirs[pix]
            nrm, off = self.normals[cell], self.offsets[cell]
            den = np.einsum("pkc,pc->pk", nrm, d)
            num = off - np.einsum("pkc,pc->pk", nrm, o)
            with np.errstate(divide="ignore", invalid="ignore"):
                t = num / den
            t_in = np.where(den < 0, t, -np.inf).max(1)
            t_out = np.where(den > 0, t, np.inf).min(1)
            outside = (num < 0) | ((num == 0) & ~self.claims[cell])
            parallel_out = ((den == 0) & outside).any(1)
            ok = (t_in < t_out) & ~parallel_out & np.isfinite(t_in) & np.isfinite(t_out)
            cell, pix, o, d, t_in, t_out = cell[ok], pix[ok], o[ok], d[ok], t_in[ok], t_out[ok]
            g, s0, v0 = self.grad[cell], self.s0[cell], self.v0[cell]
            s_in = s0 + np.einsum("pc,pc->p", g, o + t_in[:, None] * d - v0)
            s_out = s0 + np.einsum("pc,pc->p", g, o + t_out[:, None] * d - v0)
            out.append((pix, t_in, s_in, s_out, (t_out - t_in) / self.scene.diagonal))
            start = stop
        return [np.concatenate(a) for a in zip(*out)] if out else [np.empty(0)] * 5

    def render(self, cam):
        t0 = time.perf_counter()
        origins, dirs = (a.reshape(-1, 3) for a in cam.rays())
        pix, t_in, s_f, s_b, l = self._segments(cam, origins, dirs)
        t1 = time.perf_counter()
        order = np.lexsort((t_in, pix))
        pix, s_f, s_b, l = pix[order], s_f[order], s_b[order], l[order]
        t2 = time.perf_counter()
        tf = self.scene.tf
        if self.scene.integrator == "average":
            s = 0.5 * (s_f + s_b)
            depth = tf.extinction(s) * l
            alpha = -np.expm1(-depth)
            emitted = tf.colour(s) * alpha[:, None]
        else:
            tau_f, tau_b = tf.extinction(s_f), tf.extinction(s_b)
            depth = 0.5 * l * (tau_f + tau_b)
            a, b = tau_f * l, 0.5 * (tau_b - tau_f) * l
            psi = np.exp(-np.outer(a, _GL_U) - np.outer(b, _GL_U * _GL_U)) @ _GL_W
            zeta = np.exp(-depth)
            emitted = tf.colour(s_f) * (1.0 - psi)[:, None] + tf.colour(s_b) * (psi - zeta)[:, None]
        # Front to back: transmittance before each segment is exp(-(optical depth of the
        # segments in front of it on the same ray)).
        total = np.cumsum(depth)
        first = np.r_[True, pix[1:] != pix[:-1]]
        group_start = np.maximum.accumulate(np.where(first, np.arange(len(pix)), 0))
        before = total - depth - (total[group_start] - depth[group_start])
        weight = np.exp(-before)
        n = cam.width * cam.height
        img = np.zeros((n, 4))
        for ch in range(3):
            img[:, ch] = np.bincount(pix, weights=emitted[:, ch] * weight, minlength=n)
        img[:, 3] = -np.expm1(-np.bincount(pix, weights=depth, minlength=n))
        t3 = time.perf_counter()
        return Frame(
            img.reshape(cam.height, cam.width, 4).astype(np.float32),
            project_ms=(t1 - t0) * 1e3,
            sort_ms=(t2 - t1) * 1e3,
            draw_ms=(t3 - t2) * 1e3,
            counters={"segments": len(pix), "dropped_cells": self.dropped},
        )


if __name__ == "__main__":
    serve(NumpyRaycast())
