//! Transfer functions (CONVENTIONS §3): colour (linear RGB) and extinction `tau` piecewise linear
//! in the normalised scalar `s`, constant beyond the end points.

use std::path::Path;

use serde::Deserialize;

use crate::error::{Error, Result};

/// One control point.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TfPoint {
    pub s: f64,
    pub rgb: [f64; 3],
    pub tau: f64,
}

/// A validated transfer function.
#[derive(Clone, Debug, PartialEq)]
pub struct TransferFunction {
    pub name: String,
    /// Scalar range mapped to s ∈ [0, 1]; `None` means the mesh's own range.
    pub range: Option<[f64; 2]>,
    pub points: Vec<TfPoint>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TfFile {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    range: Option<[f64; 2]>,
    points: Vec<TfPoint>,
}

/// Maps a raw scalar value to the transfer function's `s`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScalarMap {
    pub min: f64,
    /// 1 / (max − min), or 0 for a constant field (every scalar maps to s = 0).
    pub inv_span: f64,
}

impl ScalarMap {
    #[inline]
    pub fn s(&self, v: f64) -> f64 {
        (v - self.min) * self.inv_span
    }
}

/// Names of the built-in presets (documented in `docs/transfer-functions.md`).
pub const PRESETS: [&str; 3] = ["default", "cool-warm", "xray"];

impl TransferFunction {
    /// Most control points a transfer function may have: 8 per cell of `preint`'s 128-node
    /// table (`optics::PreintTable`), a quarter of the 4096 samples of the other
    /// tables (`optics::fast::TF_SAMPLES`); finer detail is lost to all but `exact`. The
    /// bound keeps `preint`'s table build (O(table nodes · points)) within seconds; 10⁵–10⁶
    /// points took minutes to hours.
    pub const MAX_POINTS: usize = 1024;
    /// The table domains are clamped to `[−S_LIMIT, S_LIMIT]` (see [`table_domain`](Self::table_domain)).
    pub const S_LIMIT: f64 = 1e30;

