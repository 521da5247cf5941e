//! Small text helpers shared by every room (reports, the job layer, the
//! frontends): plurals and the plot font.

/// `n` and the noun, plural unless `n == 1` ("1 thread", "4 threads").
pub fn plural(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// Registers DejaVu Sans as plotters' `sans-serif` (once).
pub fn register_fonts() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TTF shipped by the crate; a failure would only lose text.
        let _ = plotters::style::register_font(
            "sans-serif",
            plotters::style::FontStyle::Normal,
            dejavu::sans::regular(),
        );
        let _ = plotters::style::register_font(
            "sans-serif",
            plotters::style::FontStyle::Bold,
            dejavu::sans::bold(),
        );
    });
}
