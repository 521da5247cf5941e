//! Fixed-size numeric types shared by the binary readers: their sizes, their
//! names in each format, and decoding a byte slice of them (either byte order)
//! into `f64` (field values, coordinates) or `i64` (indices, counts).

/// A fixed-size scalar type of a binary array.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NumType {
    /// Signed 8-bit integer.
    I8,
    /// Unsigned 8-bit integer.
    U8,
    /// Signed 16-bit integer.
    I16,
    /// Unsigned 16-bit integer.
    U16,
    /// Signed 32-bit integer.
    I32,
    /// Unsigned 32-bit integer.
    U32,
    /// Signed 64-bit integer.
    I64,
    /// Unsigned 64-bit integer.
    U64,
    /// IEEE 754 single precision.
    F32,
    /// IEEE 754 double precision.
    F64,
}

impl NumType {
    /// Size of one value in bytes.
    pub fn size(self) -> usize {
        match self {
            NumType::I8 | NumType::U8 => 1,
            NumType::I16 | NumType::U16 => 2,
            NumType::I32 | NumType::U32 | NumType::F32 => 4,
            NumType::I64 | NumType::U64 | NumType::F64 => 8,
        }
    }

    /// Whether this is a floating-point type.
    pub fn is_float(self) -> bool {
        matches!(self, NumType::F32 | NumType::F64)
    }

    /// The type named in a VTK legacy file (`float`, `double`, `int`,
    /// `unsigned_char`, `vtktypeint64`, ...). `long` and `unsigned_long` are
    /// taken as 64-bit, as VTK writes them on 64-bit Linux and macOS; `bit` and
    /// `string` arrays are not supported (`None`).
    pub fn from_vtk_legacy(name: &str) -> Option<NumType> {
        Some(match name.to_ascii_lowercase().as_str() {
            "char" | "signed_char" | "vtktypeint8" => NumType::I8,
            "unsigned_char" | "vtktypeuint8" => NumType::U8,
            "short" | "vtktypeint16" => NumType::I16,
            "unsigned_short" | "vtktypeuint16" => NumType::U16,
            "int" | "vtktypeint32" => NumType::I32,
            "unsigned_int" | "vtktypeuint32" => NumType::U32,
            "long" | "vtktypeint64" | "vtkidtype" | "long_long" => NumType::I64,
            "unsigned_long" | "vtktypeuint64" | "unsigned_long_long" => NumType::U64,
            "float" | "vtktypefloat32" => NumType::F32,
            "double" | "vtktypefloat64" => NumType::F64,
            _ => return None,
        })
    }

    /// The type named by a VTK XML `type` attribute (`Float32`, `Int64`, ...).
    pub fn from_vtk_xml(name: &str) -> Option<NumType> {
        Some(match name {
            "Int8" | "Char" => NumType::I8,
            "UInt8" => NumType::U8,
            "Int16" => NumType::I16,
            "UInt16" => NumType::U16,
            "Int32" => NumType::I32,
            "UInt32" => NumType::U32,
            "Int64" => NumType::I64,
            "UInt64" => NumType::U64,
            "Float32" => NumType::F32,
            "Float64" => NumType::F64,
            _ => return None,
        })
    }
}

macro_rules! decode_into {
    ($bytes:expr, $big:expr, $t:ty, $out:expr, $conv:expr) => {{
        const N: usize = std::mem::size_of::<$t>();
        for (o, c) in $out.iter_mut().zip($bytes.chunks_exact(N)) {
            let mut a = [0u8; N];
            a.copy_from_slice(c);
            *o = $conv(if $big {
                <$t>::from_be_bytes(a)
            } else {
                <$t>::from_le_bytes(a)
            });
        }
    }};
}

/// An output type of the decoders: what a stored value of each kind becomes
/// (the same as an `as` cast from the stored type).
trait Decoded: Copy + Send + Sync {
    /// Whether floating-point input decodes into this type (if not, it
    /// leaves the output as it was).
    const TAKES_FLOATS: bool;
    /// A signed integer (any width, widened to `i64`).
    fn from_i64(v: i64) -> Self;
    /// An unsigned 64-bit integer.
    fn from_u64(v: u64) -> Self;
    /// A floating-point value (either width, widened to `f64`).
    fn from_f64(v: f64) -> Self;
}