    /// Parses the JSON of §3; `source` names the file in messages.
    pub fn from_json(text: &str, source: &str) -> Result<TransferFunction> {
        // A UTF-8 byte-order mark is accepted (and ignored), as in every reader.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let f: TfFile = serde_json::from_str(text).map_err(|e| {
            // serde quotes the offending key verbatim, newlines included: keep one line.
            let msg: String = e
                .to_string()
                .chars()
                .flat_map(|c| {
                    let esc: Vec<char> = if c.is_control() {
                        c.escape_default().collect()
                    } else {
                        vec![c]
                    };
                    esc
                })
                .collect();
            Error::input(source, format!("not a transfer function: {msg}"))
        })?;
        let tf = TransferFunction {
            name: f.name.unwrap_or_else(|| source.to_string()),
            range: f.range,
            points: f.points,
        };
        tf.validate(source)?;
        Ok(tf)
    }

    /// Loads a preset by name, or else a JSON file by path.
    pub fn load(name_or_path: &str) -> Result<TransferFunction> {
        if let Some(tf) = Self::preset(name_or_path) {
            return Ok(tf);
        }
        let path = Path::new(name_or_path);
        if !path.exists() {
            return Err(Error::Input(format!(
                "{name_or_path}: no such transfer-function file or preset (presets: {})",
                PRESETS.join(", ")
            )));
        }
        let text = crate::io::read_input_string(path, crate::io::files::MAX_SETTINGS_BYTES)?;
        Self::from_json(&text, name_or_path)
    }

    pub fn validate(&self, source: &str) -> Result<()> {
        if self.points.is_empty() {
            return Err(Error::input(source, "\"points\" is empty"));
        }
        if self.points.len() > Self::MAX_POINTS {
            return Err(Error::input(
                source,
                format!(
                    "{} points; at most {} are accepted (the integrators' tables resolve no finer)",
                    self.points.len(),
                    Self::MAX_POINTS
                ),
            ));
        }
        for (i, p) in self.points.iter().enumerate() {
            if !p.s.is_finite() {
                return Err(Error::input(source, format!("points[{i}].s is not finite")));
            }
            if !(p.tau.is_finite() && p.tau >= 0.0) {
                return Err(Error::input(
                    source,
                    format!("points[{i}].tau = {} must be finite and >= 0", p.tau),
                ));
            }
            if p.rgb.iter().any(|c| !(0.0..=1.0).contains(c)) {
                return Err(Error::input(
                    source,
                    format!(
                        "points[{i}].rgb = {:?}: each channel must be in [0, 1] (linear RGB)",
                        p.rgb
                    ),
                ));
            }
            if i > 0 && p.s <= self.points[i - 1].s {
                return Err(Error::input(
                    source,
                    format!(
                        "points[{i}].s = {} is not greater than points[{}].s = {} (points must be sorted, no duplicates)",
                        p.s,
                        i - 1,
                        self.points[i - 1].s
                    ),
                ));
            }
        }
        if let Some([a, b]) = self.range {
            if !(a.is_finite() && b.is_finite()) || b < a {
                return Err(Error::input(
                    source,
                    format!("range [{a}, {b}] must be finite with min <= max"),
                ));
            }
        }
        Ok(())
    }

    /// The scalar map for a mesh whose active field spans `mesh_range`.
    pub fn scalar_map(&self, mesh_range: (f64, f64)) -> ScalarMap {
        let (min, max) = match self.range {
            Some([a, b]) => (a, b),
            None => mesh_range,
        };
        let span = max - min;
        let inv_span = if span > 0.0 && (1.0 / span).is_finite() {
            1.0 / span
        } else {
            0.0
        };
        ScalarMap { min, inv_span }
    }

    /// `[s_lo, s_hi]` sampled by the integrators' tables: `[min(0, first s), max(1, last s)]`,
    /// clamped to `±S_LIMIT` so that the step `(s_hi − s_lo)/(n − 1)` is finite and the bounds
    /// survive conversion to f32. Beyond ±1e30 a table holds the TF's value at the bound.
    pub fn table_domain(&self) -> (f64, f64) {
        let p = &self.points;
        let lo = p[0].s.clamp(-Self::S_LIMIT, 0.0);
        let hi = p[p.len() - 1].s.clamp(1.0, Self::S_LIMIT);
        (lo, hi)
    }

    /// The points with `lo < s < hi` (a binary search: the points are sorted).
    pub fn points_between(&self, lo: f64, hi: f64) -> &[TfPoint] {
        let p = &self.points;
        let a = p.partition_point(|q| q.s <= lo);
        let b = p.partition_point(|q| q.s < hi).max(a);
        &p[a..b]
    }

    /// Colour and extinction at `s`: linear between points, constant beyond the ends (a NaN `s`
    /// gives the first point).
    #[inline]
    pub fn eval(&self, s: f64) -> ([f64; 3], f64) {
        let p = &self.points;
        if s.is_nan() || s <= p[0].s || p.len() == 1 {
            return (p[0].rgb, p[0].tau);
        }
        let last = p[p.len() - 1];
        if s >= last.s {
            return (last.rgb, last.tau);
        }
        // First point with s_k > s; k ≥ 1 here.
        let k = p.partition_point(|q| q.s <= s);
        let (a, b) = (p[k - 1], p[k]);
        let w = (s - a.s) / (b.s - a.s);
        let lerp = |x: f64, y: f64| x + (y - x) * w;
        (
            [
                lerp(a.rgb[0], b.rgb[0]),
                lerp(a.rgb[1], b.rgb[1]),
                lerp(a.rgb[2], b.rgb[2]),
            ],
            lerp(a.tau, b.tau),
        )
    }

    /// The control-point positions strictly between `s0` and `s1` (either order), in the order
    /// met when walking from `s0` to `s1`. The `exact` integrator splits segments there.
    pub fn breakpoints_between(&self, s0: f64, s1: f64) -> impl Iterator<Item = f64> + '_ {
        let (lo, hi) = if s0 <= s1 { (s0, s1) } else { (s1, s0) };
        let inner = self.points_between(lo, hi).iter().map(|p| p.s);
        let fwd = s0 <= s1;
        let (f, b) = if fwd {
            (Some(inner), None)
        } else {
            (None, Some(inner.rev()))
        };
        f.into_iter().flatten().chain(b.into_iter().flatten())
    }

    /// Largest extinction of any point.
    pub fn max_tau(&self) -> f64 {
        self.points.iter().map(|p| p.tau).fold(0.0, f64::max)
    }

    /// A built-in preset by name.
    pub fn preset(name: &str) -> Option<TransferFunction> {
        let pt = |s: f64, rgb: [f64; 3], tau: f64| TfPoint { s, rgb, tau };
        let points = match name {
            // A warm ramp that makes both thin and thick regions visible.
            "default" => vec![
                pt(0.0, [0.0, 0.0, 0.0], 0.0),
                pt(0.25, [0.1, 0.3, 0.9], 2.0),
                pt(0.5, [0.2, 0.9, 0.4], 6.0),
                pt(0.75, [1.0, 0.7, 0.1], 12.0),
                pt(1.0, [1.0, 1.0, 1.0], 20.0),
            ],
            // Diverging blue–white–red, opacity rising towards both ends.
            "cool-warm" => vec![
                pt(0.0, [0.23, 0.30, 0.75], 10.0),
                pt(0.5, [0.87, 0.87, 0.87], 1.0),
                pt(1.0, [0.71, 0.02, 0.15], 10.0),
            ],
            // Grey emission proportional to density, like an X-ray.
            "xray" => vec![pt(0.0, [1.0, 1.0, 1.0], 0.0), pt(1.0, [1.0, 1.0, 1.0], 5.0)],
            _ => return None,
        };
        Some(TransferFunction {
            name: name.to_string(),
            range: None,
            points,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXAMPLE: &str = r#"{ "name": "example", "range": [0.0, 1.0],
      "points": [ {"s": 0.0, "rgb": [0.0, 0.0, 0.0], "tau": 0.0},
                  {"s": 0.5, "rgb": [1.0, 0.5, 0.0], "tau": 8.0},
                  {"s": 1.0, "rgb": [1.0, 1.0, 1.0], "tau": 20.0} ] }"#;

    #[test]
    fn evaluates_piecewise_linear_and_clamps() {
        let tf = TransferFunction::from_json(EXAMPLE, "ex.json").unwrap();
        assert_eq!(tf.eval(-1.0), ([0.0; 3], 0.0));
        assert_eq!(tf.eval(0.25), ([0.5, 0.25, 0.0], 4.0));
        assert_eq!(tf.eval(0.5), ([1.0, 0.5, 0.0], 8.0));
        assert_eq!(tf.eval(0.75), ([1.0, 0.75, 0.5], 14.0));
        assert_eq!(tf.eval(2.0), ([1.0; 3], 20.0));
        let b: Vec<f64> = tf.breakpoints_between(0.9, 0.1).collect();
        assert_eq!(b, vec![0.5]);
        assert_eq!(tf.breakpoints_between(0.5, 1.0).count(), 0);
    }

    #[test]
    fn scalar_map() {
        let mut tf = TransferFunction::from_json(EXAMPLE, "ex.json").unwrap();
        tf.range = None;
        let m = tf.scalar_map((2.0, 6.0));
        assert_eq!(m.s(4.0), 0.5);
        let c = tf.scalar_map((3.0, 3.0));
        assert_eq!(c.s(3.0), 0.0);
    }

    #[test]
    fn refuses_malformed_files() {
        for (bad, what) in [
            ("not json", "not a transfer function"),
            (r#"{"points": []}"#, "empty"),
            (
                r#"{"points": [{"s":0.5,"rgb":[0,0,0],"tau":1},{"s":0.5,"rgb":[0,0,0],"tau":1}]}"#,
                "not greater",
            ),
            (
                r#"{"points": [{"s":0.6,"rgb":[0,0,0],"tau":1},{"s":0.5,"rgb":[0,0,0],"tau":1}]}"#,
                "sorted",
            ),
            (r#"{"points": [{"s":0.0,"rgb":[0,0,0],"tau":-1}]}"#, "tau"),
            ("{\"r\\nx\": 1, \"points\": []}", "unknown field `r\\nx`"),
            (
                r#"{"points": [{"s":0.0,"rgb":[0,0],"tau":1}]}"#,
                "not a transfer",
            ),
            (
                r#"{"range": [1, 0], "points": [{"s":0.0,"rgb":[0,0,0],"tau":1}]}"#,
                "range",
            ),
        ] {
            let e = TransferFunction::from_json(bad, "bad.json").unwrap_err();
            let msg = e.to_string();
            assert!(msg.starts_with("bad.json: ") && msg.contains(what), "{msg}");
            assert!(!msg.contains('\n'), "{msg}");
        }
    }

    #[test]
    fn presets_are_valid() {
        for p in PRESETS {
            let tf = TransferFunction::preset(p).unwrap();
            tf.validate(p).unwrap();
            assert_eq!(TransferFunction::load(p).unwrap(), tf);
        }
        assert!(TransferFunction::load("no-such-preset").is_err());
    }

    mod fuzz_tf {
        use super::*;
        use crate::io::vtk::tests::fuzz::*;
        use crate::optics::fast::TfTable;
        use proptest::prelude::*;

        /// Numbers a hostile file may hold.
        fn number() -> impl Strategy<Value = f64> {
            prop_oneof![
                3 => -2.0f64..3.0,
                1 => prop::sample::select(vec![
                    0.0, -0.0, 1.0, 5e-309, 1e-300, 1e30, 1e39, 1e308, -1e308, f64::MAX,
                    f64::MIN_POSITIVE,
                ]),
                1 => any::<f64>().prop_filter("finite", |x| x.is_finite()),
            ]
        }

        proptest! {
            #![proptest_config(config())]
            /// Mutated JSON gives Ok or an Err of one line naming the file, never a panic.
            #[test]
            fn tf_json_never_panics(muts in prop::collection::vec(mutation(), 1..6)) {
                let bytes = apply(EXAMPLE.as_bytes(), &muts);
                let text = String::from_utf8_lossy(&bytes);
                match TransferFunction::from_json(&text, "f.json") {
                    Ok(tf) => {
                        for s in [-1.0, 0.0, 0.3, 1.0, 2.0, f64::NAN] {
                            let (c, t) = tf.eval(s);
                            prop_assert!(c.iter().all(|x| x.is_finite()) && t.is_finite());
                        }
                    }
                    Err(e) => {
                        let m = e.to_string();
                        prop_assert!(m.starts_with("f.json: ") && !m.contains('\n'), "{}", m);
                    }
                }
            }

            /// Structurally valid files with hostile numbers: accepted ones evaluate finite and
            /// in range everywhere, and their f32 table is finite.
            #[test]
            fn tf_numbers_never_break_eval(
                pts in prop::collection::vec((number(), [number(), number(), number()], number()), 1..6),
                range in prop::option::of((number(), number())),
            ) {
                let body: Vec<String> = pts
                    .iter()
                    .map(|(s, c, t)| format!(r#"{{"s":{s:e},"rgb":[{:e},{:e},{:e}],"tau":{t:e}}}"#, c[0], c[1], c[2]))
                    .collect();
                let range = range.map(|(a, b)| format!(r#""range":[{a:e},{b:e}],"#)).unwrap_or_default();
                let text = format!(r#"{{{range}"points":[{}]}}"#, body.join(","));
                let Ok(tf) = TransferFunction::from_json(&text, "n.json") else {
                    return Ok(());
                };
                let (lo, hi) = tf.table_domain();
                prop_assert!(lo.is_finite() && hi.is_finite() && (hi - lo).is_finite());
                for s in [lo, hi, 0.5, -1e308, 1e308, f64::NAN] {
                    let (c, t) = tf.eval(s);
                    prop_assert!(c.iter().all(|x| (0.0..=1.0).contains(x)) && t.is_finite() && t >= 0.0);
                }
                let table = TfTable::new(&tf, 64);
                prop_assert!(table.data().iter().flatten().all(|x| x.is_finite()));
                let m = tf.scalar_map((0.0, 1.0));
                prop_assert!(m.inv_span.is_finite());
            }
        }
    }
}
