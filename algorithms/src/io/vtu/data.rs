//! Decoding one DataArray: its payload in `ascii`, `binary` (base64, optionally zlib blocks) or
//! `appended` (raw or base64) format, every count checked before anything is allocated.

use std::io::Read;

use base64::engine::{DecodePaddingMode, GeneralPurpose, GeneralPurposeConfig};
use base64::Engine;

use super::read::{line_of, one_line};
use super::{Array, Format};
use crate::error::{Error, Result};
use crate::io::vtk_types::{self, DType};

pub(super) const B64: GeneralPurpose = GeneralPurpose::new(
    &base64::alphabet::STANDARD,
    GeneralPurposeConfig::new()
        .with_decode_padding_mode(DecodePaddingMode::Indifferent)
        .with_decode_allow_trailing_bits(true),
);

pub(super) struct Doc<'a> {
    pub(super) src: &'a str,
    pub(super) xml: &'a str,
    pub(super) big: bool,
    pub(super) hs: usize,
    pub(super) zlib: bool,
    /// Appended data after the `_`; `true` when raw.
    pub(super) appended: Option<(bool, &'a [u8])>,
    /// Offsets of every appended array, sorted (to find where a base64 one ends).
    pub(super) offsets: Vec<usize>,
}

impl Doc<'_> {
    pub(super) fn err_at(&self, pos: usize, msg: impl std::fmt::Display) -> Error {
        Error::input(format!("{}:{}", self.src, line_of(self.xml, pos)), msg)
    }

    pub(super) fn err(&self, a: &Array, msg: impl std::fmt::Display) -> Error {
        self.err_at(
            a.pos,
            format!("DataArray '{}' ({:?}): {msg}", one_line(&a.name), a.section),
        )
    }

    pub(super) fn dtype(&self, a: &Array) -> Result<DType> {
        DType::from_xml(&a.ty)
            .ok_or_else(|| self.err(a, format!("type '{}' is not numeric", one_line(&a.ty))))
    }

    pub(super) fn uint(&self, b: &[u8]) -> u64 {
        if self.hs == 8 {
            let mut w = [0u8; 8];
            w.copy_from_slice(&b[..8]);
            if self.big {
                u64::from_be_bytes(w)
            } else {
                u64::from_le_bytes(w)
            }
        } else {
            let mut w = [0u8; 4];
            w.copy_from_slice(&b[..4]);
            (if self.big {
                u32::from_be_bytes(w)
            } else {
                u32::from_le_bytes(w)
            }) as u64
        }
    }

    /// The decoded (and decompressed) bytes of a binary or appended array. `limit`: the byte
    /// count the array must have when known (a compressed array claiming more is refused before
    /// anything is inflated).
    pub(super) fn payload(&self, a: &Array, limit: Option<u64>) -> Result<Vec<u8>> {
        match a.format {
            Format::Binary => {
                let t: Vec<u8> = a
                    .text
                    .bytes()
                    .filter(|c| !c.is_ascii_whitespace())
                    .collect();
                self.payload_b64(a, &t, limit)
            }
            Format::Appended => {
                let Some((raw, data)) = self.appended else {
                    return Err(self.err(a, "format=\"appended\" but the file has no AppendedData"));
                };
                if a.offset > data.len() {
                    return Err(self.err(
                        a,
                        format!(
                            "offset {} past the {} bytes of appended data",
                            a.offset,
                            data.len()
                        ),
                    ));
                }
                if raw {
                    self.payload_raw(a, &data[a.offset..], limit)
                } else {
                    let end = self
                        .offsets
                        .iter()
                        .copied()
                        .find(|&o| o > a.offset)
                        .unwrap_or(data.len())
                        .min(data.len());
                    let t: Vec<u8> = data[a.offset..end]
                        .iter()
                        .copied()
                        .filter(|c| !c.is_ascii_whitespace())
                        .collect();
                    self.payload_b64(a, &t, limit)
                }
            }
            Format::Ascii => Err(Error::Internal("payload of an ascii array".into())),
        }
    }

    pub(super) fn payload_raw(&self, a: &Array, s: &[u8], limit: Option<u64>) -> Result<Vec<u8>> {
        let hs = self.hs;
        let short = || self.err(a, "appended data ends inside this array (truncated file?)");
        if s.len() < hs {
            return Err(short());
        }
        let first = self.uint(s);
        if !self.zlib {
            let n = usize::try_from(first).map_err(|_| short())?;
            if n > s.len() - hs {
                return Err(self.err(
                    a,
                    format!(
                        "header says {n} bytes but only {} remain (truncated file?)",
                        s.len() - hs
                    ),
                ));
            }
            return Ok(s[hs..hs + n].to_vec());
        }
        let nb = usize::try_from(first).map_err(|_| short())?;
        let hlen = nb
            .checked_add(3)
            .and_then(|k| k.checked_mul(hs))
            .filter(|&h| h <= s.len())
            .ok_or_else(|| {
                self.err(
                    a,
                    format!("compression header announces {nb} blocks, more than the file holds"),
                )
            })?;
        let header: Vec<u64> = s[hs..hlen].chunks_exact(hs).map(|c| self.uint(c)).collect();
        self.inflate(a, &header, &s[hlen..], limit)
    }

    pub(super) fn b64(&self, a: &Array, t: &[u8]) -> Result<Vec<u8>> {
        B64.decode(t)
            .map_err(|e| self.err(a, format!("bad base64 data: {e}")))
    }

    pub(super) fn payload_b64(&self, a: &Array, t: &[u8], limit: Option<u64>) -> Result<Vec<u8>> {
        let hs = self.hs;
        let chars = |bytes: usize| bytes.div_ceil(3).saturating_mul(4);
        let short = || self.err(a, "base64 data too short for its header");
        if !self.zlib {
            // Header and data are one base64 stream (VTK) or two (some writers).
            if let Ok(d) = B64.decode(t) {
                if d.len() >= hs {
                    let n = self.uint(&d);
                    if n <= (d.len() - hs) as u64 {
                        return Ok(d[hs..hs + n as usize].to_vec());
                    }
                }
            }
            let hc = chars(hs);
            if t.len() < hc {
                return Err(short());
            }
            let h = self.b64(a, &t[..hc])?;
            if h.len() < hs {
                return Err(short());
            }
            let n = self.uint(&h);
            let d = self.b64(a, &t[hc..])?;
            if n > d.len() as u64 {
                return Err(self.err(
                    a,
                    format!("header says {n} bytes but the data holds {}", d.len()),
                ));
            }
            return Ok(d[..n as usize].to_vec());
        }
        let hc1 = chars(hs);
        if t.len() < hc1 {
            return Err(short());
        }
        let h1 = self.b64(a, &t[..hc1])?;
        if h1.len() < hs {
            return Err(short());
        }
        let nb = self.uint(&h1);
        let hlen = usize::try_from(nb)
            .ok()
            .and_then(|nb| nb.checked_add(3))
            .and_then(|k| k.checked_mul(hs))
            .filter(|&h| chars(h) <= t.len())
            .ok_or_else(|| {
                self.err(
                    a,
                    format!("compression header announces {nb} blocks, more than the file holds"),
                )
            })?;
        let hc = chars(hlen);
        let h = self.b64(a, &t[..hc])?;
        if h.len() < hlen {
            return Err(short());
        }
        let header: Vec<u64> = h[hs..hlen].chunks_exact(hs).map(|c| self.uint(c)).collect();
        match B64.decode(&t[hc..]) {
            Ok(d) => self.inflate(a, &header, &d, limit),
            Err(_) => {
                let all = self.b64(a, t)?;
                self.inflate(a, &header, all.get(hlen..).unwrap_or(&[]), limit)
            }
        }
    }

    /// `header` = block size, last block size, compressed sizes; `limit` = the bytes the array
    /// must have, when known.
    pub(super) fn inflate(
        &self,
        a: &Array,
        header: &[u64],
        data: &[u8],
        limit: Option<u64>,
    ) -> Result<Vec<u8>> {
        let (bs, last, sizes) = (header[0], header[1], &header[2..]);
        let nb = sizes.len() as u64;
        if nb == 0 {
            return Ok(Vec::new());
        }
        let last = if last == 0 { bs } else { last };
        let bad = |m: String| self.err(a, m);
        if last > bs {
            return Err(bad(format!(
                "last block size {last} exceeds the block size {bs}"
            )));
        }
        let total = (nb - 1)
            .checked_mul(bs)
            .and_then(|x| x.checked_add(last))
            .ok_or_else(|| bad("block sizes overflow".into()))?;
        let ctotal = sizes
            .iter()
            .try_fold(0u64, |s, &c| s.checked_add(c))
            .filter(|&c| c <= data.len() as u64)
            .ok_or_else(|| {
                bad(format!(
                    "compressed blocks need more than the {} bytes there are (truncated file?)",
                    data.len()
                ))
            })?;
        // zlib cannot expand more than ~1032:1; refuse before allocating for a lying header.
        if total > ctotal.saturating_mul(1100).saturating_add(1024) {
            return Err(bad(format!(
                "header claims {total} bytes uncompressed from {ctotal} compressed"
            )));
        }
        // A decompression bomb (a few MB inflating to GB for 128 points) is refused here, from
        // the header alone, before a byte is inflated.
        if let Some(want) = limit {
            if total > want {
                return Err(bad(format!(
                    "header says {total} bytes uncompressed, but the array's values take {want}"
                )));
            }
        }
        let mut out = Vec::with_capacity(total as usize);
        let mut at = 0usize;
        for (i, &c) in sizes.iter().enumerate() {
            let want = if i as u64 == nb - 1 { last } else { bs };
            let chunk = &data[at..at + c as usize];
            at += c as usize;
            let before = out.len();
            flate2::read::ZlibDecoder::new(chunk)
                .take(want + 1)
                .read_to_end(&mut out)
                .map_err(|e| bad(format!("zlib block {i}: {e}")))?;
            if (out.len() - before) as u64 != want {
                return Err(bad(format!(
                    "zlib block {i} inflates to {} bytes, not {want}",
                    out.len() - before
                )));
            }
        }
        Ok(out)
    }

    pub(super) fn check_count(&self, a: &Array, got: usize, expected: Option<usize>) -> Result<()> {
        match expected {
            Some(n) if n != got => Err(self.err(a, format!("{got} values, expected {n}"))),
            _ => Ok(()),
        }
    }

    pub(super) fn ascii<T>(
        &self,
        a: &Array,
        expected: Option<usize>,
        parse: impl Fn(&str) -> Option<T>,
    ) -> Result<Vec<T>> {
        if let Some(n) = expected {
            if n > a.text.len() / 2 + 1 {
                return Err(self.err(a, format!("{n} values expected but the text holds fewer")));
            }
        }
        let v = a
            .text
            .split_ascii_whitespace()
            .map(|t| {
                parse(t)
                    .ok_or_else(|| self.err(a, format!("'{}' is not a valid value", one_line(t))))
            })
            .collect::<Result<Vec<T>>>()?;
        self.check_count(a, v.len(), expected)?;
        Ok(v)
    }

    /// The decoded bytes of a binary (inline or appended) array: a whole number of `ty` values,
    /// `expected` of them when given.
    pub(super) fn binary(&self, a: &Array, ty: DType, expected: Option<usize>) -> Result<Vec<u8>> {
        let limit = expected.and_then(|n| (n as u64).checked_mul(ty.size() as u64));
        let p = self.payload(a, limit)?;
        if p.len() % ty.size() != 0 {
            return Err(self.err(
                a,
                format!("{} bytes is not a whole number of {:?}", p.len(), ty),
            ));
        }
        self.check_count(a, p.len() / ty.size(), expected)?;
        Ok(p)
    }

    pub(super) fn floats(&self, a: &Array, expected: Option<usize>) -> Result<Vec<f64>> {
        let ty = self.dtype(a)?;
        if a.format == Format::Ascii {
            return self.ascii(a, expected, |t| t.parse::<f64>().ok());
        }
        let p = self.binary(a, ty, expected)?;
        Ok(vtk_types::decode_f64(&p, ty, self.big))
    }

    pub(super) fn ints(&self, a: &Array, expected: Option<usize>) -> Result<Vec<i64>> {
        let ty = self.dtype(a)?;
        if a.format == Format::Ascii {
            return self.ascii(a, expected, |t| t.parse::<i64>().ok());
        }
        let p = self.binary(a, ty, expected)?;
        vtk_types::decode_i64(&p, ty, self.big).map_err(|m| self.err(a, m))
    }
}