impl Decoded for f64 {
    const TAKES_FLOATS: bool = true;
    fn from_i64(v: i64) -> f64 {
        v as f64
    }
    fn from_u64(v: u64) -> f64 {
        v as f64
    }
    fn from_f64(v: f64) -> f64 {
        v
    }
}

impl Decoded for i64 {
    const TAKES_FLOATS: bool = false;
    fn from_i64(v: i64) -> i64 {
        v
    }
    fn from_u64(v: u64) -> i64 {
        v as i64
    }
    fn from_f64(v: f64) -> i64 {
        v as i64
    }
}

/// Decodes `o.len()` whole values of `ty` from `b` into `o`, on this thread.
fn decode_seq<T: Decoded>(b: &[u8], ty: NumType, big_endian: bool, o: &mut [T]) {
    let big = big_endian;
    match ty {
        NumType::I8 => decode_into!(b, big, i8, o, |v| T::from_i64(i64::from(v))),
        NumType::U8 => decode_into!(b, big, u8, o, |v| T::from_i64(i64::from(v))),
        NumType::I16 => decode_into!(b, big, i16, o, |v| T::from_i64(i64::from(v))),
        NumType::U16 => decode_into!(b, big, u16, o, |v| T::from_i64(i64::from(v))),
        NumType::I32 => decode_into!(b, big, i32, o, |v| T::from_i64(i64::from(v))),
        NumType::U32 => decode_into!(b, big, u32, o, |v| T::from_i64(i64::from(v))),
        NumType::I64 => decode_into!(b, big, i64, o, T::from_i64),
        NumType::U64 => decode_into!(b, big, u64, o, T::from_u64),
        NumType::F32 if T::TAKES_FLOATS => {
            decode_into!(b, big, f32, o, |v| T::from_f64(f64::from(v)))
        }
        NumType::F64 if T::TAKES_FLOATS => decode_into!(b, big, f64, o, T::from_f64),
        NumType::F32 | NumType::F64 => {}
    }
}

/// Values decoded per parallel task (large arrays are split into chunks of
/// this many values, decoded on all cores).
const CHUNK: usize = 1 << 16;

/// Decodes `bytes` (`out.len()` whole values of `ty`) into `out`, in
/// parallel chunks of [`CHUNK`] values.
fn decode_chunked<T: Decoded>(bytes: &[u8], ty: NumType, big_endian: bool, out: &mut [T]) {
    use rayon::prelude::*;
    out.par_chunks_mut(CHUNK)
        .zip(bytes.par_chunks(CHUNK * ty.size()))
        .for_each(|(o, b)| decode_seq(b, ty, big_endian, o));
}

/// Decodes `bytes` (`out.len()` whole values of `ty`) into `out`, in
/// parallel chunks.
pub fn decode_f64_into(bytes: &[u8], ty: NumType, big_endian: bool, out: &mut [f64]) {
    decode_chunked(bytes, ty, big_endian, out);
}

/// Decodes `bytes` as integers of `ty` into `out` (`out.len()` whole
/// values), in parallel chunks; `false` (and `out` unspecified) for a
/// floating-point `ty`.
pub fn decode_i64_into(bytes: &[u8], ty: NumType, big_endian: bool, out: &mut [i64]) -> bool {
    if ty.is_float() {
        return false;
    }
    decode_chunked(bytes, ty, big_endian, out);
    true
}

/// A vector of `n` copies of `value` for a large decoded array, filled on
/// all cores (so the first touch of its pages, the kernel's page faults and
/// zeroing, is spread over the cores too).
pub fn big_vec<T: Copy + Send + Sync>(n: usize, value: T) -> Vec<T> {
    use rayon::prelude::*;
    let mut v: Vec<T> = Vec::with_capacity(n);
    v.spare_capacity_mut()[..n]
        .par_chunks_mut(CHUNK)
        .for_each(|c| {
            for x in c {
                x.write(value);
            }
        });
    // SAFETY: the first `n` elements were just written.
    unsafe { v.set_len(n) };
    v
}

