//! The peer protocol's messages (version 1.0, `docs/peers.md`): the requests tetbench sends and
//! the checks on the replies it gets. Bulk data travels as little-endian raw files in the
//! peer's private directory; the messages name them by absolute path.

use std::path::Path;

use glam::DVec3;
use serde_json::{json, Value};

use crate::camera::{Camera, Projection};
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::tf::TransferFunction;

/// The protocol version tetbench speaks; a peer must answer `hello` with the same major.
pub const PROTOCOL: &str = "1.0";

/// The files of a scene and of a frame, in the private directory.
pub const POSITIONS: &str = "positions.f64";
pub const CELLS: &str = "cells.u32";
pub const SCALARS: &str = "scalars.f64";
pub const IMAGE: &str = "image.f32";

/// What a peer said about itself in its `hello` reply.
#[derive(Clone, Debug, Default)]
pub struct Hello {
    pub name: String,
    pub version: String,
    pub family: Option<String>,
    pub integrators: Vec<String>,
    pub projections: Vec<String>,
    pub device: Option<String>,
}

pub fn hello_request(dir: &Path) -> Value {
    json!({
        "type": "hello",
        "protocol": PROTOCOL,
        "tetbench": env!("CARGO_PKG_VERSION"),
        "dir": dir.to_string_lossy(),
    })
}

/// Reads a `hello` reply: the protocol's major must be ours.
pub fn read_hello(peer: &str, reply: &Value) -> Result<Hello> {
    let strings = |k: &str| -> Vec<String> {
        reply[k]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|v| v.as_str().map(str::to_string))
                    .collect()
            })
            .unwrap_or_default()
    };
    let protocol = reply["protocol"].as_str().unwrap_or("");
    let major = |v: &str| v.split('.').next().unwrap_or("").to_string();
    if major(protocol) != major(PROTOCOL) {
        return Err(Error::Input(format!(
            "peer '{peer}' speaks protocol {}; this tetbench speaks {}.x",
            if protocol.is_empty() {
                "(none given)"
            } else {
                protocol
            },
            major(PROTOCOL)
        )));
    }
    let projections = match strings("projections") {
        p if p.is_empty() => vec!["ortho".to_string(), "persp".to_string()],
        p => p,
    };
    Ok(Hello {
        name: reply["name"].as_str().unwrap_or(peer).to_string(),
        version: reply["version"].as_str().unwrap_or("").to_string(),
        family: reply["family"].as_str().map(str::to_string),
        integrators: strings("integrators"),
        projections,
        device: reply["device"].as_str().map(str::to_string),
    })
}

/// Writes the scene's files into `dir` and returns the `prepare` request: positions centred on
/// the bounding box (CONVENTIONS §1), every tet as it is, scalars as the transfer function's `s`.
pub fn prepare_request(
    dir: &Path,
    mesh: &Mesh,
    tf: &TransferFunction,
    integrator: &str,
    params: &[(String, String)],
) -> Result<Value> {
    let c = mesh.bbox().center();
    let mut positions = Vec::with_capacity(mesh.num_vertices() * 24);
    for p in mesh.positions() {
        for x in (*p - c).to_array() {
            positions.extend_from_slice(&x.to_le_bytes());
        }
    }
    let mut cells = Vec::with_capacity(mesh.num_tets() * 16);
    for t in mesh.tets() {
        for &i in t {
            cells.extend_from_slice(&i.to_le_bytes());
        }
    }
    let map = tf.scalar_map(mesh.scalar_range());
    let mut scalars = Vec::with_capacity(mesh.num_vertices() * 8);
    for &v in mesh.scalars() {
        scalars.extend_from_slice(&map.s(v).to_le_bytes());
    }
    let write = |name: &str, bytes: &[u8]| -> Result<String> {
        let p = dir.join(name);
        std::fs::write(&p, bytes).map_err(|e| Error::io(&p, e))?;
        Ok(p.to_string_lossy().into_owned())
    };
    let bb = mesh.bbox();
    let v = |p: DVec3| [p.x, p.y, p.z];
    let points: Vec<Value> = tf
        .points
        .iter()
        .map(|p| json!({"s": p.s, "rgb": p.rgb, "tau": p.tau}))
        .collect();
    let params: serde_json::Map<String, Value> = params
        .iter()
        .map(|(k, v)| (k.clone(), Value::String(v.clone())))
        .collect();
    Ok(json!({
        "type": "prepare",
        "integrator": integrator,
        "params": params,
        "mesh": {
            "vertices": mesh.num_vertices(),
            "tets": mesh.num_tets(),
            "diagonal": mesh.diagonal(),
            "bbox_min": v(bb.min - c),
            "bbox_max": v(bb.max - c),
            "files": {
                "positions": write(POSITIONS, &positions)?,
                "cells": write(CELLS, &cells)?,
                "scalars": write(SCALARS, &scalars)?,
            },
        },
        "tf": {"points": points},
    }))
}

