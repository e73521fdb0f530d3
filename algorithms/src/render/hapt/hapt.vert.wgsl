// hapt.vert.wgsl — HAPT §3, the single pass: one instance per tet in sorted order (instance i
// reads order[i], written on the GPU by the sort, with no readback), 12 vertices = up to 4 fan
// triangles built here from the tet and vertex buffers by the shared classification (vertex
// pulling: WebGPU has no geometry shaders). Libraries: view.wgsl, classify.wgsl, volume.wgsl,
// hapt.wgsl.

@vertex
fn vs_hapt(@builtin(vertex_index) vi: u32, @builtin(instance_index) ii: u32) -> HaptVarying {
    let t = order[ii];
    let tet = tets[t];
    var x: array<vec4<f32>, 4>;
    for (var k = 0u; k < 4u; k++) {
        x[k] = vec4<f32>(verts[tet[k]].xyz, scal[tet[k]]);
    }
    return hapt_fan_vertex(vi, x);
}

// Streaming mode: instance i is the i-th tet of the uploaded chunk (already in sorted order).
@vertex
fn vs_hapt_stream(@builtin(vertex_index) vi: u32, @builtin(instance_index) ii: u32)
    -> HaptVarying {
    var x: array<vec4<f32>, 4>;
    for (var k = 0u; k < 4u; k++) {
        x[k] = chunk[4u * ii + k];
    }
    return hapt_fan_vertex(vi, x);
}
