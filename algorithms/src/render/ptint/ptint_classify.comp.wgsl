// ptint_classify.comp.wgsl — ptint pass 1b (PTINT §3.1): every tet classified by the ternary
// truth table (pt_classify): its record (thick vertex, s_f, s_b, l or the 1/z-weighted
// attributes, table index → fan order and count) for pass 2, and its sort key (centroid depth,
// table index) read back by the CPU. Libraries: view.wgsl, classify.wgsl, volume.wgsl,
// ptint.wgsl.

@group(2) @binding(0) var<storage, read> verts: array<vec4<f32>>;
@group(2) @binding(1) var<storage, read> pverts: array<PtintVert>;
@group(2) @binding(2) var<storage, read> tets: array<vec4<u32>>;
@group(2) @binding(3) var<storage, read_write> records: array<PtintRecord>;
// (centroid depth bits, table index): the key of sort/mod.rs — ortho c · f, persp |c − E|²;
// larger is farther.
@group(2) @binding(4) var<storage, read_write> keys: array<vec2<u32>>;

@compute @workgroup_size(64)
fn cs_classify(@builtin(global_invocation_id) gid: vec3<u32>,
               @builtin(num_workgroups) nwg: vec3<u32>) {
    let t = ptint_index(gid, nwg);
    if t >= arrayLength(&tets) {
        return;
    }
    let tet = tets[t];
    var v: array<PtVertex, 4>;
    var c = vec3<f32>(0.0);
    for (var k = 0u; k < 4u; k++) {
        let x = verts[tet[k]];
        let pv = pverts[tet[k]];
        v[k] = PtVertex(pv.q, pv.z, x.w, x.xyz);
        c += x.xyz;
    }
    c *= 0.25;
    let th = pt_classify(v, view.persp != 0u, view.inv_l);
    let at = volume_thick_attr(th.sf, th.sb, th.zf, th.zb, th.l);
    records[t] = PtintRecord(at.a, th.thick, at.b, th.case_index);
    var key: f32;
    if view.persp != 0u {
        let d = c - view.eye.xyz;
        key = dot(d, d);
    } else {
        key = -dot(c, view.to_eye.xyz);
    }
    keys[t] = vec2<u32>(bitcast<u32>(key), th.case_index);
}