/// The near and far planes: around the bounding sphere, which the eye sees from `2R` (ortho)
/// or `3R` (persp).
fn near_far(cam: &Camera) -> (f64, f64) {
    let r = cam.radius;
    match cam.projection {
        Projection::Ortho => (0.5 * r, 3.5 * r),
        Projection::Persp => (1.5 * r, 4.5 * r),
    }
}

/// The eye in the centred frame: `2R·d` (ortho; any point on the view axis would do) or
/// `3R·d` (persp, CONVENTIONS §2).
pub fn eye(cam: &Camera) -> DVec3 {
    match cam.projection {
        Projection::Ortho => 2.0 * cam.radius * cam.to_eye,
        Projection::Persp => cam.eye(),
    }
}

/// The view matrix (world to camera, the camera looking down −z) and the projection matrix
/// (camera to OpenGL clip space, y up), row-major. A pixel centre (i, j) lands at
/// NDC `x = 2(i + ½)/W − 1`, `y = 1 − 2(j + ½)/H`.
pub fn matrices(cam: &Camera) -> ([f64; 16], [f64; 16]) {
    let e = eye(cam);
    let (r, u, f) = (cam.right, cam.up, cam.forward);
    let view = [
        r.x,
        r.y,
        r.z,
        -r.dot(e),
        u.x,
        u.y,
        u.z,
        -u.dot(e),
        -f.x,
        -f.y,
        -f.z,
        f.dot(e),
        0.0,
        0.0,
        0.0,
        1.0,
    ];
    let a = 0.5 * cam.width as f64 * cam.pixel;
    let b = 0.5 * cam.height as f64 * cam.pixel;
    let (n, fa) = near_far(cam);
    let proj = match cam.projection {
        Projection::Ortho => [
            1.0 / a,
            0.0,
            0.0,
            0.0,
            0.0,
            1.0 / b,
            0.0,
            0.0,
            0.0,
            0.0,
            -2.0 / (fa - n),
            -(fa + n) / (fa - n),
            0.0,
            0.0,
            0.0,
            1.0,
        ],
        Projection::Persp => {
            // The image's half-size a × b lies on the plane through the target, 3R away.
            let d = 3.0 * cam.radius;
            [
                d / a,
                0.0,
                0.0,
                0.0,
                0.0,
                d / b,
                0.0,
                0.0,
                0.0,
                0.0,
                -(fa + n) / (fa - n),
                -2.0 * fa * n / (fa - n),
                0.0,
                0.0,
                -1.0,
                0.0,
            ]
        }
    };
    (view, proj)
}

/// The `render` request: the camera of CONVENTIONS §2 in the centred frame, the image size and
/// the file the peer writes the image to.
pub fn render_request(cam: &Camera, image: &Path) -> Value {
    let v = |p: DVec3| [p.x, p.y, p.z];
    let half_h = 0.5 * cam.height as f64 * cam.pixel;
    let fov = match cam.projection {
        Projection::Ortho => Value::Null,
        Projection::Persp => json!((2.0 * (half_h / (3.0 * cam.radius)).atan()).to_degrees()),
    };
    let (near, far) = near_far(cam);
    let (view, proj) = matrices(cam);
    json!({
        "type": "render",
        "width": cam.width,
        "height": cam.height,
        "projection": cam.projection.name(),
        "eye": v(eye(cam)),
        "target": [0.0, 0.0, 0.0],
        "up": v(cam.up),
        "right": v(cam.right),
        "forward": v(cam.forward),
        "radius": cam.radius,
        "pixel_size": cam.pixel,
        "ortho_scale": half_h,
        "fov_y_deg": fov,
        "near": near,
        "far": far,
        "view_matrix": view,
        "projection_matrix": proj,
        "image": image.to_string_lossy(),
    })
}

/// A non-negative finite number under `key`, if the reply has one.
pub fn number(reply: &Value, key: &str) -> Result<Option<f64>> {
    match &reply[key] {
        Value::Null => Ok(None),
        Value::Number(n) => match n.as_f64() {
            Some(x) if x.is_finite() && x >= 0.0 => Ok(Some(x)),
            _ => Err(Error::Input(format!(
                "`{key}` must be a finite number >= 0, got {n}"
            ))),
        },
        other => Err(Error::Input(format!(
            "`{key}` must be a number, got {other}"
        ))),
    }
}

