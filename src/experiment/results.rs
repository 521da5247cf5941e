//! Results of a sweep: `results.csv` (one row per run: every parameter, the
//! repetition, status, wall time, error, and every statistic flattened to
//! `a.b` columns) and `summary.md` (per point, medians over repetitions).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;

use super::config::Plan;
use super::grid::Point;

/// One CSV row: column -> text.
pub type Row = BTreeMap<String, String>;

/// The runs recorded so far, as read from and written to `results.csv`.
#[derive(Debug, Clone, Default)]
pub struct Results {
    /// The CSV file.
    pub path: PathBuf,
    /// Columns in first-seen order.
    pub columns: Vec<String>,
    /// Rows.
    pub rows: Vec<Row>,
    /// Columns of the file as last written (empty: not written by us yet).
    saved_columns: Vec<String>,
    /// Rows `..saved_rows` are in the file unchanged since the last write.
    saved_rows: usize,
}

/// Status text of a successful run.
pub const OK: &str = "ok";
/// Status text of a failed run.
pub const FAILED: &str = "failed";

impl Results {
    /// Reads `path` if it exists (an empty table otherwise).
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        let mut r = Results {
            path: path.to_path_buf(),
            ..Default::default()
        };
        if !path.exists() {
            return Ok(r);
        }
        let mut rd = csv::ReaderBuilder::new()
            .flexible(false)
            .from_path(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        r.columns = rd
            .headers()
            .with_context(|| format!("{}: bad header", path.display()))?
            .iter()
            .map(String::from)
            .collect();
        for (i, rec) in rd.records().enumerate() {
            let rec = rec.with_context(|| {
                format!(
                    "{}: bad row {} (delete the file or use --force)",
                    path.display(),
                    i + 2
                )
            })?;
            r.rows.push(
                r.columns
                    .iter()
                    .cloned()
                    .zip(rec.iter().map(String::from))
                    .filter(|(_, v)| !v.is_empty())
                    .collect(),
            );
        }
        Ok(r)
    }

    /// Index of the row of this point and repetition, if recorded.
    pub fn find(&self, point: &Point, repetition: usize) -> Option<usize> {
        let rep = repetition.to_string();
        self.rows
            .iter()
            .position(|row| row.get("repetition") == Some(&rep) && matches(row, point))
    }

    /// Rows of this point (every repetition).
    pub fn rows_of(&self, point: &Point) -> Vec<&Row> {
        self.rows.iter().filter(|row| matches(row, point)).collect()
    }

    /// Records a run, replacing an earlier row of the same point and repetition.
    pub fn record(
        &mut self,
        point: &Point,
        repetition: usize,
        wall_s: f64,
        outcome: &Result<serde_json::Value, String>,
    ) {
        let mut row = Row::new();
        let mut order: Vec<String> = Vec::new();
        let mut put = |row: &mut Row, k: String, v: String| {
            order.push(k.clone());
            row.insert(k, v);
        };
        for (k, v) in point {
            put(&mut row, k.clone(), v.to_string());
        }
        put(&mut row, "repetition".into(), repetition.to_string());
        put(
            &mut row,
            "status".into(),
            if outcome.is_ok() { OK } else { FAILED }.into(),
        );
        put(&mut row, "wall_s".into(), format!("{wall_s:.6}"));
        put(
            &mut row,
            "error".into(),
            outcome
                .as_ref()
                .err()
                .map(|e| e.replace(['\n', '\r'], " "))
                .unwrap_or_default(),
        );
        if let Ok(stats) = outcome {
            let mut flat = Vec::new();
            flatten("", stats, &mut flat);
            for (k, v) in flat {
                // A statistic named like a parameter (e.g. `threads`) keeps its value under `stats.NAME`.
                let k = if point.iter().any(|(p, _)| *p == k)
                    || ["repetition", "status", "wall_s", "error"].contains(&k.as_str())
                {
                    format!("stats.{k}")
                } else {
                    k
                };
                put(&mut row, k, v);
            }
        }
        for k in order {
            if !self.columns.contains(&k) {
                self.columns.push(k);
            }
        }
        row.retain(|_, v| !v.is_empty());
        match self.find(point, repetition) {
            Some(i) => {
                self.rows[i] = row;
                // The file holds the old row: the next save rewrites it.
                self.saved_columns.clear();
            }
            None => self.rows.push(row),
        }
    }

