// ptint.wgsl — library: the buffers' element types shared by ptint's stages (PTINT §3).

// A projected vertex (pass 1a): snapped pixel coordinates, depth, TF coordinate.
struct PtintVert {
    q: vec2<i32>,
    z: f32,
    s: f32,
}

// The classification record of a tet (pass 1b), 32 bytes: the thick vertex's VolumeAttr
// (a, b), its position in pixels, and the table index (PT_TABLE; fan order and count).
struct PtintRecord {
    a: vec4<f32>,
    thick: vec2<f32>,
    b: f32,
    case_index: u32,
}

// Flattened invocation index of a 2-D dispatch of 64-wide workgroups (meshes beyond
// 65535 × 64 elements need a second dimension).
fn ptint_index(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.y * nwg.x * 64u + gid.x;
}
