// volume.wgsl — library: what a vertex stage hands the volume fragment stage
// (volume.frag.wgsl). Needs view.wgsl.
//
// VolumeVarying: clip position with w = 1 (view_clip), and two attributes interpolated
// LINEARLY in screen space (@interpolate(linear), no perspective division):
//   ortho (view.persp = 0): a = (s_f, s_b, l, 0), b unused. At the thick vertex: its s_f, s_b
//     and l; at a silhouette vertex: (s, s, 0, 0). Exact: in ortho these are linear in screen
//     space over each fan triangle (cpu_pt module docs).
//   persp (view.persp = 1): a = (1/z_f, 1/z_b, 1/z_f − 1/z_b, s_f/z_f), b = s_b/z_b, z the depth
//     along the view axis; at a silhouette vertex (1/z, 1/z, 0, s/z), b = s/z. These are linear
//     in screen space; the fragment stage recovers l = (1/z_f − 1/z_b)/(1/z_f · 1/z_b)·sec θ/L.
// Build them with volume_thick_attr / volume_vertex_attr and volume_varying.

struct VolumeVarying {
    @builtin(position) pos: vec4<f32>,
    @location(0) @interpolate(linear) a: vec4<f32>,
    @location(1) @interpolate(linear) b: f32,
}

struct VolumeAttr {
    a: vec4<f32>,
    b: f32,
}

// The thick vertex's attributes from its classification (pt_classify's s_f, s_b, z_f, z_b, l).
fn volume_thick_attr(sf: f32, sb: f32, zf: f32, zb: f32, l: f32) -> VolumeAttr {
    if view.persp != 0u {
        let qf = 1.0 / zf;
        let qb = 1.0 / zb;
        // 1/z_f − 1/z_b as (z_b − z_f)·qf·qb: no cancellation (cpu_pt).
        let dq = max((zb - zf) * qf * qb, 0.0);
        return VolumeAttr(vec4<f32>(qf, qb, dq, sf * qf), sb * qb);
    }
    return VolumeAttr(vec4<f32>(sf, sb, l, 0.0), 0.0);
}

// A silhouette vertex's attributes (thin: l = 0, s_f = s_b = s) from its scalar and depth.
fn volume_vertex_attr(s: f32, z: f32) -> VolumeAttr {
    if view.persp != 0u {
        let qz = 1.0 / z;
        return VolumeAttr(vec4<f32>(qz, qz, 0.0, s * qz), s * qz);
    }
    return VolumeAttr(vec4<f32>(s, s, 0.0, 0.0), 0.0);
}

// The varying at pixel position `pix` (x right, y down, pixels).
fn volume_varying(pix: vec2<f32>, at: VolumeAttr) -> VolumeVarying {
    return VolumeVarying(view_clip(pix), at.a, at.b);
}

// A vertex of an unused (degenerate) triangle: all three at one point outside the viewport.
fn volume_unused() -> VolumeVarying {
    return VolumeVarying(vec4<f32>(-2.0, -2.0, 0.5, 1.0), vec4<f32>(0.0), 0.0);
}

// The pixel's ray segment (s_f, s_b, l) from the interpolated attributes (a, b) at the fragment
// position `pos` (the pixel centre (i + 0.5, j + 0.5), as cpu_pt's sec θ table).
fn volume_ray(pos: vec2<f32>, a: vec4<f32>, b: f32) -> vec3<f32> {
    if view.persp != 0u {
        let qf = a.x;
        let qb = a.y;
        let l = a.z / (qf * qb) * view_sec(pos) * view.inv_l;
        return vec3<f32>(a.w / qf, b / qb, l);
    }
    return vec3<f32>(a.x, a.y, a.z);
}
