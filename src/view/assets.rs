//! The page, embedded in the binary (no build step): plain HTML, CSS and
//! JavaScript modules from `src/view/assets/`.

/// The page (`GET /`).
pub const INDEX_HTML: &str = include_str!("assets/index.html");

/// The page's modules and style by name (`GET /assets/NAME`): MIME type
/// and text.
pub fn get(name: &str) -> Option<(&'static str, &'static str)> {
    const JS: &str = "text/javascript; charset=utf-8";
    Some(match name {
        "app.js" => (JS, include_str!("assets/app.js")),
        "camera.js" => (JS, include_str!("assets/camera.js")),
        "tf.js" => (JS, include_str!("assets/tf.js")),
        "style.css" => ("text/css; charset=utf-8", include_str!("assets/style.css")),
        _ => return None,
    })
}
