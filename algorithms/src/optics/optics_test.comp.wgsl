// optics_test.comp.wgsl — compute stage used by the tests only: `segment` (optics.wgsl) on a
// list of (s_f, s_b, l) triples, to compare with FastIntegrator::segment.
// Libraries: optics.wgsl.

@group(2) @binding(0) var<storage, read> test_in: array<vec4<f32>>;
@group(2) @binding(1) var<storage, read_write> test_out: array<vec4<f32>>;

@compute @workgroup_size(64)
fn cs_optics_test(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&test_in) {
        return;
    }
    let x = test_in[i];
    test_out[i] = segment(x.x, x.y, x.z);
}