    /// Writes the CSV: appends the new rows when that is enough, else
    /// rewrites it (to a temporary file first, so an interrupted write never
    /// loses earlier runs) with the plan's parameters first.
    pub fn save(&mut self, plan: &Plan) -> anyhow::Result<()> {
        // Appending is enough when earlier rows are unchanged and no column is new.
        let fits = |row: &Row| row.keys().all(|k| self.saved_columns.contains(k));
        if !self.saved_columns.is_empty() && self.rows[self.saved_rows..].iter().all(fits) {
            let f = std::fs::OpenOptions::new()
                .append(true)
                .open(&self.path)
                .with_context(|| format!("cannot append to {}", self.path.display()))?;
            let mut w = csv::Writer::from_writer(f);
            for row in &self.rows[self.saved_rows..] {
                w.write_record(
                    self.saved_columns
                        .iter()
                        .map(|c| row.get(c).map(String::as_str).unwrap_or("")),
                )?;
            }
            w.flush()?;
            self.saved_rows = self.rows.len();
            return Ok(());
        }
        let mut cols = plan.param_names();
        for c in ["repetition", "status", "wall_s", "error"]
            .iter()
            .map(|s| s.to_string())
            .chain(self.columns.iter().cloned())
        {
            if !cols.contains(&c) {
                cols.push(c);
            }
        }
        let tmp = self.path.with_extension("csv.tmp");
        {
            let mut w = csv::Writer::from_path(&tmp)
                .with_context(|| format!("cannot write {}", tmp.display()))?;
            w.write_record(&cols)?;
            for row in &self.rows {
                w.write_record(
                    cols.iter()
                        .map(|c| row.get(c).map(String::as_str).unwrap_or("")),
                )?;
            }
            w.flush()?;
        }
        std::fs::rename(&tmp, &self.path)
            .with_context(|| format!("cannot write {}", self.path.display()))?;
        self.saved_columns = cols;
        self.saved_rows = self.rows.len();
        Ok(())
    }

    /// Every column name, for "did you mean" messages.
    pub fn known_columns(&self) -> Vec<String> {
        self.columns.clone()
    }
}

fn matches(row: &Row, point: &Point) -> bool {
    point
        .iter()
        .all(|(k, v)| row.get(k).map(String::as_str).unwrap_or("") == v.to_string())
}

/// Flattens JSON: nested objects become `a.b` keys; arrays are kept as JSON text.
pub fn flatten(prefix: &str, v: &serde_json::Value, out: &mut Vec<(String, String)>) {
    match v {
        serde_json::Value::Object(map) => {
            for (k, x) in map {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&key, x, out);
            }
        }
        serde_json::Value::Null => out.push((prefix.to_string(), String::new())),
        serde_json::Value::String(s) => out.push((prefix.to_string(), s.clone())),
        other => out.push((prefix.to_string(), other.to_string())),
    }
}

