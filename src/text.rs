//! Small text helpers shared by every room (reports, the job layer, the
//! frontends).

/// `n` and the noun, plural unless `n == 1` ("1 thread", "4 threads").
pub fn plural(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}
