// ptint_project.comp.wgsl — ptint pass 1a (PTINT §3.1): every vertex projected once to snapped
// pixel coordinates and depth. Libraries: view.wgsl, ptint.wgsl.

@group(2) @binding(0) var<storage, read> verts: array<vec4<f32>>; // centred xyz, w = s
@group(2) @binding(1) var<storage, read_write> pverts: array<PtintVert>;

@compute @workgroup_size(64)
fn cs_project(@builtin(global_invocation_id) gid: vec3<u32>,
              @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = ptint_index(gid, nwg);
    if i >= arrayLength(&verts) {
        return;
    }
    let v = verts[i];
    let p = view_project(v.xyz);
    pverts[i] = PtintVert(vec2<i32>(view_snap(p.x), view_snap(p.y)), p.z, v.w);
}
