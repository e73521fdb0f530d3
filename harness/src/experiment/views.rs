//! Views of an experiment: named `AZ,EL`, Fibonacci views over the sphere, a rotation path.

use super::*;

pub(super) fn expand_views(v: &ViewsSpec) -> Result<Vec<ViewItem>> {
    bound("views.named", v.named.len(), MAX_VIEWS)?;
    bound("views.fibonacci", v.fibonacci, MAX_VIEWS)?;
    if let Some(r) = &v.rotate {
        bound("views.rotate.frames", r.frames, MAX_VIEWS)?;
    }
    let mut out = Vec::new();
    for (i, s) in v.named.iter().enumerate() {
        let view = View::parse(s).map_err(|e| key_err(format!("views.named[{i}]"), e))?;
        out.push(ViewItem {
            id: format!("named:{i}"),
            view,
        });
    }
    for (k, view) in algorithms::camera::fibonacci_views(v.fibonacci)
        .into_iter()
        .enumerate()
    {
        out.push(ViewItem {
            id: format!("fib:{k}"),
            view,
        });
    }
    if let Some(r) = &v.rotate {
        if r.frames == 0 {
            return Err(Error::Input(
                "key `views.rotate.frames`: must be at least 1".into(),
            ));
        }
        let axis = match r.axis.as_str() {
            "x" => DVec3::X,
            "y" => DVec3::Y,
            "z" => DVec3::Z,
            a => {
                return Err(Error::Input(format!(
                    "key `views.rotate.axis`: '{a}': expected x, y or z"
                )))
            }
        };
        let start = match &r.start {
            Some(s) => View::parse(s).map_err(|e| key_err("views.rotate.start", e))?,
            None if r.axis == "z" => View::new(90.0, 0.0),
            None => View::new(0.0, 0.0),
        };
        let d0 = start.to_eye();
        if d0.cross(axis).length() < 1e-6 {
            return Err(Error::Input(
                "key `views.rotate.start`: the start view looks along the rotation axis".into(),
            ));
        }
        for k in 0..r.frames {
            let ang = -(k as f64) * std::f64::consts::TAU / r.frames as f64;
            let d = rotate(d0, axis, ang);
            let el = d.y.clamp(-1.0, 1.0).asin().to_degrees();
            let mut az = d.x.atan2(d.z).to_degrees();
            if az < 0.0 {
                az += 360.0;
            }
            out.push(ViewItem {
                id: format!("rot:{k}"),
                view: View::new(round6(az), round6(el)),
            });
        }
    }
    if out.is_empty() {
        out.push(ViewItem {
            id: "named:0".into(),
            view: View::new(0.0, 0.0),
        });
    }
    Ok(out)
}

fn round6(v: f64) -> f64 {
    let r = (v * 1e6).round() / 1e6;
    if r == 0.0 {
        0.0
    } else {
        r
    }
}

/// Rodrigues' rotation of `v` about unit `k` by `a` radians. The camera turns by −a when the
/// model turns by a.
fn rotate(v: DVec3, k: DVec3, a: f64) -> DVec3 {
    v * a.cos() + k.cross(v) * a.sin() + k * k.dot(v) * (1.0 - a.cos())
}
