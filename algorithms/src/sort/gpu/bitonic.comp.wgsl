// gpu-bitonic: one compare-exchange step (k, j) of Batcher's bitonic sorting network over
// (key, value) pairs padded to a power of two with (0xffffffff, 0xffffffff), which sort last.
// Pairs compare by key then value; the values (tet indices) are distinct, so the result is the
// one ascending order of the pairs — the same as the stable radix sort's.

struct BitonicParams {
    k: u32,
    j: u32,
    _p0: u32,
    _p1: u32,
}

@group(0) @binding(0) var<uniform> bp: BitonicParams;
@group(0) @binding(1) var<storage, read_write> keys: array<u32>;
@group(0) @binding(2) var<storage, read_write> vals: array<u32>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = group_index(wid, nwg) * SORT_WG + lid;
    let p = i ^ bp.j;
    if (p <= i || p >= arrayLength(&keys)) {
        return;
    }
    let ki = keys[i];
    let kp = keys[p];
    let vi = vals[i];
    let vp = vals[p];
    // Whether (ki, vi) > (kp, vp).
    let greater = ki > kp || (ki == kp && vi > vp);
    let ascending = (i & bp.k) == 0u;
    if (greater == ascending) {
        keys[i] = kp;
        keys[p] = ki;
        vals[i] = vp;
        vals[p] = vi;
    }
}
