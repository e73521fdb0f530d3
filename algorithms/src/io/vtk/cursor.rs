//! The reader's cursor over the file's bytes: lines and keywords, and arrays of values read as
//! ASCII tokens or big-endian binary, every count checked against the bytes left before
//! anything is allocated.

use std::fmt::Display;

use crate::error::{Error, Result};
use crate::io::vtk_types::{self, DType};

/// What a data array holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Ty {
    Num(DType),
    Bit,
    Str,
}

pub(super) struct Cur<'a> {
    pub(super) b: &'a [u8],
    pub(super) pos: usize,
    pub(super) line: usize,
    pub(super) src: &'a str,
    pub(super) binary: bool,
    /// The line terminator: `\n` (with or without `\r` before it), or `\r` for a file with
    /// CR-only line endings (classic Mac), detected from the first line.
    pub(super) eol: u8,
}

impl<'a> Cur<'a> {
    /// A cursor at the start of `bytes` (a UTF-8 byte-order mark skipped, as in every reader),
    /// ASCII until the header says otherwise; `src` names the file in messages.
    pub(super) fn new(bytes: &'a [u8], src: &'a str) -> Cur<'a> {
        let b = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        // CR-only line endings: the first line ends in a lone '\r'.
        let eol = match b.iter().position(|&c| c == b'\n' || c == b'\r') {
            Some(i) if b[i] == b'\r' && b.get(i + 1) != Some(&b'\n') => b'\r',
            _ => b'\n',
        };
        Cur {
            b,
            pos: 0,
            line: 1,
            src,
            binary: false,
            eol,
        }
    }

    pub(super) fn err(&self, line: usize, msg: impl Display) -> Error {
        Error::input(format!("{}:{line}", self.src), msg)
    }

    pub(super) fn remaining(&self) -> usize {
        self.b.len() - self.pos
    }

    pub(super) fn skip_ws(&mut self) {
        while self.pos < self.b.len() && self.b[self.pos].is_ascii_whitespace() {
            if self.b[self.pos] == self.eol {
                self.line += 1;
            }
            self.pos += 1;
        }
    }

    /// The rest of the current line (without `\r\n`), and its line number.
    pub(super) fn raw_line(&mut self) -> Option<(usize, &'a [u8])> {
        if self.pos >= self.b.len() {
            return None;
        }
        let start = self.pos;
        let l = self.line;
        let eol = self.eol;
        let end = match self.b[start..].iter().position(|&c| c == eol) {
            Some(i) => {
                self.pos = start + i + 1;
                self.line += 1;
                start + i
            }
            None => {
                self.pos = self.b.len();
                self.b.len()
            }
        };
        let mut s = &self.b[start..end];
        if s.last() == Some(&b'\r') {
            s = &s[..s.len() - 1];
        }
        Some((l, s))
    }

    /// The next non-blank line, split into words.
    pub(super) fn keyword_line(&mut self) -> Result<Option<(usize, Vec<&'a str>)>> {
        self.skip_ws();
        let Some((l, s)) = self.raw_line() else {
            return Ok(None);
        };
        let s = std::str::from_utf8(s)
            .map_err(|_| self.err(l, "expected a keyword line, found binary data"))?;
        Ok(Some((l, s.split_whitespace().collect())))
    }

    /// The next word, upper-cased, without consuming anything.
    pub(super) fn peek_word(&self) -> String {
        let mut p = self.pos;
        while p < self.b.len() && self.b[p].is_ascii_whitespace() {
            p += 1;
        }
        let s = p;
        while p < self.b.len() && !self.b[p].is_ascii_whitespace() && p - s < 32 {
            p += 1;
        }
        String::from_utf8_lossy(&self.b[s..p]).to_ascii_uppercase()
    }

    pub(super) fn token(&mut self) -> Option<&'a [u8]> {
        self.skip_ws();
        let s = self.pos;
        while self.pos < self.b.len() && !self.b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        (self.pos > s).then(|| &self.b[s..self.pos])
    }

    /// Refuses `n` values that the rest of the file could not hold, before anything is
    /// allocated for them; returns the byte count for binary data.
    pub(super) fn check_room(&self, n: usize, ty: Ty, what: &str, line: usize) -> Result<usize> {
        let rem = self.remaining();
        if self.binary {
            let bytes = match ty {
                Ty::Num(d) => n.checked_mul(d.size()),
                Ty::Bit => Some(n.div_ceil(8)),
                Ty::Str => Some(n), // at least a newline each
            };
            match bytes {
                Some(b) if b <= rem => Ok(b),
                _ => Err(self.err(
                    line,
                    format!("{what}: {n} values announced but only {rem} bytes remain (truncated file or wrong count)"),
                )),
            }
        } else if n > rem / 2 + 1 {
            Err(self.err(
                line,
                format!("{what}: {n} values announced but only {rem} bytes remain (truncated file or wrong count)"),
            ))
        } else {
            Ok(0)
        }
    }

    pub(super) fn ascii_tokens<T>(
        &mut self,
        n: usize,
        what: &str,
        mut parse: impl FnMut(&str) -> Option<T>,
    ) -> Result<Vec<T>> {
        let mut out = Vec::with_capacity(n);
        for k in 0..n {
            let Some(t) = self.token() else {
                return Err(self.err(
                    self.line,
                    format!("{what}: file ends after {k} of {n} values"),
                ));
            };
            let v = std::str::from_utf8(t).ok().and_then(&mut parse);
            match v {
                Some(v) => out.push(v),
                None => {
                    return Err(self.err(
                        self.line,
                        format!(
                            "{what}: '{}' is not a valid value",
                            String::from_utf8_lossy(&t[..t.len().min(40)]).escape_debug()
                        ),
                    ))
                }
            }
        }
        Ok(out)
    }

    pub(super) fn values(
        &mut self,
        n: usize,
        ty: DType,
        what: &str,
        line: usize,
    ) -> Result<Vec<f64>> {
        let bytes = self.check_room(n, Ty::Num(ty), what, line)?;
        if self.binary {
            let v = vtk_types::decode_f64(&self.b[self.pos..self.pos + bytes], ty, true);
            self.advance_binary(bytes);
            Ok(v)
        } else {
            self.ascii_tokens(n, what, |s| s.parse::<f64>().ok())
        }
    }

    pub(super) fn ints(
        &mut self,
        n: usize,
        ty: DType,
        what: &str,
        line: usize,
    ) -> Result<Vec<i64>> {
        let bytes = self.check_room(n, Ty::Num(ty), what, line)?;
        if self.binary {
            let v = vtk_types::decode_i64(&self.b[self.pos..self.pos + bytes], ty, true)
                .map_err(|m| self.err(line, format!("{what}: {m}")))?;
            self.advance_binary(bytes);
            Ok(v)
        } else {
            self.ascii_tokens(n, what, |s| s.parse::<i64>().ok())
        }
    }

    pub(super) fn skip(&mut self, n: usize, ty: Ty, what: &str, line: usize) -> Result<()> {
        let bytes = self.check_room(n, ty, what, line)?;
        if !self.binary {
            self.ascii_tokens(n, what, |_| Some(()))?;
        } else if ty == Ty::Str {
            for k in 0..n {
                if self.raw_line().is_none() {
                    return Err(
                        self.err(line, format!("{what}: file ends after {k} of {n} strings"))
                    );
                }
            }
        } else {
            self.advance_binary(bytes);
        }
        Ok(())
    }

    pub(super) fn advance_binary(&mut self, bytes: usize) {
        let end = self.pos + bytes;
        self.line += self.b[self.pos..end]
            .iter()
            .filter(|&&c| c == self.eol)
            .count();
        self.pos = end;
    }

    /// Skips a `METADATA` block (up to its blank line) if one follows.
    pub(super) fn metadata(&mut self) -> Result<()> {
        if self.peek_word() == "METADATA" {
            self.keyword_line()?;
            while let Some((_, s)) = self.raw_line() {
                if s.iter().all(|c| c.is_ascii_whitespace()) {
                    break;
                }
            }
        }
        Ok(())
    }
}

