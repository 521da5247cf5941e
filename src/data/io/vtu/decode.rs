//! Decoding a `<DataArray>`: ascii, inline base64, appended raw or base64,
//! zlib-compressed blocks, length headers of 32 or 64 bits; and the checks
//! of its length against what the mesh needs.

use std::borrow::Cow;
use std::io::Read;

use base64::Engine;

use super::{ArrayDesc, Ctx, Format};
use crate::data::io::numeric::{decode_f64, decode_i64, NumType};
use crate::error::{Error, Result};

impl Ctx<'_> {
    pub(crate) fn err(&self, a: &ArrayDesc, msg: impl Into<String>) -> Error {
        Error::data(self.path, a.loc(), msg)
    }

    pub(super) fn uint(&self, b: &[u8]) -> u64 {
        if self.header_u64 {
            decode_i64(b, NumType::U64, self.big_endian)
                .and_then(|v| v.first().copied())
                .unwrap_or(0) as u64
        } else {
            decode_i64(b, NumType::U32, self.big_endian)
                .and_then(|v| v.first().copied())
                .unwrap_or(0) as u64
        }
    }

    /// Base64 text that may be several separately padded runs (VTK encodes
    /// the header and the data separately).
    pub(super) fn base64(&self, a: &ArrayDesc, text: &[u8]) -> Result<Vec<u8>> {
        let clean: Vec<u8> = text
            .iter()
            .copied()
            .filter(|b| !b.is_ascii_whitespace())
            .collect();
        let mut out = Vec::with_capacity(clean.len() / 4 * 3);
        let mut start = 0;
        let mut i = 0;
        while i < clean.len() {
            if clean[i] == b'=' {
                while i < clean.len() && clean[i] == b'=' {
                    i += 1;
                }
                self.decode_run(a, &clean[start..i], start, &mut out)?;
                start = i;
            } else {
                i += 1;
            }
        }
        self.decode_run(a, &clean[start..], start, &mut out)?;
        Ok(out)
    }

    pub(super) fn decode_run(
        &self,
        a: &ArrayDesc,
        run: &[u8],
        at: usize,
        out: &mut Vec<u8>,
    ) -> Result<()> {
        if run.is_empty() {
            return Ok(());
        }
        base64::engine::general_purpose::STANDARD
            .decode_vec(run, out)
            .map_err(|e| {
                self.err(
                    a,
                    format!("invalid base64 data (at character {at} of the array's text): {e}"),
                )
            })
    }

    /// The data bytes of a binary or appended array, after its header and
    /// decompression. `raw` starts at the array's header.
    pub(super) fn payload<'r>(&self, a: &ArrayDesc, raw: &'r [u8]) -> Result<Cow<'r, [u8]>> {
        let hs = if self.header_u64 { 8 } else { 4 };
        let trunc = |need: u64, what: &str| {
            self.err(
                a,
                format!(
                    "data is truncated: {what} needs {need} bytes, only {} are present",
                    raw.len()
                ),
            )
        };
        if raw.len() < hs {
            return Err(trunc(hs as u64, "the length header"));
        }
        if !self.zlib {
            let n = self.uint(&raw[..hs]);
            if n > (raw.len() - hs) as u64 {
                return Err(trunc(n + hs as u64, &format!("the header (\"{n} bytes\")")));
            }
            // Uncompressed: the file's own bytes, not a copy.
            return Ok(Cow::Borrowed(&raw[hs..hs + n as usize]));
        }
        if raw.len() < 3 * hs {
            return Err(trunc(3 * hs as u64, "the compression header"));
        }
        let nblocks = self.uint(&raw[..hs]);
        let bs = self.uint(&raw[hs..2 * hs]);
        let last = self.uint(&raw[2 * hs..3 * hs]);
        let head = (3 + nblocks as u128) * hs as u128;
        if head > raw.len() as u128 {
            return Err(trunc(
                head as u64,
                &format!("the compression header of {nblocks} blocks"),
            ));
        }
        let sizes: Vec<u64> = (0..nblocks as usize)
            .map(|k| self.uint(&raw[(3 + k) * hs..(4 + k) * hs]))
            .collect();
        let total: u128 = sizes.iter().map(|&s| s as u128).sum();
        if head + total > raw.len() as u128 {
            return Err(trunc(
                (head + total) as u64,
                &format!("{nblocks} compressed block(s)"),
            ));
        }
        let expected_total = if nblocks == 0 {
            0
        } else {
            (nblocks as u128 - 1) * bs as u128 + if last == 0 { bs } else { last } as u128
        };
        if expected_total > 1 << 40 {
            return Err(self.err(
                a,
                format!("compression header claims {expected_total} bytes of data"),
            ));
        }
        let mut starts = Vec::with_capacity(sizes.len());
        let mut p = head as usize;
        for &cs in &sizes {
            starts.push(p);
            p += cs as usize;
        }
        let want = |k: usize| {
            if k + 1 == sizes.len() && last != 0 {
                last
            } else {
                bs
            }
        };
        let short = |k: usize, got: usize| {
            self.err(
                a,
                format!(
                    "zlib block {k} of {nblocks} inflates to {got} bytes, the header says {}",
                    want(k)
                ),
            )
        };
        if expected_total <= raw.len() as u128 * 8 && bs > 0 && last <= bs {
            // Blocks inflated on all cores, each into its own slice.
            use rayon::prelude::*;
            let mut out = vec![0u8; expected_total as usize];
            let firsts: Vec<(usize, std::result::Result<usize, String>)> = out
                .par_chunks_mut(bs as usize)
                .enumerate()
                .map(|(k, dst)| {
                    let block = &raw[starts[k]..starts[k] + sizes[k] as usize];
                    let mut d = flate2::read::ZlibDecoder::new(block);
                    let mut got = 0;
                    while got < dst.len() {
                        match d.read(&mut dst[got..]) {
                            Ok(0) => break,
                            Ok(n) => got += n,
                            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                            Err(e) => return (k, Err(e.to_string())),
                        }
                    }
                    (k, Ok(got))
                })
                .collect();
            for (k, r) in firsts {
                match r {
                    Err(e) => return Err(self.err(a, format!("zlib block {k} of {nblocks}: {e}"))),
                    Ok(got) if got as u64 != want(k) => return Err(short(k, got)),
                    Ok(_) => {}
                }
            }
            return Ok(Cow::Owned(out));
        }
        let mut out = Vec::with_capacity(expected_total.min(raw.len() as u128 * 8) as usize);
        for (k, &start) in starts.iter().enumerate() {
            let block = &raw[start..start + sizes[k] as usize];
            let before = out.len();
            flate2::read::ZlibDecoder::new(block)
                .take(want(k))
                .read_to_end(&mut out)
                .map_err(|e| self.err(a, format!("zlib block {k} of {nblocks}: {e}")))?;
            if (out.len() - before) as u64 != want(k) {
                return Err(short(k, out.len() - before));
            }
        }
        Ok(Cow::Owned(out))
    }

    /// The decoded bytes of a binary or appended array (empty for ascii):
    /// raw uncompressed appended data is borrowed from the file.
    pub(crate) fn bytes<'s>(&'s self, a: &'s ArrayDesc) -> Result<Cow<'s, [u8]>> {
        match a.format {
            Format::Binary => {
                let raw = self.base64(a, &a.text)?;
                Ok(Cow::Owned(self.payload(a, &raw)?.into_owned()))
            }
            Format::Appended => {
                let (body, b64) = self.appended.ok_or_else(|| {
                    self.err(a, "format=\"appended\" but the file has no <AppendedData>")
                })?;
                if a.offset > body.len() {
                    return Err(self.err(
                        a,
                        format!(
                            "offset {} is past the end of the appended data ({} bytes)",
                            a.offset,
                            body.len()
                        ),
                    ));
                }
                if b64 {
                    let end = self.appended_end(a.offset, body.len());
                    let raw = self.base64(a, &body[a.offset..end])?;
                    Ok(Cow::Owned(self.payload(a, &raw)?.into_owned()))
                } else {
                    self.payload(a, &body[a.offset..])
                }
            }
            Format::Ascii => Ok(Cow::Borrowed(&[])),
        }
    }

    /// The values of an ascii array.
    pub(crate) fn ascii<T: std::str::FromStr>(&self, a: &ArrayDesc, what: &str) -> Result<Vec<T>> {
        let text =
            std::str::from_utf8(&a.text).map_err(|_| self.err(a, "ascii data is not text"))?;
        text.split_ascii_whitespace()
            .enumerate()
            .map(|(i, t)| {
                t.parse::<T>().map_err(|_| {
                    self.err(
                        a,
                        format!(
                            "value {i}: \"{}\" is not a valid {what}",
                            t.chars().take(40).collect::<String>()
                        ),
                    )
                })
            })
            .collect()
    }

    pub(super) fn f64s(&self, a: &ArrayDesc, expected: usize) -> Result<Vec<f64>> {
        let v = match a.format {
            Format::Ascii => {
                let v: Vec<f64> = self.ascii(a, "number")?;
                if a.ty == NumType::F32 {
                    v.into_iter().map(|x| x as f32 as f64).collect()
                } else {
                    v
                }
            }
            _ => {
                let b = self.bytes(a)?;
                self.check_len(a, b.len())?;
                decode_f64(&b, a.ty, self.big_endian)
            }
        };
        self.check_count(a, v.len(), expected)?;
        Ok(v)
    }

    pub(super) fn i64s(&self, a: &ArrayDesc, expected: usize) -> Result<Vec<i64>> {
        if a.ty.is_float() {
            return Err(self.err(
                a,
                format!("must be an integer array, found type {:?}", a.ty),
            ));
        }
        let v = match a.format {
            Format::Ascii => self.ascii(a, "integer")?,
            _ => {
                let b = self.bytes(a)?;
                self.check_len(a, b.len())?;
                decode_i64(&b, a.ty, self.big_endian).unwrap_or_default()
            }
        };
        self.check_count(a, v.len(), expected)?;
        Ok(v)
    }

    pub(super) fn check_len(&self, a: &ArrayDesc, n: usize) -> Result<()> {
        if !n.is_multiple_of(a.ty.size()) {
            return Err(self.err(
                a,
                format!(
                    "{n} bytes of data is not a whole number of {:?} values",
                    a.ty
                ),
            ));
        }
        Ok(())
    }

    pub(super) fn check_count(&self, a: &ArrayDesc, got: usize, expected: usize) -> Result<()> {
        if got != expected {
            return Err(self.err(
                a,
                format!("has {got} values, expected {expected} (counts disagree with the data)"),
            ));
        }
        Ok(())
    }
}
