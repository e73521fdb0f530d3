//! PLOT3D reader (CONVENTIONS §9, `datasets/README.md`): a "whole", single-grid xyz file and its
//! q file. The variant — byte order, a leading grid count of 1, float32 or float64, IBLANK,
//! Fortran record markers — is found by trying every combination against the file size; the
//! byte order is the one whose `ni nj nk` are positive and make the sizes agree. Nothing is
//! allocated before the sizes agree. The files are read at offsets a block at a time, each
//! array straight into the mesh's, so the peak is the mesh and a block.
//!
//! Fields: density, momentum-x/-y/-z, energy, and velocity = |momentum| / density (0 where the
//! density is 0). Every hex cell is kept and split (5 tets alternating, or 6 with
//! `Split::Six`): an IBLANK array is read past and ignored, so blanked cells are rendered too.
//! Mach, alpha, Reynolds number and time go to `field_data`.
//!
//! Past 600 lines only with its tests (about 320 lines of code).

use std::path::{Path, PathBuf};

use glam::DVec3;

use crate::error::{Error, Result};
use crate::io::{split, LoadOptions, Split};
use crate::mesh::{Field, Mesh};

/// The scalar names a PLOT3D mesh offers.
pub const PLOT3D_FIELDS: [&str; 6] = [
    "density",
    "energy",
    "velocity",
    "momentum-x",
    "momentum-y",
    "momentum-z",
];

/// Reads a PLOT3D xyz file and its q file (`opts.q_file`, or the xyz file name with `xyz`
/// replaced by `q`).
pub fn read_plot3d(xyz: &Path, opts: &LoadOptions) -> Result<Mesh> {
    let q = match &opts.q_file {
        Some(q) => q.clone(),
        None => q_path(xyz)?,
    };
    let xyz_file = FileSrc::open(xyz)?;
    if !q.exists() {
        return Err(Error::input(
            xyz.display(),
            format!(
                "PLOT3D q file {} not found (give it with --q FILE)",
                q.display()
            ),
        ));
    }
    let q_file = FileSrc::open(&q)?;
    parse(
        &xyz_file,
        &q_file,
        &xyz.display().to_string(),
        &q.display().to_string(),
        opts,
    )
}

/// Bytes at offsets: a file read where it is needed, or one held in memory.
trait Src {
    /// The size in bytes.
    fn size(&self) -> usize;
    /// Fills `buf` with the bytes at `off`, or says that they are not all there.
    fn at(&self, off: usize, buf: &mut [u8]) -> std::io::Result<bool>;
}

impl Src for &[u8] {
    fn size(&self) -> usize {
        self.len()
    }
    fn at(&self, off: usize, buf: &mut [u8]) -> std::io::Result<bool> {
        match off.checked_add(buf.len()).and_then(|e| self.get(off..e)) {
            Some(b) => {
                buf.copy_from_slice(b);
                Ok(true)
            }
            None => Ok(false),
        }
    }
}

/// A file read at offsets (`pread`), a block at a time: never held whole.
struct FileSrc {
    file: std::fs::File,
    len: usize,
}

impl FileSrc {
    fn open(path: &Path) -> Result<FileSrc> {
        let file = crate::io::open_input(path)?;
        let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
        let len = usize::try_from(len)
            .map_err(|_| Error::input(path.display(), format!("{len} bytes: too large")))?;
        Ok(FileSrc { file, len })
    }
}

impl Src for FileSrc {
    fn size(&self) -> usize {
        self.len
    }
    fn at(&self, off: usize, buf: &mut [u8]) -> std::io::Result<bool> {
        use std::os::unix::fs::FileExt;
        if off.checked_add(buf.len()).is_none_or(|e| e > self.len) {
            return Ok(false);
        }
        self.file.read_exact_at(buf, off as u64).map(|_| true)
    }
}

