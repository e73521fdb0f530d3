// hapt_iso.frag.wgsl — HAPT §3 iso-surfaces on the fly, composited with the volume (modes
// `iso` and `dvr+iso`). The pixel's ray segment through the tet, (s_f, s_b, l) as in
// volume.frag.wgsl, is split where the linear field crosses each iso value (at fraction
// u = (v − s_f)/(s_b − s_f)): that point lies on the marching-tetrahedra polygon of the tet for
// that value, so the surface drawn is exactly the marching-tetrahedra surface. Front to back
// inside the tet: volume piece (mode dvr+iso), the flat-shaded iso-surface (TF colour at the
// value times the tet's headlight factor, opacity iso_alpha), next piece, …; the result is
// premultiplied and blended "over" like the volume. Libraries: view.wgsl, volume.wgsl,
// optics.wgsl, classify.wgsl, hapt.wgsl.

@fragment
fn fs_hapt_iso(in: HaptVarying) -> @location(0) vec4<f32> {
    let r = volume_ray(in.pos.xy, in.a, in.b);
    let sf = r.x;
    let sb = r.y;
    let l = r.z;
    let dvr = (hp.mode & 1u) != 0u;
    // Crossings as fractions along the segment, sorted (at most 4).
    var u = vec4<f32>(2.0);
    var idx = vec4<u32>(0u);
    var n = 0u;
    for (var i = 0u; i < hp.iso_n; i++) {
        let v = hp.iso_s[i];
        if (v - sf) * (v - sb) <= 0.0 && sf != sb {
            var f = clamp((v - sf) / (sb - sf), 0.0, 1.0);
            var j = n;
            while j > 0u && u[j - 1u] > f {
                u[j] = u[j - 1u];
                idx[j] = idx[j - 1u];
                j--;
            }
            u[j] = f;
            idx[j] = i;
            n++;
        }
    }
    var acc = vec3<f32>(0.0);
    var trans = 1.0;
    var u0 = 0.0;
    var s0 = sf;
    for (var c = 0u; c < n; c++) {
        let v = hp.iso_s[idx[c]];
        if dvr {
            let seg = segment(s0, v, (u[c] - u0) * l);
            acc += trans * seg.rgb;
            trans *= 1.0 - seg.a;
        }
        let col = hp.iso_rgba[idx[c]];
        acc += trans * col.a * in.shade * col.rgb;
        trans *= 1.0 - col.a;
        u0 = u[c];
        s0 = v;
    }
    if dvr {
        let seg = segment(s0, sb, (1.0 - u0) * l);
        acc += trans * seg.rgb;
        trans *= 1.0 - seg.a;
    }
    return vec4<f32>(acc, 1.0 - trans);
}
