//! The reader's lexer: lines, tokens, counts and binary blocks, with the
//! line or byte offset every error names.

use super::*;

impl<'a> Parser<'a> {
    pub(super) fn at_line(&self, offset: usize, msg: impl Into<String>) -> Error {
        Error::data(self.path, format!("line {}", line_of(self.d, offset)), msg)
    }

    pub(super) fn at_byte(&self, offset: usize, msg: impl Into<String>) -> Error {
        Error::data(self.path, format!("byte {offset}"), msg)
    }

    /// The next line, blank or not: `(start offset, text without the line end)`.
    pub(super) fn raw_line(&mut self) -> Result<Option<(usize, &'a str)>> {
        if self.pos >= self.d.len() {
            return Ok(None);
        }
        let start = self.pos;
        let end = self.d[start..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(self.d.len(), |i| start + i);
        self.pos = (end + 1).min(self.d.len());
        let bytes = &self.d[start..end];
        let text = std::str::from_utf8(bytes).map_err(|_| {
            self.at_line(
                start,
                "expected a line of text (a keyword), found binary data",
            )
        })?;
        Ok(Some((start, text.trim_end_matches('\r'))))
    }

    /// The next non-blank line, trimmed.
    pub(super) fn line(&mut self) -> Result<Option<(usize, &'a str)>> {
        loop {
            match self.raw_line()? {
                None => return Ok(None),
                Some((o, l)) if !l.trim().is_empty() => {
                    return Ok(Some((o + (l.len() - l.trim_start().len()), l.trim())))
                }
                Some(_) => {}
            }
        }
    }

    /// The first word (upper-cased) of the next non-blank line, without
    /// consuming it; `None` at the end or on binary data.
    pub(super) fn peek_keyword(&mut self) -> Option<String> {
        let save = self.pos;
        let kw = self
            .line()
            .ok()
            .flatten()
            .and_then(|(_, l)| l.split_whitespace().next().map(str::to_ascii_uppercase));
        self.pos = save;
        kw
    }

    pub(super) fn num_type(&self, at: usize, name: &str) -> Result<NumType> {
        NumType::from_vtk_legacy(name).ok_or_else(|| {
            self.at_line(at, format!("unsupported data type \"{}\" (supported: float, double, char, unsigned_char, short, unsigned_short, int, unsigned_int, long, unsigned_long, vtktypeint64, vtktypeuint64)", short(name)))
        })
    }

    pub(super) fn count(&self, at: usize, tok: Option<&str>, what: &str) -> Result<usize> {
        let tok = tok.ok_or_else(|| self.at_line(at, format!("missing {what}")))?;
        tok.parse::<usize>().map_err(|_| {
            self.at_line(
                at,
                format!(
                    "{what} must be a non-negative integer, found \"{}\"",
                    short(tok)
                ),
            )
        })
    }

    /// Bytes of the next binary block of `n` values of `ty`.
    pub(super) fn binary_block(&mut self, n: usize, ty: NumType, what: &str) -> Result<&'a [u8]> {
        let start = self.pos;
        let avail = self.d.len() - start;
        let need = n.checked_mul(ty.size()).filter(|&b| b <= avail).ok_or_else(|| {
            self.at_byte(
                start,
                format!("file is truncated: {what} needs {n} x {} = {} bytes of binary data from byte {start}, but only {avail} bytes remain", ty.size(), n as u128 * ty.size() as u128),
            )
        })?;
        self.pos += need;
        Ok(&self.d[start..start + need])
    }

    /// The next ASCII token and its offset.
    pub(super) fn token(&mut self) -> Option<(usize, &'a [u8])> {
        let d = self.d;
        let mut i = self.pos;
        while i < d.len() && d[i].is_ascii_whitespace() {
            i += 1;
        }
        if i >= d.len() {
            self.pos = i;
            return None;
        }
        let start = i;
        while i < d.len() && !d[i].is_ascii_whitespace() {
            i += 1;
        }
        self.pos = i;
        Some((start, &d[start..i]))
    }

    pub(super) fn ascii_values<T: std::str::FromStr>(
        &mut self,
        n: usize,
        ty: &str,
        what: &str,
    ) -> Result<Vec<T>> {
        let mut out = Vec::with_capacity(n.min(self.d.len() / 2 + 1));
        for k in 0..n {
            let (at, tok) = self.token().ok_or_else(|| {
                self.at_line(
                    self.d.len(),
                    format!("file ends after {k} of the {n} values of {what}"),
                )
            })?;
            let v = std::str::from_utf8(tok)
                .ok()
                .and_then(|s| s.parse::<T>().ok())
                .ok_or_else(|| {
                    self.at_line(
                        at,
                        format!(
                            "value {k} of {what}: \"{}\" is not a valid {ty} (expected {n} values)",
                            short(&String::from_utf8_lossy(tok))
                        ),
                    )
                })?;
            out.push(v);
        }
        Ok(out)
    }

    /// Gives back the mapped pages of the binary block `start..self.pos`
    /// (decoded).
    pub(super) fn release_from(&self, start: usize) {
        if let Some(f) = self.file {
            f.release(start, self.pos);
        }
    }

    /// `n` points of `ty` (binary: decoded on all cores straight into
    /// `[x, y, z]`).
    pub(super) fn points(&mut self, n: usize, ty: NumType) -> Result<Vec<[f64; 3]>> {
        if self.binary {
            let start = self.pos;
            let p = decode_points(
                self.binary_block(n.saturating_mul(3), ty, "POINTS")?,
                ty,
                true,
            );
            self.release_from(start);
            Ok(p)
        } else {
            let v = self.floats(n.saturating_mul(3), ty, "POINTS")?;
            Ok(v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
        }
    }

    /// `CELL_TYPES n`: binary blocks of type 10 only are checked in
    /// parallel and not stored.
    pub(super) fn cell_types(&mut self, n: usize) -> Result<TypeList> {
        if self.binary {
            let start = self.pos;
            let b = self.binary_block(n, NumType::I32, "CELL_TYPES")?;
            if super::super::numeric::all_equal(b, NumType::I32, true, 10) {
                self.release_from(start);
                return Ok(TypeList::AllTetra(n));
            }
            self.pos = start;
        }
        Ok(TypeList::Codes(self.ints(n, NumType::I32, "CELL_TYPES")?))
    }

    pub(super) fn floats(&mut self, n: usize, ty: NumType, what: &str) -> Result<Vec<f64>> {
        if self.binary {
            let start = self.pos;
            let v = decode_f64(self.binary_block(n, ty, what)?, ty, true);
            self.release_from(start);
            Ok(v)
        } else {
            let v: Vec<f64> = self.ascii_values(n, "number", what)?;
            // A `float` array holds single-precision values, as in VTK.
            Ok(if ty == NumType::F32 {
                v.into_iter().map(|x| x as f32 as f64).collect()
            } else {
                v
            })
        }
    }

    pub(super) fn ints(&mut self, n: usize, ty: NumType, what: &str) -> Result<Vec<i64>> {
        if self.binary {
            let start = self.pos;
            let b = self.binary_block(n, ty, what)?;
            let v = decode_i64(b, ty, true).unwrap_or_else(|| {
                decode_f64(b, ty, true)
                    .into_iter()
                    .map(|v| v as i64)
                    .collect()
            });
            self.release_from(start);
            Ok(v)
        } else {
            self.ascii_values(n, "integer", what)
        }
    }
}