/// The q file beside `xyz`: its file name with the last `xyz` replaced by `q`.
pub fn q_path(xyz: &Path) -> Result<PathBuf> {
    let name = xyz
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    match name.rfind("xyz") {
        Some(i) => Ok(xyz.with_file_name(format!("{}q{}", &name[..i], &name[i + 3..]))),
        None => Err(Error::input(
            xyz.display(),
            "cannot name the PLOT3D q file: the file name has no 'xyz' (give it with --q FILE)",
        )),
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Variant {
    big: bool,
    ngrid: bool,
    markers: bool,
    f64: bool,
    iblank: bool,
}

impl Variant {
    fn all() -> impl Iterator<Item = Variant> {
        (0..32u32).map(|b| Variant {
            big: b & 16 == 0,
            ngrid: b & 8 != 0,
            markers: b & 4 != 0,
            f64: b & 2 != 0,
            iblank: b & 1 != 0,
        })
    }
    fn fs(self) -> usize {
        if self.f64 {
            8
        } else {
            4
        }
    }
    fn describe(self) -> String {
        format!(
            "{}-endian, {}{}{}{}",
            if self.big { "big" } else { "little" },
            if self.f64 { "float64" } else { "float32" },
            if self.iblank { ", IBLANK" } else { "" },
            if self.ngrid { ", grid count" } else { "" },
            if self.markers {
                ", Fortran record markers"
            } else {
                ""
            },
        )
    }
}

fn i32_at(b: &dyn Src, off: usize, big: bool) -> Option<i64> {
    let mut w = [0u8; 4];
    if !b.at(off, &mut w).ok()? {
        return None;
    }
    Some(if big {
        i32::from_be_bytes(w)
    } else {
        i32::from_le_bytes(w)
    } as i64)
}

/// Reads a record of `len` bytes starting at `off` (with markers when asked); returns the
/// offset of its data and the offset past it.
fn record(b: &dyn Src, off: usize, len: usize, v: Variant) -> Option<(usize, usize)> {
    if !v.markers {
        let end = off.checked_add(len)?;
        return (end <= b.size()).then_some((off, end));
    }
    let m = i32_at(b, off, v.big)?;
    if m < 0 || m as u64 != len as u64 {
        return None;
    }
    let data = off + 4;
    let end = data.checked_add(len)?;
    (i32_at(b, end, v.big)? == m).then_some((data, end + 4))
}

/// Grid count (when present) and dimensions: offset past them.
fn dims(b: &dyn Src, v: Variant) -> Option<([usize; 3], usize, usize)> {
    let mut off = 0;
    if v.ngrid {
        let (d, e) = record(b, 0, 4, v)?;
        if i32_at(b, d, v.big)? != 1 {
            return None;
        }
        off = e;
    }
    let (d, e) = record(b, off, 12, v)?;
    let mut n = [0usize; 3];
    for (k, x) in n.iter_mut().enumerate() {
        let val = i32_at(b, d + 4 * k, v.big)?;
        if val <= 0 {
            return None;
        }
        *x = val as usize;
    }
    let count = n[0].checked_mul(n[1])?.checked_mul(n[2])?;
    Some((n, count, e))
}

/// xyz layout: dims, offset of the coordinate data. The file size must agree exactly.
fn xyz_layout(b: &dyn Src, v: Variant) -> Option<([usize; 3], usize)> {
    let (d, n, off) = dims(b, v)?;
    let len =
        n.checked_mul(3 * v.fs())?
            .checked_add(if v.iblank { n.checked_mul(4)? } else { 0 })?;
    if v.markers && len > i32::MAX as usize {
        return None;
    }
    let (data, end) = record(b, off, len, v)?;
    (end == b.size()).then_some((d, data))
}

/// q layout: dims, offset of (mach, alpha, re, time), offset of the 5 arrays; trailing bytes
/// are allowed when `exact` is false.
fn q_layout(b: &dyn Src, v: Variant, exact: bool) -> Option<([usize; 3], usize, usize)> {
    let (d, n, off) = dims(b, v)?;
    let (h, e) = record(b, off, 4 * v.fs(), v)?;
    let len = n.checked_mul(5 * v.fs())?;
    if v.markers && len > i32::MAX as usize {
        return None;
    }
    let (data, end) = record(b, e, len, v)?;
    (!exact || end == b.size()).then_some((d, h, data))
}

/// Bytes decoded at a time.
const BLOCK: usize = 8 * 8192;

/// The `n` floats of `v`'s precision and byte order at `off`, handed to `f` with their index,
/// read a block at a time.
fn floats(
    b: &dyn Src,
    name: &str,
    off: usize,
    n: usize,
    v: Variant,
    mut f: impl FnMut(usize, f64),
) -> Result<()> {
    let fs = v.fs();
    let mut buf = vec![0u8; BLOCK.min(n * fs)];
    let mut i = 0;
    while i < n {
        let k = (BLOCK / fs).min(n - i);
        let chunk = &mut buf[..k * fs];
        if !b
            .at(off + i * fs, chunk)
            .map_err(|e| Error::input(name, e))?
        {
            return Err(Error::input(name, "file ends inside its data (truncated?)"));
        }
        for (j, c) in chunk.chunks_exact(fs).enumerate() {
            let x = if v.f64 {
                let w: [u8; 8] = c.try_into().unwrap_or([0; 8]);
                if v.big {
                    f64::from_be_bytes(w)
                } else {
                    f64::from_le_bytes(w)
                }
            } else {
                let w: [u8; 4] = c.try_into().unwrap_or([0; 4]);
                (if v.big {
                    f32::from_be_bytes(w)
                } else {
                    f32::from_le_bytes(w)
                }) as f64
            };
            f(i + j, x);
        }
        i += k;
    }
    Ok(())
}

/// Parses a PLOT3D xyz and q pair held in memory; the names are used in messages.
pub fn parse_plot3d(
    xyz: &[u8],
    q: &[u8],
    xyz_name: &str,
    q_name: &str,
    opts: &LoadOptions,
) -> Result<Mesh> {
    parse(&xyz, &q, xyz_name, q_name, opts)
}

/// Parses a PLOT3D xyz and q pair, reading each array straight into the mesh's.
fn parse(
    xyz: &dyn Src,
    q: &dyn Src,
    xyz_name: &str,
    q_name: &str,
    opts: &LoadOptions,
) -> Result<Mesh> {
    let active = opts.scalar.as_deref().unwrap_or("density");
    if !PLOT3D_FIELDS.contains(&active) {
        return Err(Error::input(
            xyz_name,
            format!(
                "unknown PLOT3D scalar '{}' (choices: {})",
                active.escape_debug(),
                PLOT3D_FIELDS.join(", ")
            ),
        ));
    }
    let Some((xv, (d, xoff))) = Variant::all().find_map(|v| xyz_layout(xyz, v).map(|l| (v, l)))
    else {
        let hint = match (
            i32_at(xyz, 0, true),
            i32_at(xyz, 4, true),
            i32_at(xyz, 8, true),
        ) {
            (Some(a), Some(b), Some(c)) => {
                format!(" (it starts with {a} {b} {c} as big-endian int32)")
            }
            _ => String::new(),
        };
        return Err(Error::input(
            xyz_name,
            format!(
                "not a PLOT3D whole single-grid xyz file: no combination of byte order, precision, \
                 IBLANK, grid count and record markers matches its size of {} bytes{hint}",
                xyz.size()
            ),
        ));
    };
    let n = d[0] * d[1] * d[2];
    // q: the xyz file's variant first, exact sizes before trailing bytes.
    let same = |v: Variant| {
        v.big == xv.big && v.f64 == xv.f64 && v.markers == xv.markers && v.ngrid == xv.ngrid
    };
    let qvariants: Vec<Variant> = Variant::all().filter(|v| !v.iblank).collect();
    let found = [true, false].iter().find_map(|&exact| {
        qvariants
            .iter()
            .filter(|v| same(**v))
            .chain(qvariants.iter().filter(|v| !same(**v)))
            .find_map(|&v| q_layout(q, v, exact).filter(|l| l.0 == d).map(|l| (v, l)))
    });
    let Some((qv, (_, hoff, qoff))) = found else {
        let msg = match dims(q, Variant { iblank: false, ..xv }) {
            Some((qd, _, _)) if qd != d => format!(
                "q dimensions {}×{}×{} differ from the grid's {}×{}×{}",
                qd[0], qd[1], qd[2], d[0], d[1], d[2]
            ),
            _ => format!(
                "not a PLOT3D q file for a {}×{}×{} grid ({}): its {} bytes are too few or match no layout",
                d[0],
                d[1],
                d[2],
                xv.describe(),
                q.size()
            ),
        };
        return Err(Error::input(q_name, msg));
    };
    // Each array straight into the mesh's: x, y and z into the positions in three passes.
    let mut positions =
        crate::util::alloc::try_vec(n, DVec3::ZERO).map_err(|e| Error::input(xyz_name, e))?;
    for c in [0usize, 1, 2] {
        floats(xyz, xyz_name, xoff + c * n * xv.fs(), n, xv, |i, x| {
            positions[i][c] = x
        })?;
    }
    let mut h = [0.0; 4];
    floats(q, q_name, hoff, 4, qv, |i, x| h[i] = x)?;
    let arr = |k: usize| -> Result<Vec<f64>> {
        let mut a = crate::util::alloc::try_vec(n, 0.0).map_err(|e| Error::input(q_name, e))?;
        floats(q, q_name, qoff + k * n * qv.fs(), n, qv, |i, x| a[i] = x)?;
        Ok(a)
    };
    let (rho, mx, my, mz, e) = (arr(0)?, arr(1)?, arr(2)?, arr(3)?, arr(4)?);
    let vel: Vec<f64> = (0..n)
        .map(|i| {
            if rho[i] == 0.0 {
                0.0
            } else {
                DVec3::new(mx[i], my[i], mz[i]).length() / rho[i]
            }
        })
        .collect();
    let tets = split::split_structured(xyz_name, d, &positions, opts.split.unwrap_or(Split::Five))?;
    let f = |name: &str, v: Vec<f64>| Field {
        name: name.to_string(),
        steps: vec![v],
    };
    let fields = vec![
        f("density", rho),
        f("momentum-x", mx),
        f("momentum-y", my),
        f("momentum-z", mz),
        f("energy", e),
        f("velocity", vel),
    ];
    let mut mesh = Mesh::new(xyz_name, positions, tets, fields)?;
    for (k, name) in ["mach", "alpha", "reynolds", "time"].iter().enumerate() {
        mesh.field_data.insert(name.to_string(), vec![h[k]]);
    }
    mesh.select_field(active, 0)?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3×2×2 grid in the given variant, with q values; `trailing` junk bytes after q.
    fn files(v: Variant, trailing: usize) -> (Vec<u8>, Vec<u8>) {
        let d = [3i32, 2, 2];
        let n = 12;
        let int = |x: i32| {
            if v.big {
                x.to_be_bytes()
            } else {
                x.to_le_bytes()
            }
        };
        let fl = |x: f64| -> Vec<u8> {
            match (v.f64, v.big) {
                (true, true) => x.to_be_bytes().to_vec(),
                (true, false) => x.to_le_bytes().to_vec(),
                (false, true) => (x as f32).to_be_bytes().to_vec(),
                (false, false) => (x as f32).to_le_bytes().to_vec(),
            }
        };
        let rec = |out: &mut Vec<u8>, data: Vec<u8>| {
            if v.markers {
                out.extend(int(data.len() as i32));
            }
            let len = data.len();
            out.extend(data);
            if v.markers {
                out.extend(int(len as i32));
            }
        };
        let mut head = Vec::new();
        if v.ngrid {
            rec(&mut head, int(1).to_vec());
        }
        rec(&mut head, d.iter().flat_map(|&x| int(x)).collect());
        let mut xyz = head.clone();
        let mut data = Vec::new();
        for c in 0..3 {
            for idx in 0..n {
                let (i, j, k) = (idx % 3, (idx / 3) % 2, idx / 6);
                data.extend(fl([i as f64, j as f64 * 2.0, k as f64 * 0.5][c]));
            }
        }
        if v.iblank {
            for _ in 0..n {
                data.extend(int(1));
            }
        }
        rec(&mut xyz, data);
        let mut q = head;
        rec(
            &mut q,
            [0.5, 1.0, 1e6, 2.0].iter().flat_map(|&x| fl(x)).collect(),
        );
        let mut data = Vec::new();
        for k in 0..5 {
            for i in 0..n {
                let val = match k {
                    0 => {
                        if i == 0 {
                            0.0
                        } else {
                            1.0 + i as f64
                        }
                    }
                    1 => 3.0,
                    2 => 4.0,
                    3 => 0.0,
                    _ => -(i as f64),
                };
                data.extend(fl(val));
            }
        }
        rec(&mut q, data);
        q.extend(vec![7u8; trailing]);
        (xyz, q)
    }

    #[test]
    fn every_variant_loads() {
        for v in Variant::all() {
            let (x, q) = files(v, if v.markers { 0 } else { 13 });
            let m = parse_plot3d(&x, &q, "g.xyz", "g.q", &LoadOptions::default())
                .unwrap_or_else(|e| panic!("{}: {e}", v.describe()));
            assert_eq!(
                (m.num_vertices(), m.num_tets()),
                (12, 2 * 5),
                "{}",
                v.describe()
            );
            assert_eq!(m.positions()[11], DVec3::new(2.0, 2.0, 0.5));
            assert_eq!(m.active_field(), ("density", 0));
            assert_eq!(m.negative_tets(), 0);
            assert_eq!(m.field_data["reynolds"], vec![1e6]);
            let vel = &m.fields()[5].steps[0];
            assert_eq!(vel[0], 0.0);
            assert!((vel[1] - 5.0 / 2.0).abs() < 1e-6);
        }
    }

    #[test]
    fn options_and_errors() {
        let v = Variant {
            big: true,
            ngrid: false,
            markers: false,
            f64: false,
            iblank: false,
        };
        let (x, q) = files(v, 0);
        let six = LoadOptions {
            split: Some(Split::Six),
            scalar: Some("energy".into()),
            ..Default::default()
        };
        let m = parse_plot3d(&x, &q, "g.xyz", "g.q", &six).unwrap();
        assert_eq!(m.num_tets(), 12);
        assert_eq!(m.active_field(), ("energy", 0));
        let bad = LoadOptions {
            scalar: Some("pressure".into()),
            ..Default::default()
        };
        let err = |x: &[u8], q: &[u8], opts: &LoadOptions| {
            parse_plot3d(x, q, "g.xyz", "g.q", opts)
                .unwrap_err()
                .to_string()
        };
        let e = err(&x, &q, &bad);
        assert_eq!(
            e,
            "g.xyz: unknown PLOT3D scalar 'pressure' (choices: density, energy, velocity, momentum-x, momentum-y, momentum-z)"
        );
        let d = LoadOptions::default();
        // Truncated xyz, truncated q, q of another grid, lying dimensions, NaN.
        let e = err(&x[..x.len() - 1], &q, &d);
        assert!(
            e.starts_with("g.xyz: not a PLOT3D whole single-grid xyz file"),
            "{e}"
        );
        let e = err(&x, &q[..q.len() - 1], &d);
        assert!(
            e.starts_with("g.q: not a PLOT3D q file for a 3×2×2 grid"),
            "{e}"
        );
        let mut q2 = q.clone();
        q2[3] = 4;
        let e = err(&x, &q2, &d);
        assert!(
            e.contains("g.q: q dimensions 4×2×2 differ from the grid's 3×2×2"),
            "{e}"
        );
        let mut x2 = x.clone();
        x2[..4].copy_from_slice(&0x7fff_ffffi32.to_be_bytes());
        let e = err(&x2, &q, &d);
        assert!(e.contains("2147483647 2 2"), "{e}");
        let mut x3 = x.clone();
        x3[12..16].copy_from_slice(&f32::NAN.to_be_bytes());
        let e = err(&x3, &q, &d);
        assert!(e.contains("non-finite"), "{e}");
        assert!(parse_plot3d(&[], &[], "g.xyz", "g.q", &d).is_err());
    }

    #[test]
    fn missing_q_file() {
        let dir = std::env::temp_dir().join(format!("p3d-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let v = Variant {
            big: true,
            ngrid: false,
            markers: false,
            f64: false,
            iblank: false,
        };
        let (x, _) = files(v, 0);
        let path = dir.join("gridxyz.bin");
        std::fs::write(&path, x).unwrap();
        let e = read_plot3d(&path, &LoadOptions::default()).unwrap_err();
        assert!(matches!(e, Error::Input(_)));
        let want = format!(
            "{}: PLOT3D q file {} not found (give it with --q FILE)",
            path.display(),
            dir.join("gridq.bin").display()
        );
        assert_eq!(e.to_string(), want);
        let e = read_plot3d(&dir.join("grid.bin"), &LoadOptions::default()).unwrap_err();
        assert!(e.to_string().contains("has no 'xyz'"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    fn data_dir() -> Option<PathBuf> {
        let d = std::env::var_os("TETBENCH_DATA")
            .map(PathBuf::from)
            .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/datasets"));
        d.join("bluntfinxyz.bin").exists().then_some(d)
    }

    /// The three NASA grids (skipped when the files are absent: they are not committed).
    #[test]
    fn real_datasets() {
        let Some(dir) = data_dir() else {
            return;
        };
        let cases = [
            ("bluntfinxyz.bin", "density", 40960, 187395, (0.193, 4.98)),
            ("postxyz.bin", "velocity", 109744, 513375, (0.0, 1.39)),
            ("combxyz.bin", "density", 47025, 215040, (0.198, 0.710)),
        ];
        for (file, scalar, nv, nt, (lo, hi)) in cases {
            let path = dir.join(file);
            if !path.exists() {
                continue;
            }
            let opts = LoadOptions {
                scalar: Some(scalar.into()),
                ..Default::default()
            };
            let m = read_plot3d(&path, &opts).unwrap();
            assert_eq!((m.num_vertices(), m.num_tets()), (nv, nt), "{file}");
            let (a, b) = m.scalar_range();
            eprintln!(
                "{file}: {nv} vertices, {nt} tets, {scalar} {a}..{b}, degenerate {}",
                m.degenerate_tets()
            );
            let close = |x: f64, y: f64| (x - y).abs() <= 0.005 * y.abs().max(0.01);
            assert!(
                close(a, lo) && close(b, hi),
                "{file}: {scalar} range {a}..{b}"
            );
            assert_eq!(m.negative_tets(), 0, "{file}");
            if file == "bluntfinxyz.bin" {
                // Conforming: boundary faces are exactly 2 per boundary quad.
                let (i, j, k) = (39, 31, 31);
                assert_eq!(
                    m.boundary_faces().len(),
                    4 * (i * j + j * k + i * k),
                    "{file}"
                );
            }
        }
    }

    mod fuzz_plot3d {
        use super::*;
        use crate::io::vtk::tests::fuzz::*;
        use proptest::prelude::*;

        /// Pairs in several layouts: float32 and float64, both byte orders, markers, grid
        /// count, IBLANK, trailing bytes after q.
        fn samples() -> Vec<(Vec<u8>, Vec<u8>)> {
            Variant::all()
                .step_by(3)
                .enumerate()
                .map(|(k, v)| files(v, if k % 4 == 0 { 8 } else { 0 }))
                .collect()
        }

        proptest! {
            #![proptest_config(config())]
            /// Mutated and truncated xyz and q files (dimensions included: the snippets hold
            /// 0x7fffffff) give Ok or an Err of one line, never a panic; a mesh that loads has
            /// finite positions.
            #[test]
            fn plot3d_reader_never_panics(
                which in 0usize..11,
                field in 0usize..7,
                split in 0usize..2,
                xmuts in prop::collection::vec(mutation(), 0..5),
                qmuts in prop::collection::vec(mutation(), 0..5),
            ) {
                thread_local!(static SAMPLES: Vec<(Vec<u8>, Vec<u8>)> = samples());
                let (x, q) = SAMPLES.with(|s| {
                    let (x, q) = &s[which % s.len()];
                    (apply(x, &xmuts), apply(q, &qmuts))
                });
                let scalar = PLOT3D_FIELDS.get(field).map(|f| f.to_string()).unwrap_or("bogus".into());
                let opts = LoadOptions {
                    split: [None, Some(Split::Six)][split],
                    scalar: Some(scalar),
                    ..Default::default()
                };
                match parse_plot3d(&x, &q, "f.xyz", "f.q", &opts) {
                    Ok(m) => prop_assert!(m.num_tets() > 0),
                    Err(e) => {
                        let m = e.to_string();
                        prop_assert!(!m.contains('\n'), "{}", m);
                    }
                }
            }
        }
    }
}
