// view.wgsl — library: the camera of CONVENTIONS §2 as a uniform, and the projection of a point
// of the centred frame (CONVENTIONS §1) to snapped pixel coordinates (algorithms::render::pt::snap).
// Bound at @group(1) @binding(0) by every stage that needs it (Rust: gpu::shader::ViewUniform).

struct View {
    right: vec4<f32>,   // r (xyz)
    up: vec4<f32>,      // u
    to_eye: vec4<f32>,  // d; forward f = -d
    eye: vec4<f32>,     // E = 3R d (persp)
    size: vec2<f32>,    // W, H in pixels
    pixel: f32,         // p = 2R / min(W, H)
    radius: f32,        // R = L / 2
    inv_l: f32,         // 1 / L (optical units, CONVENTIONS §1)
    persp: u32,         // 0 ortho, 1 persp
    _pad: vec2<u32>,
}

@group(1) @binding(0) var<uniform> view: View;

// Largest |snapped coordinate| on the GPU: one unit inside the CPU's clamp (2^30,
// pt::MAX_PIXEL_COORD), so that differences of two coordinates fit in i32.
const PT_MAX_Q: f32 = 1073741823.0;

// Camera::project in f32: (px, py, depth). Ortho depth: from the plane at 2R in front of C;
// persp: distance along the view axis from the eye.
fn view_project(p: vec3<f32>) -> vec3<f32> {
    var x: f32;
    var y: f32;
    var depth: f32;
    if view.persp != 0u {
        let v = p - view.eye.xyz;
        let z = -dot(v, view.to_eye.xyz);
        let s = 3.0 * view.radius / z;
        x = dot(v, view.right.xyz) * s;
        y = dot(v, view.up.xyz) * s;
        depth = z;
    } else {
        x = dot(p, view.right.xyz);
        y = dot(p, view.up.xyz);
        depth = 2.0 * view.radius - dot(p, view.to_eye.xyz);
    }
    return vec3<f32>(x / view.pixel + 0.5 * view.size.x, 0.5 * view.size.y - y / view.pixel, depth);
}

// pt::snap: round to the nearest 1/2^PT_SUBPIXEL_BITS pixel, halves away from zero. The f32
// projection can land one unit away from the CPU's f64 one (see docs/gpu.md).
fn view_snap(px: f32) -> i32 {
    let v = clamp(px * f32(1u << PT_SUBPIXEL_BITS), -PT_MAX_Q, PT_MAX_Q);
    return i32(sign(v) * floor(abs(v) + 0.5));
}

// sec θ of the ray through the continuous pixel position `pix` (persp; 1 in ortho), as
// cpu_pt's per-pixel table: |ray| / (ray · f) with the ray from the eye through the point of
// the plane through C at distance 3R.
fn view_sec(pix: vec2<f32>) -> f32 {
    if view.persp == 0u {
        return 1.0;
    }
    let x = (pix.x - 0.5 * view.size.x) * view.pixel;
    let y = (0.5 * view.size.y - pix.y) * view.pixel;
    let d = 3.0 * view.radius;
    return sqrt(x * x + y * y + d * d) / d;
}

// Pixel coordinates (x right, y down) to clip space; w = 1 so that every interpolation is
// linear in screen space (the stages interpolate 1/z-weighted quantities themselves).
fn view_clip(pix: vec2<f32>) -> vec4<f32> {
    return vec4<f32>(2.0 * pix.x / view.size.x - 1.0, 1.0 - 2.0 * pix.y / view.size.y, 0.5, 1.0);
}
