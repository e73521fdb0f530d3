// gpu-radix, stage 2 of a pass: exclusive prefix sum of the digit-major histogram, in one
// workgroup: thread d totals digit d over the blocks, the 256 totals are scanned, then thread d
// rewrites its row as running offsets.

struct RadixParams {
    n: u32,
    nblocks: u32,
    shift: u32,
    _p: u32,
}

@group(0) @binding(0) var<uniform> rp: RadixParams;
@group(0) @binding(1) var<storage, read_write> hist: array<u32>;

var<workgroup> totals: array<u32, 256>;

@compute @workgroup_size(256)
fn main(@builtin(local_invocation_index) lid: u32) {
    let row = lid * rp.nblocks;
    var sum = 0u;
    for (var b = 0u; b < rp.nblocks; b++) {
        sum += hist[row + b];
    }
    totals[lid] = sum;
    workgroupBarrier();
    // Hillis–Steele inclusive scan of the 256 totals.
    for (var off = 1u; off < RADIX_BINS; off = off << 1u) {
        var add = 0u;
        if (lid >= off) {
            add = totals[lid - off];
        }
        workgroupBarrier();
        totals[lid] += add;
        workgroupBarrier();
    }
    var run = totals[lid] - sum;
    for (var b = 0u; b < rp.nblocks; b++) {
        let c = hist[row + b];
        hist[row + b] = run;
        run += c;
    }
}
