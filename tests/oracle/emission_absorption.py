"""The emission-absorption model (CONVENTIONS §4) evaluated in 50-digit arithmetic (mpmath):
the yardstick `tests/tests/exact_oracle.rs` holds the `exact` integrator and `reference` to.

Input (JSON on stdin):
  {"tf": [[s, r, g, b, tau], ...],                     # sorted by s, piecewise linear
   "rays": [[[s_f, s_b, l], ...], ...]}                # segments front to back, or
  {"tf": ..., "mesh": {"verts": [[x, y, z, s], ...], "tets": [[a, b, c, d], ...], "L": L},
   "pixels": [[ox, oy, oz, dx, dy, dz], ...]}          # one ray per pixel
Output (JSON on stdout): one [r, g, b, alpha] per ray or pixel, as decimal strings.

Every number given is an f64 and is taken exactly. A segment's scalar is linear along it
(s = s_f + (s_b - s_f) u, u in [0, 1]); colour C and extinction tau are the TF's at s, and
  I = integral of C(u) tau(u) l T(u) du,  T(u) = exp(-integral_0^u tau l),  alpha = 1 - T(end),
summed along the ray with the optical depth carried from segment to segment. The integral is
taken by quadrature on pieces where C and tau are linear (split at the TF's points),
each piece cut where the optical depth grows by 2, so that the integrand is smooth and nearly
flat on every interval, by Gauss-Legendre rules of 24 and 48 nodes, whose difference must be
below 1e-40 (checked; the 24-node rule's error bound is below 1e-46 there).
Beyond an optical depth of 130 the rest of the ray weighs below 1e-56 and is left out.

For pixels, each ray is clipped against every tet exactly: the barycentric coordinates of
o + t d are affine in t, their zero crossings bound the interval inside the tet, and the scalar
is their combination of the vertices' s. Intervals are taken in order of t; a tet of zero
volume has no interior and contributes nothing.
"""
import json
import sys

from mpmath import mp, mpf
from mpmath.calculus.quadrature import GaussLegendre

mp.dps = 50
DEPTH_END = mpf(130)
CHECK = mpf(10) ** -40


def tf_at(tf, s):
    """(r, g, b, tau) at s: linear between points, constant beyond the ends."""
    if s <= tf[0][0]:
        return tf[0][1:]
    if s >= tf[-1][0]:
        return tf[-1][1:]
    lo, hi = 0, len(tf) - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if tf[mid][0] <= s:
            lo = mid
        else:
            hi = mid
    a, b = tf[lo], tf[hi]
    w = (s - a[0]) / (b[0] - a[0])
    return [a[c] + (b[c] - a[c]) * w for c in range(1, 5)]


# Gauss-Legendre rules of 24 and 48 nodes on [-1, 1] (mpmath's), the second the value and the
# first its check.
RULES = [GaussLegendre(mp).calc_nodes(d, mp.prec + 20) for d in (4, 5)]


class Ray:
    def __init__(self):
        self.rgb = [mpf(0)] * 3
        self.depth = mpf(0)

    def piece(self, c0, t0, c1, t1, length):
        """Adds a piece of optical length `length` on which colour goes linearly from c0 to
        c1 and extinction from t0 to t1."""
        if length == 0 or self.depth >= DEPTH_END:
            return
        # On x in [0, 1]: tau(x) = t0 + (t1 - t0) x, depth D(x) = D0 + length (t0 x + (t1 - t0) x^2 / 2).
        a, b = length * t0, length * (t1 - t0) / 2
        d0 = self.depth
        cuts = [mpf(0)]
        target = d0 + 2
        while True:
            # The x where D(x) = target: b x^2 + a x - (target - d0) = 0, stable root.
            v = target - d0
            disc = a * a + 4 * b * v
            if disc < 0:
                break
            x = 2 * v / (a + mp.sqrt(disc)) if a + mp.sqrt(disc) > 0 else mpf(2)
            if x >= 1 or target > DEPTH_END + 2:
                break
            cuts.append(x)
            target += 2
        cuts.append(mpf(1))

        def gauss(x0, x1, rule):
            """The rule on [x0, x1] for the integrand colour(x) tau(x) length T(x), as a
            function of the colour: the transmittance at each node is taken once."""
            h, m = (x1 - x0) / 2, (x1 + x0) / 2
            nodes = [(m + h * x, w * h) for x, w in rule]
            wt = [(x, w * (t0 + (t1 - t0) * x) * length * mp.exp(-(d0 + a * x + b * x * x)))
                  for x, w in nodes]
            return lambda colour: mp.fsum(w * colour(x) for x, w in wt)

        for x0, x1 in zip(cuts, cuts[1:]):
            low, high = gauss(x0, x1, RULES[0]), gauss(x0, x1, RULES[1])
            for c in range(3):
                val = high(lambda x: (c0[c] + (c1[c] - c0[c]) * x))
                err = abs(val - low(lambda x: (c0[c] + (c1[c] - c0[c]) * x)))
                if err > CHECK:
                    raise RuntimeError(f"quadrature rules differ by {err} on [{x0}, {x1}]")
                self.rgb[c] += val
        self.depth = d0 + a + b

    def segment(self, tf, sf, sb, l):
        """A segment of optical length l from scalar sf to sb, split at the TF's points."""
        if l <= 0:
            return
        us = [mpf(0)]
        if sf != sb:
            lo, hi = min(sf, sb), max(sf, sb)
            inner = sorted(p[0] for p in tf if lo < p[0] < hi)
            if sb < sf:
                inner.reverse()
            us += [(s - sf) / (sb - sf) for s in inner]
        us.append(mpf(1))
        for u0, u1 in zip(us, us[1:]):
            e0 = tf_at(tf, sf + (sb - sf) * u0)
            e1 = tf_at(tf, sf + (sb - sf) * u1)
            self.piece(e0[:3], e0[3], e1[:3], e1[3], l * (u1 - u0))

    def result(self):
        return [str(c) for c in self.rgb] + [str(-mp.expm1(-self.depth))]


