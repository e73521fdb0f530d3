// ptint_fan.vert.wgsl — ptint pass 2 (PTINT §3.2): the fans of the sorted tets, by vertex
// pulling. Instance i is the i-th drawn tet back to front (`order`, built on the CPU after the
// sort); its 12 vertices are triangles k = 0..3 of the fan, (thick, fan(k), fan(k + 1)) with
// the table's fan order; triangles k ≥ ntri are degenerate, and so are triangles too thin for
// the rasterizer (pt_fan_too_thin). Feeds volume.frag.wgsl.
// Libraries: view.wgsl, classify.wgsl, volume.wgsl, ptint.wgsl.

@group(2) @binding(0) var<storage, read> pverts: array<PtintVert>;
@group(2) @binding(1) var<storage, read> tets: array<vec4<u32>>;
@group(2) @binding(2) var<storage, read> records: array<PtintRecord>;
@group(2) @binding(3) var<storage, read> order: array<u32>;

@vertex
fn vs_fan(@builtin(vertex_index) vi: u32, @builtin(instance_index) ii: u32) -> VolumeVarying {
    let t = order[ii];
    let rec = records[t];
    let entry = pt_entry(rec.case_index);
    let tri = vi / 3u;
    let corner = vi % 3u;
    if tri >= pt_ntri(entry) {
        return volume_unused();
    }
    // All three corners decide alike, so a too-thin triangle is dropped whole.
    let qa = pverts[tets[t][pt_fan(entry, tri)]].q;
    let qb = pverts[tets[t][pt_fan(entry, tri + 1u)]].q;
    if pt_fan_too_thin(rec.thick, qa, qb) {
        return volume_unused();
    }
    if corner == 0u {
        return volume_varying(rec.thick, VolumeAttr(rec.a, rec.b));
    }
    let v = tets[t][pt_fan(entry, tri + corner - 1u)];
    let pv = pverts[v];
    let pix = vec2<f32>(pv.q) * (1.0 / f32(1u << PT_SUBPIXEL_BITS));
    return volume_varying(pix, volume_vertex_attr(pv.s, pv.z));
}