/// Median of numbers (mean of the middle two for an even count).
pub fn median(v: &[f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let n = s.len();
    Some(if n % 2 == 1 {
        s[n / 2]
    } else {
        (s[n / 2 - 1] + s[n / 2]) / 2.0
    })
}

/// A number for a table: 4 significant digits, scientific when tiny or huge.
pub fn fmt_num(x: f64) -> String {
    if x == x.trunc() && x.abs() < 1e15 {
        format!("{}", x as i64)
    } else if x.abs() >= 1e5 || x.abs() < 1e-3 {
        format!("{x:.3e}")
    } else {
        let digits = (3 - x.abs().log10().floor() as i32).max(0) as usize;
        format!("{x:.digits$}")
    }
}

/// The median over a point's successful runs of one column, as text: a
/// number, the common text of a non-numeric column, or empty.
fn cell(rows: &[&Row], col: &str) -> String {
    let vals: Vec<&str> = rows
        .iter()
        .filter_map(|r| r.get(col).map(String::as_str))
        .collect();
    if vals.is_empty() {
        return String::new();
    }
    let nums: Vec<f64> = vals.iter().filter_map(|v| v.parse::<f64>().ok()).collect();
    if nums.len() == vals.len() {
        return median(&nums).map(fmt_num).unwrap_or_default();
    }
    if vals.iter().all(|v| *v == vals[0]) {
        vals[0].to_string()
    } else {
        "(varies)".into()
    }
}

/// Builds summary.md: per point, the varied parameters, successful runs out
/// of recorded ones, and the median of each summary column. Returns the
/// text and warnings about columns that no run has.
pub fn summary(plan: &Plan, results: &Results) -> (String, Vec<String>) {
    let mut warnings = Vec::new();
    for c in &plan.summary_columns {
        if !results.columns.contains(c) && !plan.param_names().contains(c) {
            warnings.push(format!(
                "{}: summary.columns: no run has a column `{c}`{}",
                plan.path.display(),
                suggest(c, &results.known_columns())
            ));
        }
    }
    let mut md = String::new();
    let _ = writeln!(md, "# Sweep `{}`\n", plan.name);
    if let Some(d) = &plan.description {
        let _ = writeln!(md, "{}\n", d.trim());
    }
    let _ = writeln!(
        md,
        "Config: `{}`; command: `pvrsim {}`; {} repetition(s) per point.\n",
        plan.path.display(),
        plan.executor.command,
        plan.repetitions
    );
    if !plan.fixed.is_empty() {
        let fixed: Vec<String> = plan
            .fixed
            .iter()
            .map(|(k, v)| format!("`{k} = {v}`"))
            .collect();
        let _ = writeln!(md, "Fixed: {}.\n", fixed.join(", "));
    }
    let _ = writeln!(md, "Values are medians over the successful repetitions; `ok` counts successful runs out of those recorded.\n");
    let varied = plan.grid.names();
    let mut header: Vec<String> = varied.clone();
    header.push("ok".into());
    header.extend(plan.summary_columns.iter().cloned());
    let table = render_table(
        &header,
        plan.points().iter().map(|p| {
            let rows: Vec<&Row> = results.rows_of(p);
            let ok: Vec<&Row> = rows
                .iter()
                .copied()
                .filter(|r| r.get("status").map(String::as_str) == Some(OK))
                .collect();
            let mut line: Vec<String> = p
                .iter()
                .take(varied.len())
                .map(|(_, v)| v.to_string())
                .collect();
            line.push(format!("{}/{}", ok.len(), rows.len()));
            line.extend(plan.summary_columns.iter().map(|c| cell(&ok, c)));
            line
        }),
    );
    md.push_str(&table);
    let failed: Vec<String> = plan
        .points()
        .iter()
        .flat_map(|p| {
            results
                .rows_of(p)
                .into_iter()
                .filter(|r| r.get("status").map(String::as_str) == Some(FAILED))
        })
        .map(|r| {
            let params: Vec<String> = varied
                .iter()
                .map(|k| format!("{k}={}", r.get(k).map(String::as_str).unwrap_or("")))
                .collect();
            format!(
                "- {} (repetition {}): {}",
                params.join(", "),
                r.get("repetition").map(String::as_str).unwrap_or("?"),
                r.get("error").map(String::as_str).unwrap_or("")
            )
        })
        .collect();
    if !failed.is_empty() {
        let _ = writeln!(md, "\n## Failed runs\n\n{}", failed.join("\n"));
    }
    (md, warnings)
}

/// A Markdown table with aligned columns.
pub fn render_table(header: &[String], rows: impl Iterator<Item = Vec<String>>) -> String {
    let rows: Vec<Vec<String>> = rows.collect();
    let width: Vec<usize> = (0..header.len())
        .map(|i| {
            rows.iter()
                .map(|r| r[i].chars().count())
                .chain([header[i].chars().count(), 3])
                .max()
                .unwrap_or(3)
        })
        .collect();
    let line = |cells: &[String]| {
        let c: Vec<String> = cells
            .iter()
            .zip(&width)
            .map(|(c, w)| format!("{c:<w$}"))
            .collect();
        format!("| {} |\n", c.join(" | "))
    };
    let mut s = line(header);
    s.push_str(&line(
        &width.iter().map(|w| "-".repeat(*w)).collect::<Vec<_>>(),
    ));
    for r in &rows {
        s.push_str(&line(r));
    }
    s
}

/// ", did you mean `x`?" for the closest known name, if any is close.
pub fn suggest(name: &str, known: &[String]) -> String {
    let best = known.iter().map(|k| (edit_distance(name, k), k)).min();
    match best {
        Some((d, k)) if d <= 3.max(name.len() / 3) => format!("; did you mean `{k}`?"),
        _ if known.is_empty() => String::new(),
        _ => format!(" (columns: {})", known.join(", ")),
    }
}

fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1];
        for (j, cb) in b.iter().enumerate() {
            cur.push(
                (prev[j] + usize::from(ca != *cb))
                    .min(prev[j + 1] + 1)
                    .min(cur[j] + 1),
            );
        }
        prev = cur;
    }
    prev[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flattens_nested_objects() {
        let v =
            serde_json::json!({"a": 1, "e": {"max_abs": 2.5, "n": null}, "s": "x", "l": [1, 2]});
        let mut out = Vec::new();
        flatten("", &v, &mut out);
        let m: BTreeMap<_, _> = out.into_iter().collect();
        assert_eq!(m["a"], "1");
        assert_eq!(m["e.max_abs"], "2.5");
        assert_eq!(m["e.n"], "");
        assert_eq!(m["s"], "x");
        assert_eq!(m["l"], "[1,2]");
    }

    #[test]
    fn save_appends_and_rewrites_consistently() {
        use crate::experiment::grid::ParamValue;
        let dir = std::env::temp_dir().join(format!("pvrsim-results-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let plan = Plan::parse(
            "name = \"t\"\nscene = \"s\"\n[vary]\ntile = [1, 2, 3]",
            &dir.join("t.toml"),
        )
        .unwrap();
        let points = plan.points();
        let path = dir.join("results.csv");
        let _ = std::fs::remove_file(&path);
        let mut r = Results::load(&path).unwrap();
        let stats = |v: i64| Ok(serde_json::json!({ "n": v, "e": { "max": v * 2 } }));
        r.record(&points[0], 0, 0.5, &Err("boom".into()));
        r.save(&plan).unwrap();
        r.record(&points[1], 0, 0.5, &stats(1));
        r.save(&plan).unwrap(); // new columns: rewrite
        r.record(&points[2], 0, 0.5, &stats(2));
        r.save(&plan).unwrap(); // append
        r.record(&points[0], 0, 0.5, &stats(3));
        r.save(&plan).unwrap(); // replacement: rewrite
        let back = Results::load(&path).unwrap();
        assert_eq!(back.rows.len(), 3);
        assert_eq!(back.columns[..2], ["tile".to_string(), "scene".to_string()]);
        let get = |i: usize, c: &str| back.rows[i].get(c).cloned().unwrap_or_default();
        assert_eq!(
            (get(0, "status"), get(0, "n"), get(0, "e.max")),
            ("ok".into(), "3".into(), "6".into())
        );
        assert_eq!((get(2, "tile"), get(2, "n")), ("3".into(), "2".into()));
        assert_eq!(back.find(&points[1], 0), Some(1));
        assert_eq!(points[1][0], ("tile".to_string(), ParamValue::Int(2)));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn numbers_and_medians() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), Some(2.5));
        assert_eq!(fmt_num(12.0), "12");
        assert_eq!(fmt_num(0.012345), "0.01235");
        assert_eq!(fmt_num(123.456), "123.5");
        assert_eq!(fmt_num(0.0001234), "1.234e-4");
        assert_eq!(
            suggest("time_scan", &["time_scan_s".into(), "wall_s".into()]),
            "; did you mean `time_scan_s`?"
        );
    }
}