def tet_interval(v, o, d):
    """(t_in, t_out, s_in, s_out) of the ray o + t d inside tet v (4 points with s), or None."""
    p = [[mpf(x) for x in q[:3]] for q in v]
    s = [mpf(q[3]) for q in v]

    def sub(a, b):
        return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]

    def det3(a, b, c):
        return (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]))

    e1, e2, e3 = sub(p[1], p[0]), sub(p[2], p[0]), sub(p[3], p[0])
    vol = det3(e1, e2, e3)
    if vol == 0:
        return None
    # Barycentric coordinates (Cramer) of x = o + t d: lambda_k(t) = alpha_k + beta_k t.
    r0 = sub(o, p[0])
    alpha = [det3(r0, e2, e3) / vol, det3(e1, r0, e3) / vol, det3(e1, e2, r0) / vol]
    beta = [det3(d, e2, e3) / vol, det3(e1, d, e3) / vol, det3(e1, e2, d) / vol]
    alpha = [1 - sum(alpha)] + alpha
    beta = [-sum(beta)] + beta
    t_in, t_out = -mp.inf, mp.inf
    for a, b in zip(alpha, beta):
        if b == 0:
            if a < 0:
                return None
        elif b > 0:
            t_in = max(t_in, -a / b)
        else:
            t_out = min(t_out, -a / b)
    if not t_in < t_out:
        return None

    def scalar(t):
        return sum((a + b * t) * sk for a, b, sk in zip(alpha, beta, s))

    return t_in, t_out, scalar(t_in), scalar(t_out)


def pixels(tf, mesh, rays):
    import numpy as np

    verts = np.array(mesh["verts"], dtype=float)
    tets = np.array(mesh["tets"], dtype=np.int64)
    L = mpf(mesh["L"])
    pts = verts[tets][:, :, :3]
    centre = pts.mean(axis=1)
    radius = np.sqrt(((pts - centre[:, None, :]) ** 2).sum(axis=2)).max(axis=1)
    out = []
    for r in rays:
        o64, d64 = np.array(r[:3]), np.array(r[3:])
        # Tets whose bounding sphere the ray's line passes within (padded against rounding).
        rel = centre - o64
        dist = np.linalg.norm(np.cross(rel, d64), axis=1) / np.linalg.norm(d64)
        near = np.nonzero(dist <= radius * (1 + 1e-9) + 1e-12)[0]
        o = [mpf(x) for x in r[:3]]
        d = [mpf(x) for x in r[3:]]
        dnorm = mp.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
        spans = []
        for t in near:
            iv = tet_interval([mesh["verts"][k] for k in mesh["tets"][t]], o, d)
            if iv is not None and iv[1] > 0:
                spans.append(iv)
        spans.sort(key=lambda x: x[0])
        ray = Ray()
        for t_in, t_out, s_in, s_out in spans:
            if t_in < 0:
                # Only what lies in front of the origin (persp: the eye) counts.
                s_in = s_in + (s_out - s_in) * (-t_in) / (t_out - t_in)
                t_in = mpf(0)
            ray.segment(tf, s_in, s_out, (t_out - t_in) * dnorm / L)
        out.append(ray.result())
    return out


def main():
    job = json.load(sys.stdin)
    tf = [[mpf(x) for x in p] for p in job["tf"]]
    if "rays" in job:
        out = []
        for segs in job["rays"]:
            ray = Ray()
            for sf, sb, l in segs:
                ray.segment(tf, mpf(sf), mpf(sb), mpf(l))
            out.append(ray.result())
    else:
        out = pixels(tf, job["mesh"], job["pixels"])
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