/// The reply's `counters` object as (name, value) pairs (at most 64; non-numbers refused).
pub fn counters(reply: &Value) -> Result<Vec<(String, f64)>> {
    match &reply["counters"] {
        Value::Null => Ok(Vec::new()),
        Value::Object(m) if m.len() <= 64 => m
            .iter()
            .map(|(k, v)| match v.as_f64() {
                Some(x) if x.is_finite() && k.len() <= 64 => Ok((k.clone(), x)),
                _ => Err(Error::Input(format!(
                    "counter `{k}` must be a finite number with a short name"
                ))),
            })
            .collect(),
        _ => Err(Error::Input(
            "`counters` must be an object of at most 64 numbers".into(),
        )),
    }
}

/// Reads the peer's image file: exactly `W·H` RGBA f32 pixels, row 0 at the top, straight
/// into the image's pixels.
pub fn read_image(path: &Path, w: u32, h: u32) -> Result<crate::image::Image> {
    use std::io::Read;
    let want = w as u64 * h as u64 * 16;
    // A regular file only: a pipe left in its place must not block the frame past its timeout.
    let mut f =
        crate::io::files::open_input(path).map_err(|e| Error::Input(format!("no image ({e})")))?;
    let len = f.metadata().map_err(|e| Error::io(path, e))?.len();
    if len != want {
        return Err(Error::Input(format!(
            "image of {len} bytes, expected {w}×{h} RGBA f32 = {want} bytes"
        )));
    }
    let mut image = crate::image::Image::new(w, h);
    let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut image.pixels);
    f.read_exact(bytes).map_err(|e| Error::io(path, e))?;
    #[cfg(target_endian = "big")]
    for px in image.pixels.iter_mut() {
        for c in px.iter_mut() {
            *c = f32::from_bits(u32::from_le(c.to_bits()));
        }
    }
    Ok(image)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::View;

    /// The matrices put each pixel centre's ray where §2 says: the point of the plane through
    /// the target at pixel (i, j) lands at NDC (2(i+½)/W − 1, 1 − 2(j+½)/H).
    #[test]
    fn matrices_map_pixel_centres_to_ndc() {
        let bbox = crate::mesh::Aabb {
            min: DVec3::new(-1.0, -2.0, 0.0),
            max: DVec3::new(3.0, 1.0, 0.5),
        };
        for projection in [Projection::Ortho, Projection::Persp] {
            let cam = Camera::new(&bbox, View::new(30.0, 20.0), projection, 64, 48);
            let (view, proj) = matrices(&cam);
            let mul = |m: &[f64; 16], p: [f64; 4]| -> [f64; 4] {
                let mut o = [0.0; 4];
                for (r, o) in o.iter_mut().enumerate() {
                    *o = (0..4).map(|c| m[4 * r + c] * p[c]).sum();
                }
                o
            };
            for (i, j) in [(0u32, 0u32), (63, 47), (10, 30)] {
                let (x, y) = cam.plane_xy(i as f64 + 0.5, j as f64 + 0.5);
                let p = x * cam.right + y * cam.up;
                let c = mul(&proj, mul(&view, [p.x, p.y, p.z, 1.0]));
                let ndc = (c[0] / c[3], c[1] / c[3], c[2] / c[3]);
                let want = (
                    2.0 * (i as f64 + 0.5) / 64.0 - 1.0,
                    1.0 - 2.0 * (j as f64 + 0.5) / 48.0,
                );
                assert!(
                    (ndc.0 - want.0).abs() < 1e-12,
                    "{projection:?} {ndc:?} {want:?}"
                );
                assert!(
                    (ndc.1 - want.1).abs() < 1e-12,
                    "{projection:?} {ndc:?} {want:?}"
                );
                assert!(ndc.2.abs() < 1.0, "{projection:?}: depth {}", ndc.2);
            }
        }
    }

    #[test]
    fn another_major_version_is_refused_in_one_line() {
        let e = read_hello("p", &json!({"ok": true, "protocol": "2.0"}))
            .unwrap_err()
            .to_string();
        assert_eq!(e, "peer 'p' speaks protocol 2.0; this tetbench speaks 1.x");
        let h = read_hello(
            "p",
            &json!({"ok": true, "protocol": "1.7", "integrators": ["average"]}),
        )
        .unwrap();
        assert_eq!(h.integrators, ["average"]);
        assert_eq!(h.projections, ["ortho", "persp"]);
    }
}