/// Decodes `bytes` (whose length should be a multiple of `ty.size()`; a
/// trailing partial value is ignored) as values of `ty` into `f64`, on all
/// cores for large arrays.
pub fn decode_f64(bytes: &[u8], ty: NumType, big_endian: bool) -> Vec<f64> {
    let mut out = big_vec(bytes.len() / ty.size(), 0.0);
    decode_f64_into(bytes, ty, big_endian, &mut out);
    out
}

/// Decodes `bytes` as integers of `ty` into `i64` (`u64` values above
/// `i64::MAX` wrap to negative numbers, which every caller rejects as an
/// index). `None` for a floating-point `ty`.
pub fn decode_i64(bytes: &[u8], ty: NumType, big_endian: bool) -> Option<Vec<i64>> {
    let mut out = big_vec(bytes.len() / ty.size(), 0);
    decode_i64_into(bytes, ty, big_endian, &mut out).then_some(out)
}

/// Decodes `n` points of three coordinates of `ty` into `[x, y, z]`
/// directly (no intermediate flat array).
pub fn decode_points(bytes: &[u8], ty: NumType, big_endian: bool) -> Vec<[f64; 3]> {
    let mut out = big_vec(bytes.len() / ty.size() / 3, [0.0; 3]);
    decode_f64_into(bytes, ty, big_endian, out.as_flattened_mut());
    out
}

/// Decodes `4 n` integer vertex indices of `ty` into tetrahedra, in
/// parallel, checking each index against `npoints`; `None` if any index is
/// negative or out of range (the caller then reports the first bad cell by
/// its general path), or for a floating-point `ty`.
pub fn decode_tets(
    bytes: &[u8],
    ty: NumType,
    big_endian: bool,
    npoints: usize,
) -> Option<Vec<[u32; 4]>> {
    use rayon::prelude::*;
    if ty.is_float() {
        return None;
    }
    let s = ty.size();
    let n = bytes.len() / s / 4;
    let mut out = big_vec(n, [0u32; 4]);
    let ok = out
        .par_chunks_mut(CHUNK)
        .zip(bytes.par_chunks(CHUNK * 4 * s))
        .all(|(o, b)| {
            // Decoded through a small stack buffer, 256 cells at a time.
            let mut buf = [0i64; 1024];
            let mut good = true;
            for (oc, bc) in o.chunks_mut(256).zip(b.chunks(1024 * s)) {
                let v = &mut buf[..oc.len() * 4];
                decode_seq(bc, ty, big_endian, v);
                for (t, c) in oc.iter_mut().zip(v.chunks_exact(4)) {
                    for k in 0..4 {
                        good &= c[k] >= 0 && (c[k] as u64) < npoints as u64;
                        t[k] = c[k] as u32;
                    }
                }
            }
            good
        });
    ok.then_some(out)
}

/// Decodes cells written as `4 i0 i1 i2 i3` (a count, then four indices:
/// the VTK legacy classic layout, all tetrahedra) into tetrahedra, in
/// parallel; `None` if any count is not 4 or any index is negative or not
/// below `npoints`, or for a floating-point `ty`.
pub fn decode_counted_tets(
    bytes: &[u8],
    ty: NumType,
    big_endian: bool,
    npoints: usize,
) -> Option<Vec<[u32; 4]>> {
    let mut out = big_vec(bytes.len() / ty.size() / 5, [0u32; 4]);
    decode_counted_tets_into(bytes, ty, big_endian, npoints, &mut out).then_some(out)
}

