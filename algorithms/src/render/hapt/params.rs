//! `hapt`'s parameters (`--param KEY=VALUE`), declared once with their defaults and read
//! through [`crate::plugin::Params`] into [`Settings`].

use crate::error::{Error, Result};
use crate::plugin::{ParamInfo, Params};

/// Smallest chunk: a smaller `stream=N` is raised to it. Each chunk is one upload, one pass and
/// one submit with a fixed cost (~1 MB of driver memory on lavapipe while in flight): `stream=1`
/// on 13K tets took 88 s and 15.5 GB.
pub const MIN_CHUNK: usize = 1024;
/// Largest chunk, in tets.
const MAX_CHUNK: usize = 1 << 22;

/// The parameters `hapt` takes, with their defaults (what `tetbench list` prints).
pub const PARAMS: &[ParamInfo] = &[
    ParamInfo {
        name: "mode",
        default: "dvr",
        doc: "dvr, iso or dvr+iso: volume, iso-surfaces, or both",
    },
    ParamInfo {
        name: "iso",
        default: "",
        doc: "up to 4 iso values, comma-separated, in scalar units or P% of the field's range",
    },
    ParamInfo {
        name: "iso_alpha",
        default: "1",
        doc: "opacity of the iso-surfaces, in [0, 1]",
    },
    ParamInfo {
        name: "stream",
        default: "",
        doc: "N: stream the sorted tets in chunks of N (the mesh is not resident)",
    },
    ParamInfo {
        name: "timevarying",
        default: "0",
        doc: "1: upload time step k mod n of the active field before frame k",
    },
];

/// What is drawn: the volume, iso-surfaces, or both.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Dvr,
    Iso,
    DvrIso,
}

impl Mode {
    /// The `mode` bits of `hapt.wgsl`'s `HaptParams`.
    pub fn bits(self) -> u32 {
        match self {
            Mode::Dvr => 1,
            Mode::Iso => 2,
            Mode::DvrIso => 3,
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            Mode::Dvr => "dvr",
            Mode::Iso => "iso",
            Mode::DvrIso => "dvr+iso",
        }
    }
}

/// An iso value: in scalar units, or a percentage of the active field's range (`50%`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IsoValue {
    Scalar(f64),
    Percent(f64),
}

impl IsoValue {
    fn parse(x: &str) -> Option<IsoValue> {
        let (num, pct) = match x.strip_suffix('%') {
            Some(n) => (n, true),
            None => (x, false),
        };
        let v = num.trim().parse::<f64>().ok().filter(|v| v.is_finite())?;
        // A percentage is of the field's range: outside [0, 100] no surface can exist.
        if pct && !(0.0..=100.0).contains(&v) {
            return None;
        }
        Some(if pct {
            IsoValue::Percent(v)
        } else {
            IsoValue::Scalar(v)
        })
    }

    /// The value in scalar units, for a field whose range is `range`.
    pub fn scalar(self, range: (f64, f64)) -> f64 {
        match self {
            IsoValue::Scalar(v) => v,
            IsoValue::Percent(p) => range.0 + (range.1 - range.0) * p / 100.0,
        }
    }
}

/// `hapt`'s parameters, read and checked.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub mode: Mode,
    pub iso: Vec<IsoValue>,
    pub iso_alpha: f32,
    /// Streaming: tets per chunk (at least [`MIN_CHUNK`]).
    pub stream: Option<usize>,
    pub timevarying: bool,
}

impl Settings {
    /// Reads the `KEY=VALUE` pairs given to `hapt`.
    pub fn read(given: &[(String, String)]) -> Result<Settings> {
        let p = Params::new("hapt", PARAMS, given)?;
        let mode = p.choice(
            "mode",
            &[
                ("dvr", Mode::Dvr),
                ("iso", Mode::Iso),
                ("dvr+iso", Mode::DvrIso),
                ("dvriso", Mode::DvrIso),
            ],
        )?;
        // A value ending in % is that percentage of the active field's range.
        let iso = p.list(
            "iso",
            4,
            "numbers or P% with P in 0..=100",
            IsoValue::parse,
        )?;
        let iso_alpha = p.f64_in("iso_alpha", 0.0..=1.0)? as f32;
        let stream = p
            .opt_usize_in("stream", 1..=MAX_CHUNK)?
            .map(|n| n.max(MIN_CHUNK));
        let timevarying = p.flag("timevarying")?;
        if mode == Mode::Dvr && !iso.is_empty() {
            return Err(Error::Input(
                "hapt: iso=... draws iso-surfaces only with mode=iso or mode=dvr+iso (mode is dvr)"
                    .into(),
            ));
        }
        if mode != Mode::Dvr && iso.is_empty() {
            return Err(Error::Input(format!(
                "hapt: mode={} needs iso=v1,... (scalar units)",
                mode.name()
            )));
        }
        Ok(Settings {
            mode,
            iso,
            iso_alpha,
            stream,
            timevarying,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(kv: &[(&str, &str)]) -> Result<Settings> {
        let given: Vec<(String, String)> = kv
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        Settings::read(&given)
    }

    #[test]
    fn iso_values_out_of_range_or_without_an_iso_mode_are_refused() {
        for (kv, what) in [
            (&[("mode", "iso"), ("iso", "200%")][..], "0..=100"),
            (&[("mode", "iso"), ("iso", "30%,-1%")][..], "0..=100"),
            (&[("iso", "0.5")][..], "mode=iso"),
            (&[("mode", "dvr"), ("iso", "0.5")][..], "mode=iso"),
            (&[("mode", "iso")][..], "needs iso"),
        ] {
            let e = params(kv).err().unwrap_or_else(|| panic!("{kv:?} accepted")).to_string();
            assert!(e.starts_with("hapt: ") && e.contains(what), "{kv:?}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
        assert!(params(&[("mode", "iso"), ("iso", "0%,100%,0.5")]).is_ok());
        assert!(params(&[("mode", "dvr+iso"), ("iso", "30%,60%")]).is_ok());
    }

    #[test]
    fn tiny_stream_chunks_are_raised_to_the_floor() {
        assert_eq!(params(&[("stream", "1")]).unwrap().stream, Some(MIN_CHUNK));
        assert_eq!(params(&[("stream", "5000")]).unwrap().stream, Some(5000));
        assert!(params(&[("stream", "0")]).is_err());
    }
}
