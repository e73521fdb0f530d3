// optics.wgsl — library: the per-segment integrators of CONVENTIONS §4 on the GPU, an exact
// port of the f32 fast paths of algorithms::optics::fast (FastIntegrator::segment) reading the
// same tables, uploaded by optics::gpu::OpticsTables at @group(0):
//   binding 0: OpticsParams (uniform)
//   binding 1: the transfer function, TfTable::data(), [r, g, b, τ] per sample
//   binding 2: Ψ, PsiTable::data(), n × n f32 (partial)
//   binding 3: the pre-integration table, PreintTable::data(), [r, g, b, τ] per entry (preint)
// `segment(s_f, s_b, l)` returns the premultiplied [r, g, b, α] of one segment.

struct OpticsParams {
    kind: u32,          // 0 average, 1 partial, 2 preint
    tf_n: u32,          // TF samples
    psi_n: u32,         // Ψ table side
    pre_ns: u32,        // preint table: samples of s_f and of s_b
    tf_lo: f32,         // TfTable::domain(): sample i at s = lo + i / scale
    tf_scale: f32,
    pre_nl: u32,        // preint table: samples of l
    pre_lo: f32,        // PreintTable::s_range()[0]
    pre_scale: f32,     // (n_s − 1) / (s_hi − s_lo)
    pre_l_max: f32,     // PreintTable::L_MAX
    pre_l0: f32,        // PreintTable::L0
    pre_l_norm: f32,    // 1 / ln(1 + L_MAX / L0)
}

@group(0) @binding(0) var<uniform> optics: OpticsParams;
@group(0) @binding(1) var<storage, read> optics_tf: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> optics_psi: array<f32>;
@group(0) @binding(3) var<storage, read> optics_preint: array<vec4<f32>>;

// Whether x is neither NaN nor ±∞ (by its bits: a compiler may not fold this away).
fn optics_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

// optics::fast::exp_neg: exp(−x) for x ≥ 0 as 2^y, y = −x·log2 e = n + f, f ∈ [−0.5, 0.5], by
// the Cephes exp2f polynomial (relative error ≤ 2e-6 for x ≤ 20).
fn exp_neg(x: f32) -> f32 {
    let y = max(-x * 1.4426950408889634, -126.0);
    let n = round(y); // ties to even, as the CPU's 1.5·2^23 trick
    let f = y - n;
    let p = ((((1.5353362e-4 * f + 1.3398874e-3) * f + 9.618437e-3) * f + 5.5503325e-2) * f
        + 2.4022648e-1) * f + 6.931472e-1;
    let m = 1.0 + f * p;
    return m * bitcast<f32>(u32(i32(n) + 127) << 23u);
}

// τ·l with 0·∞ = 0.
fn tau_len(tau: f32, l: f32) -> f32 {
    return select(tau * l, 0.0, tau == 0.0);
}

// ln(1 + x), accurate for small x (WGSL has no log1p): ln(u)·x/(u − 1), u = 1 + x.
fn optics_log1p(x: f32) -> f32 {
    let u = 1.0 + x;
    if u == 1.0 {
        return x;
    }
    return log(u) * x / (u - 1.0);
}

// TfTable::eval: [r, g, b, τ] at s, linear between samples, clamped to the end samples.
fn tf_eval(s: f32) -> vec4<f32> {
    let x = clamp((s - optics.tf_lo) * optics.tf_scale, 0.0, f32(optics.tf_n - 1u));
    let i = min(u32(x), optics.tf_n - 2u);
    let t = x - f32(i);
    let a = optics_tf[i];
    let b = optics_tf[i + 1u];
    return a + (b - a) * t;
}

