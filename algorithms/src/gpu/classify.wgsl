// classify.wgsl — library: the classification of a projected tet (algorithms::render::pt::classify),
// read from the generated table PT_TABLE (render::pt::table_wgsl(), the prelude render::pt::wgsl::module composes).
//
// WGSL has no i64. The four tests of PTINT Fig. 3 are cross products of differences of snapped
// coordinates (|q| < 2^30, differences < 2^31, products < 2^62): they are computed EXACTLY here
// in two's-complement 64-bit arithmetic on pairs of u32 (lo, hi), so for the same snapped
// points the GPU picks the same table entry as the CPU, and never an impossible one. What can
// differ is the snapped points themselves (the projection runs in f32 on the GPU, in f64 on the
// CPU: a vertex can land one 1/4096-pixel unit away), and the thick vertex, s_f, s_b and l,
// computed in f32 from the exact weights rounded to f32. See docs/gpu.md.

// --- 64-bit integers as vec2<u32>(lo, hi), two's complement -------------------------------

fn i64_add(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

fn i64_neg(a: vec2<u32>) -> vec2<u32> {
    let lo = ~a.x + 1u;
    return vec2<u32>(lo, ~a.y + select(0u, 1u, lo == 0u));
}

// Exact product of two i32.
fn i64_mul(a: i32, b: i32) -> vec2<u32> {
    let ua = select(bitcast<u32>(a), 0u - bitcast<u32>(a), a < 0);
    let ub = select(bitcast<u32>(b), 0u - bitcast<u32>(b), b < 0);
    let a0 = ua & 0xffffu;
    let a1 = ua >> 16u;
    let b0 = ub & 0xffffu;
    let b1 = ub >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = p01 + p10;
    let mid_carry = select(0u, 0x10000u, mid < p01);
    let lo = p00 + (mid << 16u);
    let hi = p11 + (mid >> 16u) + mid_carry + select(0u, 1u, lo < p00);
    let m = vec2<u32>(lo, hi);
    return select(m, i64_neg(m), (a < 0) != (b < 0));
}

fn i64_sign(a: vec2<u32>) -> i32 {
    if bitcast<i32>(a.y) < 0 {
        return -1;
    }
    return select(1, 0, a.x == 0u && a.y == 0u);
}

fn i64_to_f32(a: vec2<u32>) -> f32 {
    let neg = bitcast<i32>(a.y) < 0;
    let m = select(a, i64_neg(a), neg);
    let v = f32(m.y) * 4294967296.0 + f32(m.x);
    return select(v, -v, neg);
}

// a × b of two 2-D integer vectors, exact.
fn i64_cross(a: vec2<i32>, b: vec2<i32>) -> vec2<u32> {
    return i64_add(i64_mul(a.x, b.y), i64_neg(i64_mul(a.y, b.x)));
}

// --- table entries (pt::Case::pack) ------------------------------------------------------

fn pt_class(entry: u32) -> u32 { return entry & 15u; }
fn pt_ntri(entry: u32) -> u32 { return (entry >> 4u) & 15u; }
fn pt_side_a(entry: u32) -> u32 { return (entry >> 8u) & 15u; }
fn pt_side_b(entry: u32) -> u32 { return (entry >> 12u) & 15u; }
// Silhouette vertex k (k ≤ ntri) of the fan: triangle k is (thick, fan(k), fan(k + 1)).
fn pt_fan(entry: u32, k: u32) -> u32 { return (entry >> (16u + 2u * k)) & 3u; }

fn pt_entry(case_index: u32) -> u32 {
    var table = PT_TABLE;
    return table[min(case_index, 80u)];
}

// --- classification ----------------------------------------------------------------------

// One projected vertex, as pt::ProjVertex.
struct PtVertex {
    q: vec2<i32>,   // snapped pixel coordinates (pt::snap)
    z: f32,         // depth along the view axis (view_project)
    s: f32,         // transfer-function coordinate
    p: vec3<f32>,   // position in the centred frame
}

// A classified tet, as pt::Thick. The fan order and the triangle count are in `entry`
// (pt_ntri, pt_fan).
struct PtThick {
    case_index: u32,
    entry: u32,
    thick: vec2<f32>, // thick vertex in pixels (snapped units / 2^PT_SUBPIXEL_BITS)
    sf: f32,
    sb: f32,
    zf: f32,
    zb: f32,
    l: f32,           // optical units: world length / L (CONVENTIONS §1)
}

struct PtHull {
    p: vec3<f32>,
    s: f32,
    z: f32,
}

// The point of the hull of `mask` on the thick ray (pt::hull_point): 2-D weights
// λ_k = w_k / Σ w_k; in perspective the 3-D weights are μ_k ∝ λ_k / z_k.
fn pt_hull_point(verts: array<PtVertex, 4>, w: vec4<f32>, mask: u32, persp: bool) -> PtHull {
    var v = verts;
    var sum = 0.0;
    for (var k = 0u; k < 4u; k++) {
        if (mask & (1u << k)) != 0u {
            sum += w[k];
        }
    }
    var p = vec3<f32>(0.0);
    var s = 0.0;
    var acc = 0.0;
    var zl = 0.0;
    for (var k = 0u; k < 4u; k++) {
        if (mask & (1u << k)) == 0u {
            continue;
        }
        let lam = w[k] / sum;
        let mu = select(lam, lam / v[k].z, persp);
        p += mu * v[k].p;
        s += mu * v[k].s;
        acc += mu;
        zl += lam * v[k].z;
    }
    if persp {
        return PtHull(p / acc, s / acc, 1.0 / acc);
    }
    return PtHull(p, s, zl);
}

// pt::classify: the table entry and, for a drawn tet, the thick vertex with s_f, s_b, the
// depths and l = |X_B − X_A| / L (PTINT §3.1; Shirley & Tuchman 1990).
fn pt_classify(verts: array<PtVertex, 4>, persp: bool, inv_l: f32) -> PtThick {
    var v = verts;
    // The four tests of PTINT Fig. 3 (pt::tests), exact.
    let e1 = v[1].q - v[0].q;
    let e2 = v[2].q - v[0].q;
    let e3 = v[3].q - v[0].q;
    let e4 = v[1].q - v[2].q;
    let e5 = v[1].q - v[3].q;
    let t1 = i64_cross(e1, e2);
    let t2 = i64_cross(e1, e3);
    let t3 = i64_cross(e2, e3);
    let t4 = i64_cross(e4, e5);
    // PTINT eq. 3: Σ (sign(t_i) + 1)·3^(i−1) (pt::table_index).
    let idx = u32(i64_sign(t1) + 1) + 3u * u32(i64_sign(t2) + 1) + 9u * u32(i64_sign(t3) + 1)
        + 27u * u32(i64_sign(t4) + 1);
    let entry = pt_entry(idx);
    var out = PtThick(idx, entry, vec2<f32>(0.0), 0.0, 0.0, 0.0, 0.0, 0.0);
    if pt_ntri(entry) == 0u {
        return out;
    }
    // Radon weights w = (t4, −t3, t2, −t1) (pt::radon_weights), rounded to f32.
    let w = vec4<f32>(i64_to_f32(t4), -i64_to_f32(t3), i64_to_f32(t2), -i64_to_f32(t1));
    let a = pt_side_a(entry);
    let scale = 1.0 / f32(1u << PT_SUBPIXEL_BITS);
    if pt_class(entry) == 2u {
        // The crossing of the edges A and B: Σ_A w_k q_k / Σ_A w_k.
        var sum = 0.0;
        for (var k = 0u; k < 4u; k++) {
            if (a & (1u << k)) != 0u {
                sum += w[k];
            }
        }
        var x = vec2<f32>(0.0);
        for (var k = 0u; k < 4u; k++) {
            if (a & (1u << k)) != 0u {
                x += (w[k] / sum) * vec2<f32>(v[k].q) * scale;
            }
        }
        out.thick = x;
    } else {
        out.thick = vec2<f32>(v[countTrailingZeros(a)].q) * scale;
    }
    let ha = pt_hull_point(verts, w, a, persp);
    let hb = pt_hull_point(verts, w, pt_side_b(entry), persp);
    out.l = length(hb.p - ha.p) * inv_l;
    if ha.z <= hb.z {
        out.sf = ha.s;
        out.sb = hb.s;
        out.zf = ha.z;
        out.zb = hb.z;
    } else {
        out.sf = hb.s;
        out.sb = ha.s;
        out.zf = hb.z;
        out.zb = ha.z;
    }
    return out;
}

// Whether a fan triangle (thick vertex `thick` in pixels; silhouette vertices `qa`, `qb`
// snapped) is too thin for the GPU's rasterizer: its altitude is at most PT_MIN_ALTITUDE
// pixels. Rasterizers snap vertices to 1/256 pixel (or coarser), so such a triangle covers a
// pixel centre only through that rounding, and its attributes are then extrapolated far outside
// the triangle: a face seen edge-on in perspective (its plane through the eye) gave a zero-area
// fan triangle through a pixel centre and α 0.996 where the reference has 0.557. The CPU
// rasterizer (exact, top-left rule) covers no pixel centre with a zero-area triangle, so
// dropping these keeps the GPU at the CPU's image.
const PT_MIN_ALTITUDE: f32 = 0.00390625; // 1/256 pixel

fn pt_fan_too_thin(thick: vec2<f32>, qa: vec2<i32>, qb: vec2<i32>) -> bool {
    let unit = 1.0 / f32(1u << PT_SUBPIXEL_BITS);
    let a = vec2<f32>(qa) * unit - thick;
    let b = vec2<f32>(qb) * unit - thick;
    let area2 = abs(a.x * b.y - a.y * b.x);
    let longest = max(max(length(a), length(b)), length(b - a));
    return area2 <= longest * PT_MIN_ALTITUDE;
}
