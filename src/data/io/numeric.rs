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

macro_rules! decode_as {
    ($bytes:expr, $big:expr, $t:ty, $out:ty) => {{
        const N: usize = std::mem::size_of::<$t>();
        $bytes
            .chunks_exact(N)
            .map(|c| {
                let mut a = [0u8; N];
                a.copy_from_slice(c);
                (if $big {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }) as $out
            })
            .collect()
    }};
}

/// Decodes `bytes` (whose length should be a multiple of `ty.size()`; a
/// trailing partial value is ignored) as values of `ty` into `f64`.
pub fn decode_f64(bytes: &[u8], ty: NumType, big_endian: bool) -> Vec<f64> {
    match ty {
        NumType::I8 => decode_as!(bytes, big_endian, i8, f64),
        NumType::U8 => decode_as!(bytes, big_endian, u8, f64),
        NumType::I16 => decode_as!(bytes, big_endian, i16, f64),
        NumType::U16 => decode_as!(bytes, big_endian, u16, f64),
        NumType::I32 => decode_as!(bytes, big_endian, i32, f64),
        NumType::U32 => decode_as!(bytes, big_endian, u32, f64),
        NumType::I64 => decode_as!(bytes, big_endian, i64, f64),
        NumType::U64 => decode_as!(bytes, big_endian, u64, f64),
        NumType::F32 => decode_as!(bytes, big_endian, f32, f64),
        NumType::F64 => decode_as!(bytes, big_endian, f64, f64),
    }
}

/// Decodes `bytes` as integers of `ty` into `i64` (`u64` values above
/// `i64::MAX` wrap to negative numbers, which every caller rejects as an
/// index). `None` for a floating-point `ty`.
pub fn decode_i64(bytes: &[u8], ty: NumType, big_endian: bool) -> Option<Vec<i64>> {
    Some(match ty {
        NumType::I8 => decode_as!(bytes, big_endian, i8, i64),
        NumType::U8 => decode_as!(bytes, big_endian, u8, i64),
        NumType::I16 => decode_as!(bytes, big_endian, i16, i64),
        NumType::U16 => decode_as!(bytes, big_endian, u16, i64),
        NumType::I32 => decode_as!(bytes, big_endian, i32, i64),
        NumType::U32 => decode_as!(bytes, big_endian, u32, i64),
        NumType::I64 => decode_as!(bytes, big_endian, i64, i64),
        NumType::U64 => decode_as!(bytes, big_endian, u64, i64),
        NumType::F32 | NumType::F64 => return None,
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
}