// optics::fast::psi_lookup: bilinear Ψ at the end depths fa, fb ≥ 0, indexed by γ = x/(1 + x)
// (CONVENTIONS §4, partial).
fn psi_lookup(fa: f32, fb: f32) -> f32 {
    let n = optics.psi_n;
    let m = f32(n - 1u);
    let gi = (1.0 - 1.0 / (1.0 + fa)) * m;
    let gj = (1.0 - 1.0 / (1.0 + fb)) * m;
    let i = min(u32(gi), n - 2u);
    let j = min(u32(gj), n - 2u);
    let ti = gi - f32(i);
    let tj = gj - f32(j);
    let r0 = j * n + i;
    let r1 = (j + 1u) * n + i;
    let v0 = optics_psi[r0] + (optics_psi[r0 + 1u] - optics_psi[r0]) * ti;
    let v1 = optics_psi[r1] + (optics_psi[r1 + 1u] - optics_psi[r1]) * ti;
    return v0 + (v1 - v0) * tj;
}

// optics::fast::preint_lookup: trilinear in (s_f, s_b, l coordinate), l on the log axis
// ln(1 + l/L0) / ln(1 + L_MAX/L0); α from the tabled mean extinction.
fn preint_lookup(sf: f32, sb: f32, l: f32) -> vec4<f32> {
    let ns = optics.pre_ns;
    let nl = optics.pre_nl;
    let x = clamp((sf - optics.pre_lo) * optics.pre_scale, 0.0, f32(ns - 1u));
    let y = clamp((sb - optics.pre_lo) * optics.pre_scale, 0.0, f32(ns - 1u));
    let lc = optics_log1p(min(l, optics.pre_l_max) / optics.pre_l0) * optics.pre_l_norm;
    let z = clamp(lc * f32(nl - 1u), 0.0, f32(nl - 1u));
    let i = min(u32(x), ns - 2u);
    let j = min(u32(y), ns - 2u);
    let k = min(u32(z), nl - 2u);
    let ti = x - f32(i);
    let tj = y - f32(j);
    let tk = z - f32(k);
    var v = vec4<f32>(0.0);
    for (var dk = 0u; dk < 2u; dk++) {
        let wk = select(1.0 - tk, tk, dk == 1u);
        for (var dj = 0u; dj < 2u; dj++) {
            let wj = select(1.0 - tj, tj, dj == 1u);
            let base = ((k + dk) * ns + j + dj) * ns + i;
            let e0 = optics_preint[base];
            let e1 = optics_preint[base + 1u];
            v += (wk * wj) * (e0 + (e1 - e0) * ti);
        }
    }
    let alpha = 1.0 - exp_neg(tau_len(v.w, l));
    return vec4<f32>(v.xyz * alpha, alpha);
}

// FastIntegrator::segment: premultiplied [r, g, b, α] of one segment (CONVENTIONS §4); l ≤ 0,
// NaN or non-finite ends give 0.
fn segment(sf: f32, sb: f32, l: f32) -> vec4<f32> {
    if !(optics_finite(sf) && optics_finite(sb) && l > 0.0) {
        return vec4<f32>(0.0);
    }
    if optics.kind == 0u {
        // average (Shirley–Tuchman): C(s̄), α = 1 − exp(−τ(s̄)·l).
        let c = tf_eval(0.5 * sf + 0.5 * sb);
        let alpha = 1.0 - exp_neg(tau_len(c.w, l));
        return vec4<f32>(c.xyz * alpha, alpha);
    }
    if optics.kind == 1u {
        // partial (Moreland–Angel): ζ = exp(−l(τ_f + τ_b)/2), I = C_f(1 − Ψ) + C_b(Ψ − ζ)
        // = C_f·α + (C_b − C_f)(Ψ − ζ).
        let cf = tf_eval(sf);
        let cb = tf_eval(sb);
        let fa = tau_len(cf.w, l);
        let fb = tau_len(cb.w, l);
        let zeta = exp_neg(0.5 * (fa + fb));
        let alpha = 1.0 - zeta;
        let pmz = clamp(psi_lookup(fa, fb) - zeta, 0.0, alpha);
        return vec4<f32>(cf.xyz * alpha + (cb.xyz - cf.xyz) * pmz, alpha);
    }
    return preint_lookup(sf, sb, l);
}