pub(super) fn count(c: &Cur, line: usize, w: &[&str], i: usize) -> Result<usize> {
    let kw = w[0];
    let Some(s) = w.get(i) else {
        return Err(c.err(line, format!("{kw}: missing count")));
    };
    match s.parse::<i64>() {
        Ok(v) if v >= 0 => {
            usize::try_from(v).map_err(|_| c.err(line, format!("{kw}: count {v} too large")))
        }
        Ok(v) => Err(c.err(line, format!("{kw}: negative count {v}"))),
        Err(_) => Err(c.err(line, format!("{kw}: '{}' is not a count", s.escape_debug()))),
    }
}

pub(super) fn ty_of(c: &Cur, line: usize, kw: &str, s: Option<&&str>) -> Result<Ty> {
    let Some(s) = s else {
        return Err(c.err(line, format!("{kw}: missing data type")));
    };
    match s.to_ascii_lowercase().as_str() {
        "bit" => Ok(Ty::Bit),
        "string" | "utf8_string" => Ok(Ty::Str),
        _ => DType::from_legacy(s).map(Ty::Num).ok_or_else(|| {
            c.err(
                line,
                format!("{kw}: unknown data type '{}'", s.escape_debug()),
            )
        }),
    }
}

pub(super) fn num_ty(c: &Cur, line: usize, kw: &str, s: Option<&&str>) -> Result<DType> {
    match ty_of(c, line, kw, s)? {
        Ty::Num(d) => Ok(d),
        _ => Err(c.err(line, format!("{kw}: a numeric data type is needed"))),
    }
}
