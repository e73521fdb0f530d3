// gpu-radix, stage 3 of a pass: the stable scatter. A block is read in chunks of 256 in
// element order; inside a chunk, the rank of an element among the earlier elements with the same
// digit comes from one 256-bit mask per digit (bit t set when thread t has that digit): the
// popcount of the mask below the thread's bit. Chunks are done in order and each digit's running
// slot advances by the chunk's count, so equal digits keep their input order — the sort is
// stable, and LSD passes over stable scatters sort by the whole key with ties in index order.

struct RadixParams {
    n: u32,
    nblocks: u32,
    shift: u32,
    _p: u32,
}

@group(0) @binding(0) var<uniform> rp: RadixParams;
@group(0) @binding(1) var<storage, read> keys_in: array<u32>;
@group(0) @binding(2) var<storage, read> vals_in: array<u32>;
@group(0) @binding(3) var<storage, read_write> keys_out: array<u32>;
@group(0) @binding(4) var<storage, read_write> vals_out: array<u32>;
@group(0) @binding(5) var<storage, read> hist: array<u32>;

// 256 digits x 8 words of 32 bits.
var<workgroup> masks: array<atomic<u32>, 2048>;
var<workgroup> run: array<u32, 256>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let b = group_index(wid, nwg);
    if (b >= rp.nblocks) {
        return;
    }
    run[lid] = hist[lid * rp.nblocks + b];
    let word = lid >> 5u;
    let bit = 1u << (lid & 31u);
    for (var c = 0u; c < RADIX_ITEMS; c++) {
        for (var w = 0u; w < 8u; w++) {
            atomicStore(&masks[lid * 8u + w], 0u);
        }
        workgroupBarrier();
        let i = b * RADIX_BLOCK + c * SORT_WG + lid;
        let valid = i < rp.n;
        var k = 0u;
        var d = 0u;
        if (valid) {
            k = keys_in[i];
            d = (k >> rp.shift) & 255u;
            atomicOr(&masks[d * 8u + word], bit);
        }
        workgroupBarrier();
        if (valid) {
            var rank = countOneBits(atomicLoad(&masks[d * 8u + word]) & (bit - 1u));
            for (var w = 0u; w < word; w++) {
                rank += countOneBits(atomicLoad(&masks[d * 8u + w]));
            }
            let dst = run[d] + rank;
            keys_out[dst] = k;
            vals_out[dst] = vals_in[i];
        }
        workgroupBarrier();
        var cnt = 0u;
        for (var w = 0u; w < 8u; w++) {
            cnt += countOneBits(atomicLoad(&masks[lid * 8u + w]));
        }
        run[lid] += cnt;
        workgroupBarrier();
    }
}
