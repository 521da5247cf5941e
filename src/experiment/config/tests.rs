//! Tests of the sweep config: a full example parses into the expected
//! plan; errors name the file and the key.

use std::path::{Path, PathBuf};

use super::*;

fn parse(text: &str) -> anyhow::Result<Plan> {
    Plan::parse(text, Path::new("configs/t.toml"))
}

#[test]
fn full_example() {
    let p = parse(
        r#"
name = "t"
scene = "scene.toml"
requires = ["data.vtk"]
repetitions = 3
[fixed]
threads = 1
compare = true
[vary]
tile = [16, 32]
ert_table = { from = 5, to = 15, step = 5 }
[[zip]]
width = [10, 20]
height = [30, 40]
[[plot]]
x = "ert_table"
y = ["time_scan_s"]
[[plot]]
x = "width"
y = "time_scan_s"
[summary]
columns = ["time_scan_s"]
"#,
    )
    .unwrap();
    assert_eq!(p.repetitions, 3);
    assert_eq!(p.grid.len(), 2 * 3 * 2);
    assert_eq!(p.points().len(), 12);
    assert_eq!(
        p.param_names(),
        [
            "tile",
            "ert_table",
            "width",
            "height",
            "scene",
            "threads",
            "compare"
        ]
    );
    assert_eq!(p.plots[0].series, ["tile", "width", "height"]);
    assert_eq!(
        p.plots[1].series,
        ["tile", "ert_table"],
        "zip partners of x are not series"
    );
    assert_eq!(p.plots[0].file, "time_scan_s-vs-ert_table.png");
    assert_eq!(p.requires, [PathBuf::from("configs/data.vtk")]);
    assert_eq!(p.origin("width"), "zip[0].width");
}

#[test]
fn errors_name_file_and_key() {
    for (text, key) in [
        ("name = \"t\"\nscene = \"s\"\nrepetitons = 2", "repetitons"),
        ("name = \"t\"\nscene = \"s\"\n[vary]\ntile = 3", "vary.tile"),
        (
            "name = \"t\"\nscene = \"s\"\n[fixed]\ntile = [1, 2]",
            "fixed.tile",
        ),
        (
            "name = \"t\"\nscene = \"s\"\n[fixed]\ntile = 1\n[vary]\ntile = [1]",
            "vary.tile",
        ),
        (
            "name = \"t\"\nscene = \"s\"\n[[zip]]\nwidth = [1]\nheight = [1, 2]",
            "zip[0].height",
        ),
        (
            "name = \"t\"\nscene = \"s\"\ncommand = \"paint\"",
            "command",
        ),
        (
            "name = \"t\"\nscene = \"s\"\n[[plot]]\nx = \"a\"\ny = \"b\"\nkind = \"pie\"",
            "plot[0].kind",
        ),
        (
            "name = \"t\"\nscene = \"s\"\n[[plot]]\nx = \"a\"\ny = \"b\"\nseries = \"zz\"",
            "plot[0].series",
        ),
        ("name = \"t\"\nscene = \"s\"\n[fixed]\nstatus = 1", "status"),
        ("name = \"t\"", "scene"),
        ("name = \"t/..\"\nscene = \"s\"", "name"),
    ] {
        let e = parse(text).unwrap_err().to_string();
        assert!(
            e.starts_with("configs/t.toml: ") && e.contains(key),
            "{text}\n=> {e}"
        );
    }
}
