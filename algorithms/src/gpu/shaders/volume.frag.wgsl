// volume.frag.wgsl — fragment stage of the volume: per fragment, the ray segment through the
// tet (s_f, s_b, l) from the interpolated attributes, integrated by `segment` (optics.wgsl),
// output premultiplied. With blending One, OneMinusSrcAlpha (colour and alpha) and the tets
// drawn back to front this is "over": I ← I_seg + (1 − α_seg)·I (CONVENTIONS §4).
// Libraries: view.wgsl, volume.wgsl (VolumeVarying: what a vertex stage must feed it, and the
// helpers that build it), optics.wgsl.

@fragment
fn fs_volume(in: VolumeVarying) -> @location(0) vec4<f32> {
    var sf: f32;
    var sb: f32;
    var l: f32;
    if view.persp != 0u {
        let qf = in.a.x;
        let qb = in.a.y;
        // in.pos.xy is the pixel centre (i + 0.5, j + 0.5), as cpu_pt's sec θ table.
        l = in.a.z / (qf * qb) * view_sec(in.pos.xy) * view.inv_l;
        sf = in.a.w / qf;
        sb = in.b / qb;
    } else {
        sf = in.a.x;
        sb = in.a.y;
        l = in.a.z;
    }
    // l ≤ 0 (and NaN) gives a zero segment: the blend leaves the pixel as it was.
    return segment(sf, sb, l);
}
