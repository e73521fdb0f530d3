// Key stage of the GPU sorts (HAPT §3: centroids and keys on the GPU). One thread per tet:
// key = c · forward (ortho) or |c − eye|² (persp) from the centred f32 centroid, exactly the
// f32 expression of the CPU centroid sorts (sort/mod.rs, KeyFn), or (mode 2) a key read as is.
// The key becomes u32 bits whose ascending order is the key's descending IEEE total order
// (+0.0 before −0.0, farther first; sort/mod.rs desc_bits), and the value is the tet index.

struct KeyParams {
    // xyz: forward (mode 0) or eye (mode 1); w unused.
    v: vec4<f32>,
    n: u32,
    // 0 ortho, 1 persp, 2 raw keys in `cent`.
    mode: u32,
    _p0: u32,
    _p1: u32,
}

@group(0) @binding(0) var<uniform> kp: KeyParams;
@group(0) @binding(1) var<storage, read> cent: array<f32>;
@group(0) @binding(2) var<storage, read_write> keys: array<u32>;
@group(0) @binding(3) var<storage, read_write> vals: array<u32>;

fn desc_bits(k: f32) -> u32 {
    let u = bitcast<u32>(k);
    let asc = select(u | 0x80000000u, ~u, (u & 0x80000000u) != 0u);
    return ~asc;
}

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = group_index(wid, nwg) * SORT_WG + lid;
    if (i >= kp.n) {
        return;
    }
    var k: f32;
    if (kp.mode == 2u) {
        k = cent[i];
    } else {
        let c = vec3<f32>(cent[3u * i], cent[3u * i + 1u], cent[3u * i + 2u]);
        if (kp.mode == 0u) {
            k = c.x * kp.v.x + c.y * kp.v.y + c.z * kp.v.z;
        } else {
            let d = c - kp.v.xyz;
            k = d.x * d.x + d.y * d.y + d.z * d.z;
        }
    }
    keys[i] = desc_bits(k);
    vals[i] = i;
}
