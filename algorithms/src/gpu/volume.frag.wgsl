// volume.frag.wgsl — fragment stage of the volume: per fragment, the ray segment through the
// tet (s_f, s_b, l) from the interpolated attributes, integrated by `segment` (optics.wgsl),
// output premultiplied. With blending One, OneMinusSrcAlpha (colour and alpha) and the tets
// drawn back to front this is "over": I ← I_seg + (1 − α_seg)·I (CONVENTIONS §4).
// Libraries: view.wgsl, volume.wgsl (VolumeVarying: what a vertex stage must feed it, and the
// helpers that build it), optics.wgsl.

@fragment
fn fs_volume(in: VolumeVarying) -> @location(0) vec4<f32> {
    let r = volume_ray(in.pos.xy, in.a, in.b);
    // l ≤ 0 (and NaN) gives a zero segment: the blend leaves the pixel as it was.
    return segment(r.x, r.y, r.z);
}
