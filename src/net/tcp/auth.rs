//! The shared token and HMAC-SHA256 (crates `hmac` and `sha2`; no
//! hand-rolled crypto). A token file holds at least [`MIN_TOKEN_BYTES`]
//! bytes (random bytes, or text such as the hex that `pvrsim cluster --transport
//! processes` writes).

use std::path::Path;

use hmac::{Hmac, Mac};
use sha2::Sha256;

use crate::net::error::{NetError, NetResult};

/// Fewest bytes a token may have.
pub const MIN_TOKEN_BYTES: usize = 32;
/// Bytes of a nonce and of a MAC.
pub const NONCE_BYTES: usize = 32;

/// The shared secret of a cluster. Without a file, the empty token: allowed
/// on loopback only (see [`crate::net::tcp::is_loopback`]).
#[derive(Clone, PartialEq, Eq)]
pub struct Token(Vec<u8>);

impl std::fmt::Debug for Token {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Token({} bytes)", self.0.len())
    }
}

impl Token {
    /// No token (loopback only): the handshake still runs, with an empty key,
    /// and authenticates nothing.
    pub fn none() -> Token {
        Token(Vec::new())
    }

    /// True for [`Token::none`].
    pub fn is_none(&self) -> bool {
        self.0.is_empty()
    }

    /// A fresh token: 32 random bytes written as 64 hex characters (the
    /// key is the text, so the token equals what [`Token::load`] reads back
    /// from the file [`Token::save`] writes).
    pub fn random() -> NetResult<Token> {
        let hex: String = random_bytes::<32>()?
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        Ok(Token(hex.into_bytes()))
    }

    /// Reads a token file: its bytes with surrounding whitespace trimmed
    /// (so an editor's newline does not change the key); at least
    /// [`MIN_TOKEN_BYTES`].
    pub fn load(path: &Path) -> NetResult<Token> {
        let bytes = std::fs::read(path).map_err(|e| NetError::Io {
            what: format!("reading token file {}", path.display()),
            msg: e.to_string(),
        })?;
        let start = bytes
            .iter()
            .position(|b| !b.is_ascii_whitespace())
            .unwrap_or(bytes.len());
        let end = bytes
            .iter()
            .rposition(|b| !b.is_ascii_whitespace())
            .map_or(start, |e| e + 1);
        let t = &bytes[start..end];
        if let Some(w) = exposure_warning(path) {
            eprintln!("pvrsim: warning: {w}");
        }
        if t.len() < MIN_TOKEN_BYTES {
            return Err(NetError::Io {
                what: format!("token file {}", path.display()),
                msg: format!(
                    "holds {} bytes; a token needs at least {MIN_TOKEN_BYTES} random bytes \
                     (e.g. `head -c 32 /dev/urandom | xxd -p -c 64 > FILE`)",
                    t.len()
                ),
            });
        }
        Ok(Token(t.to_vec()))
    }

    /// Writes the token to `path`, readable by the owner only.
    pub fn save(&self, path: &Path) -> NetResult<()> {
        use std::io::Write;
        let io = |e: std::io::Error| NetError::Io {
            what: format!("writing token file {}", path.display()),
            msg: e.to_string(),
        };
        let mut o = std::fs::OpenOptions::new();
        o.write(true).create(true).truncate(true);
        #[cfg(unix)]
        {
            use std::os::unix::fs::OpenOptionsExt;
            o.mode(0o600);
        }
        let mut f = o.open(path).map_err(io)?;
        f.write_all(&self.0).map_err(io)?;
        f.write_all(b"\n").map_err(io)
    }

    /// `HMAC-SHA256(token, label || parts...)`.
    pub fn mac(&self, label: &[u8], parts: &[&[u8]]) -> [u8; NONCE_BYTES] {
        let mut m = self.hmac();
        m.update(label);
        for p in parts {
            m.update(p);
        }
        m.finalize().into_bytes().into()
    }

    /// Checks `tag` against `HMAC-SHA256(token, label || parts...)` in
    /// constant time (the `hmac` crate's `verify_slice`).
    pub fn verify(&self, label: &[u8], parts: &[&[u8]], tag: &[u8]) -> bool {
        let mut m = self.hmac();
        m.update(label);
        for p in parts {
            m.update(p);
        }
        m.verify_slice(tag).is_ok()
    }

    fn hmac(&self) -> Hmac<Sha256> {
        // HMAC takes keys of any length (RFC 2104), so this cannot fail.
        <Hmac<Sha256> as Mac>::new_from_slice(&self.0).unwrap_or_else(|_| unreachable!())
    }
}

/// A warning if the token file at `path` may be read by users other than
/// its owner (group or other read bits), as ssh warns for a key file.
pub fn exposure_warning(path: &Path) -> Option<String> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(path).ok()?.permissions().mode() & 0o777;
        if mode & 0o044 != 0 {
            return Some(format!(
                "token file {} is readable by others (mode {mode:03o}); anyone who can read it \
                 can join or drive this cluster: chmod 600 {}",
                path.display(),
                path.display()
            ));
        }
    }
    #[cfg(not(unix))]
    let _ = path;
    None
}

/// `N` bytes from the operating system's random source.
pub fn random_bytes<const N: usize>() -> NetResult<[u8; N]> {
    let mut b = [0u8; N];
    getrandom::fill(&mut b).map_err(|e| NetError::Io {
        what: "reading the OS random source".into(),
        msg: e.to_string(),
    })?;
    Ok(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_token_file_is_refused_with_its_name() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("tok");
        std::fs::write(&p, "abc\n").unwrap();
        let e = Token::load(&p).unwrap_err().to_string();
        assert!(e.contains("tok") && e.contains("at least 32"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn world_readable_token_file_is_warned_about() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("tok");
        std::fs::write(&p, [b'a'; 40]).unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o644)).unwrap();
        let w = exposure_warning(&p).unwrap();
        assert!(w.contains("tok") && w.contains("644"), "{w}");
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o600)).unwrap();
        assert!(exposure_warning(&p).is_none());
    }

    #[test]
    fn saved_token_loads_back_and_macs_differ_by_key() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("tok");
        let t = Token::random().unwrap();
        t.save(&p).unwrap();
        let back = Token::load(&p).unwrap();
        assert_eq!(back, t);
        let m = back.mac(b"x", &[b"y"]);
        assert!(back.verify(b"x", &[b"y"], &m));
        assert!(!Token::random().unwrap().verify(b"x", &[b"y"], &m));
        assert!(!back.verify(b"x", &[b"z"], &m));
    }
}
