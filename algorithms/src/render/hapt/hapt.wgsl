// hapt.wgsl — library: hapt's buffers and its per-tet work (HAPT §3): load a tet's four
// vertices, early discard of empty tets, classification (classify.wgsl) and the fan vertex.
// Needs view.wgsl, classify.wgsl, volume.wgsl.

struct HaptParams {
    // The TF table's grid (optics::fast::TfTable::domain): cell k spans s in
    // [tf_lo + k / tf_scale, tf_lo + (k + 1) / tf_scale], k < tf_cells.
    tf_lo: f32,
    tf_scale: f32,
    tf_cells: u32,
    // Bit 0: volume (DVR), bit 1: iso-surfaces.
    mode: u32,
    // Iso values in TF coordinate s (converted from scalar units on the CPU), iso_n of them.
    iso_s: vec4<f32>,
    // Colour (rgb, the TF colour at the iso value) and opacity of each iso-surface.
    iso_rgba: array<vec4<f32>, 4>,
    iso_n: u32,
    _p0: u32,
    _p1: u32,
    _p2: u32,
}

@group(2) @binding(0) var<uniform> hp: HaptParams;
// Resident mode: centred positions (xyz), scalars (TF coordinate), tets, sorted tet indices.
@group(2) @binding(1) var<storage, read> verts: array<vec4<f32>>;
@group(2) @binding(2) var<storage, read> scal: array<f32>;
@group(2) @binding(3) var<storage, read> tets: array<vec4<u32>>;
@group(2) @binding(4) var<storage, read> order: array<u32>;
// nz[k] = number of TF cells below k on which τ is not identically 0 (k ≤ tf_cells).
@group(2) @binding(5) var<storage, read> nz: array<u32>;
// Streaming mode: the chunk's tets, four (xyz, s) a tet, in sorted order.
@group(2) @binding(6) var<storage, read> chunk: array<vec4<f32>>;

// What the vertex stage hands the fragment stages: VolumeVarying's locations 0 and 1, plus the
// tet's flat shading factor for iso-surfaces (location 2).
struct HaptVarying {
    @builtin(position) pos: vec4<f32>,
    @location(0) @interpolate(linear) a: vec4<f32>,
    @location(1) @interpolate(linear) b: f32,
    @location(2) @interpolate(flat) shade: f32,
}

// Whether τ ≡ 0 on the TF cells that s in [s0, s1] touches (HAPT §3: early discard of tets
// that contribute nothing). Exact for the integrators' tables: τ is interpolated between the
// samples of these cells only, and the CPU marks a cell empty only if the transfer function's
// τ is 0 on the whole cell (render/hapt/mod.rs, `empty_cells`).
fn hapt_tau_zero(s0: f32, s1: f32) -> bool {
    let hi = f32(hp.tf_cells);
    let x0 = clamp((s0 - hp.tf_lo) * hp.tf_scale, 0.0, hi);
    let x1 = clamp((s1 - hp.tf_lo) * hp.tf_scale, 0.0, hi);
    let k0 = min(u32(x0), hp.tf_cells - 1u);
    let k1 = min(u32(x1), hp.tf_cells - 1u);
    return nz[k1 + 1u] == nz[k0];
}

// Whether the tet draws anything in this mode: volume where τ is not 0 on its scalar range,
// iso-surfaces where an iso value lies in it (marching tetrahedra's test).
fn hapt_visible(s0: f32, s1: f32) -> bool {
    if (hp.mode & 1u) != 0u && !hapt_tau_zero(s0, s1) {
        return true;
    }
    if (hp.mode & 2u) != 0u {
        for (var i = 0u; i < hp.iso_n; i++) {
            if hp.iso_s[i] >= s0 && hp.iso_s[i] <= s1 {
                return true;
            }
        }
    }
    return false;
}

// |n · d| of the tet's field gradient n (normalised; the marching-tetrahedra facet normal) and
// the direction towards the eye d: a headlight, flat per tet. 1 where the gradient vanishes.
fn hapt_shade(x: array<vec4<f32>, 4>) -> f32 {
    var v = x;
    let e1 = v[1].xyz - v[0].xyz;
    let e2 = v[2].xyz - v[0].xyz;
    let e3 = v[3].xyz - v[0].xyz;
    // ∇s ∝ Σ Δs_k (e_{k+1} × e_{k+2}) / det; the sign of det does not matter for |n · d|.
    let g = (v[1].w - v[0].w) * cross(e2, e3) + (v[2].w - v[0].w) * cross(e3, e1)
        + (v[3].w - v[0].w) * cross(e1, e2);
    let len = length(g);
    if !(len > 0.0) || !(len < 3.0e38) {
        return 1.0;
    }
    return abs(dot(g / len, view.to_eye.xyz));
}

fn hapt_unused() -> HaptVarying {
    let u = volume_unused();
    return HaptVarying(u.pos, u.a, u.b, 0.0);
}

// Vertex `vi` (0..12) of the fan of the tet with vertices x[k] = (centred xyz, s): triangle
// vi / 3 is (thick, fan(k), fan(k + 1)) of its table entry (PTINT §3.1, HAPT §3); triangles past
// the fan's count and tets that draw nothing are degenerate.
fn hapt_fan_vertex(vi: u32, x: array<vec4<f32>, 4>) -> HaptVarying {
    var v = x;
    let s0 = min(min(v[0].w, v[1].w), min(v[2].w, v[3].w));
    let s1 = max(max(v[0].w, v[1].w), max(v[2].w, v[3].w));
    if !hapt_visible(s0, s1) {
        return hapt_unused();
    }
    var pv: array<PtVertex, 4>;
    for (var k = 0u; k < 4u; k++) {
        let p = view_project(v[k].xyz);
        pv[k] = PtVertex(vec2<i32>(view_snap(p.x), view_snap(p.y)), p.z, v[k].w, v[k].xyz);
    }
    let th = pt_classify(pv, view.persp != 0u, view.inv_l);
    let tri = vi / 3u;
    let corner = vi % 3u;
    if tri >= pt_ntri(th.entry) {
        return hapt_unused();
    }
    // All three corners decide alike, so a too-thin triangle is dropped whole.
    if pt_fan_too_thin(th.thick, pv[pt_fan(th.entry, tri)].q, pv[pt_fan(th.entry, tri + 1u)].q) {
        return hapt_unused();
    }
    var shade = 1.0;
    if (hp.mode & 2u) != 0u {
        shade = hapt_shade(x);
    }
    if corner == 0u {
        let at = volume_thick_attr(th.sf, th.sb, th.zf, th.zb, th.l);
        return HaptVarying(view_clip(th.thick), at.a, at.b, shade);
    }
    let k = pt_fan(th.entry, tri + corner - 1u);
    let pix = vec2<f32>(pv[k].q) * (1.0 / f32(1u << PT_SUBPIXEL_BITS));
    let at = volume_vertex_attr(pv[k].s, pv[k].z);
    return HaptVarying(view_clip(pix), at.a, at.b, shade);
}
