// gpu-radix, stage 1 of a pass: the 256-bin histogram of one 8-bit digit per block, written
// digit-major (hist[d * nblocks + b]) so that one exclusive scan of the whole array gives every
// (digit, block) its first output slot.

struct RadixParams {
    n: u32,
    nblocks: u32,
    shift: u32,
    _p: u32,
}

@group(0) @binding(0) var<uniform> rp: RadixParams;
@group(0) @binding(1) var<storage, read> keys: array<u32>;
@group(0) @binding(2) var<storage, read_write> hist: array<u32>;

var<workgroup> counts: array<atomic<u32>, 256>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let b = group_index(wid, nwg);
    if (b >= rp.nblocks) {
        return;
    }
    atomicStore(&counts[lid], 0u);
    workgroupBarrier();
    for (var c = 0u; c < RADIX_ITEMS; c++) {
        let i = b * RADIX_BLOCK + c * SORT_WG + lid;
        if (i < rp.n) {
            atomicAdd(&counts[(keys[i] >> rp.shift) & 255u], 1u);
        }
    }
    workgroupBarrier();
    hist[lid * rp.nblocks + b] = atomicLoad(&counts[lid]);
}
