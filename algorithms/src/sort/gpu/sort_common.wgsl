// Shared by the GPU sort stages (gpu-radix, gpu-bitonic, the key pass): element and block
// indexing over 2-D dispatches (a grid may exceed 65535 workgroups in x).

// Threads per workgroup of every sort stage.
const SORT_WG: u32 = 256u;
// Elements per radix block: each workgroup of the histogram and scatter stages owns
// SORT_WG * RADIX_ITEMS consecutive elements.
const RADIX_ITEMS: u32 = 4u;
const RADIX_BLOCK: u32 = 1024u;
// 8-bit digits, 4 passes over the 32 key bits.
const RADIX_BINS: u32 = 256u;

// The linear workgroup index of a 2-D dispatch.
fn group_index(wid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return wid.x + wid.y * nwg.x;
}