/// [`decode_counted_tets`] into `out` (`out.len()` cells); `false` on a
/// count other than 4, an index out of range, or a floating-point `ty`.
pub fn decode_counted_tets_into(
    bytes: &[u8],
    ty: NumType,
    big_endian: bool,
    npoints: usize,
    out: &mut [[u32; 4]],
) -> bool {
    use rayon::prelude::*;
    if ty.is_float() {
        return false;
    }
    let s = ty.size();
    out.par_chunks_mut(CHUNK)
        .zip(bytes.par_chunks(CHUNK * 5 * s))
        .all(|(o, b)| {
            let mut buf = [0i64; 1280];
            let mut good = true;
            for (oc, bc) in o.chunks_mut(256).zip(b.chunks(1280 * s)) {
                let v = &mut buf[..oc.len() * 5];
                decode_seq(bc, ty, big_endian, v);
                for (t, c) in oc.iter_mut().zip(v.chunks_exact(5)) {
                    good &= c[0] == 4;
                    for k in 0..4 {
                        good &= c[k + 1] >= 0 && (c[k + 1] as u64) < npoints as u64;
                        t[k] = c[k + 1] as u32;
                    }
                }
            }
            good
        })
}

/// Whether all `bytes` (integers of `ty`) equal `value`, checked in parallel.
pub fn all_equal(bytes: &[u8], ty: NumType, big_endian: bool, value: i64) -> bool {
    use rayon::prelude::*;
    if ty.is_float() {
        return false;
    }
    let s = ty.size();
    bytes.par_chunks(CHUNK * s).all(|b| {
        let mut buf = [0i64; 1024];
        b.chunks(1024 * s).all(|bc| {
            let v = &mut buf[..bc.len() / s];
            decode_seq(bc, ty, big_endian, v);
            v.iter().all(|&x| x == value)
        })
    })
}

/// Whether integers of `ty` in `bytes` are `0, step, 2 step, ...` (offsets
/// of cells that all have `step` vertices), checked in parallel.
pub fn is_arithmetic(bytes: &[u8], ty: NumType, big_endian: bool, step: i64) -> bool {
    use rayon::prelude::*;
    if ty.is_float() {
        return false;
    }
    let s = ty.size();
    bytes.par_chunks(CHUNK * s).enumerate().all(|(ci, b)| {
        let mut buf = [0i64; 1024];
        let mut base = (ci * CHUNK) as i64;
        b.chunks(1024 * s).all(|bc| {
            let v = &mut buf[..bc.len() / s];
            decode_seq(bc, ty, big_endian, v);
            let ok = v
                .iter()
                .enumerate()
                .all(|(i, &x)| x == (base + i as i64) * step);
            base += v.len() as i64;
            ok
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_both_byte_orders() {
        let be = 1.5f32.to_be_bytes();
        assert_eq!(decode_f64(&be, NumType::F32, true), vec![1.5]);
        let le = (-7i16).to_le_bytes();
        assert_eq!(decode_i64(&le, NumType::I16, false), Some(vec![-7]));
        assert_eq!(decode_i64(&le, NumType::F32, false), None);
    }

    // Each stored type decodes as an `as` cast from it would, at the ends
    // of its range, in both byte orders, to f64 and (integers) to i64.
    #[test]
    fn every_type_decodes_as_a_cast_from_it() {
        macro_rules! check {
            ($t:ty, $ty:expr) => {{
                let vals: Vec<$t> = vec![<$t>::MIN, 0 as $t, 1 as $t, 100 as $t, <$t>::MAX];
                for big in [false, true] {
                    let bytes: Vec<u8> = vals
                        .iter()
                        .flat_map(|v| {
                            if big {
                                v.to_be_bytes()
                            } else {
                                v.to_le_bytes()
                            }
                        })
                        .collect();
                    let f: Vec<f64> = vals.iter().map(|&v| v as f64).collect();
                    assert_eq!(decode_f64(&bytes, $ty, big), f, "{:?}", $ty);
                    let i: Vec<i64> = vals.iter().map(|&v| v as i64).collect();
                    let want = (!$ty.is_float()).then_some(i);
                    assert_eq!(decode_i64(&bytes, $ty, big), want, "{:?}", $ty);
                }
            }};
        }
        check!(i8, NumType::I8);
        check!(u8, NumType::U8);
        check!(i16, NumType::I16);
        check!(u16, NumType::U16);
        check!(i32, NumType::I32);
        check!(u32, NumType::U32);
        check!(i64, NumType::I64);
        check!(u64, NumType::U64);
        check!(f32, NumType::F32);
        check!(f64, NumType::F64);
    }
}
