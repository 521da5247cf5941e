//! The parameter space of a sweep: values of one parameter (a list or a
//! range), zip groups (parameters that vary together), and their Cartesian
//! product in a deterministic order.

pub use crate::job::args::by_name::ParamValue;

/// A range of numbers, `{ from, to, step }` or `{ from, to, count, log }`.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawRange {
    /// First value.
    pub from: toml::Value,
    /// Last value (included when the steps land on it).
    pub to: toml::Value,
    /// Distance between values (not with `count`).
    pub step: Option<toml::Value>,
    /// Number of values, ends included (not with `step`).
    pub count: Option<i64>,
    /// Space the `count` values geometrically (needs `from`, `to` > 0).
    #[serde(default)]
    pub log: bool,
}

/// Most values one parameter may take (guards against a typo in `step`).
pub const MAX_VALUES: usize = 100_000;

fn number(v: &toml::Value, key: &str) -> Result<ParamValue, String> {
    match v {
        toml::Value::Integer(i) => Ok(ParamValue::Int(*i)),
        toml::Value::Float(f) if f.is_finite() => Ok(ParamValue::Float(*f)),
        _ => Err(format!("{key}: expected a number, found {v}")),
    }
}

/// Removes the last-digit noise of `from + i * step` (0.30000000000000004 -> 0.3).
fn tidy(x: f64) -> f64 {
    format!("{x:.12e}").parse().unwrap_or(x)
}

impl RawRange {
    /// Expands the range; `key` names it in errors (e.g. `vary.ert_table`).
    pub fn values(&self, key: &str) -> Result<Vec<ParamValue>, String> {
        let from = number(&self.from, &format!("{key}.from"))?;
        let to = number(&self.to, &format!("{key}.to"))?;
        let ints = matches!((&from, &to), (ParamValue::Int(_), ParamValue::Int(_)));
        let (a, b) = (from.as_f64().unwrap_or(0.0), to.as_f64().unwrap_or(0.0));
        let out = match (&self.step, self.count) {
            (Some(_), Some(_)) => {
                return Err(format!("{key}: give either `step` or `count`, not both"))
            }
            (None, None) => {
                return Err(format!(
                "{key}: a range needs `step` or `count` (e.g. {{ from = 1, to = 10, step = 1 }})"
            ))
            }
            (Some(step), None) => {
                if self.log {
                    return Err(format!("{key}: `log = true` needs `count`, not `step`"));
                }
                let step = number(step, &format!("{key}.step"))?;
                let s = step.as_f64().unwrap_or(0.0);
                if s == 0.0 || (b - a) * s < 0.0 {
                    return Err(format!("{key}.step: {step} never gets from {from} to {to}"));
                }
                let n = ((b - a) / s + 1e-9).floor() + 1.0;
                if n > MAX_VALUES as f64 {
                    return Err(format!(
                        "{key}: {n} values (more than {MAX_VALUES}); check `step`"
                    ));
                }
                let n = n as i64;
                match (&from, &step) {
                    (ParamValue::Int(f), ParamValue::Int(st)) if ints => {
                        (0..n).map(|i| ParamValue::Int(f + i * st)).collect()
                    }
                    _ => (0..n)
                        .map(|i| ParamValue::Float(tidy(a + i as f64 * s)))
                        .collect(),
                }
            }
            (None, Some(count)) => {
                if count < 1 || count as usize > MAX_VALUES {
                    return Err(format!(
                        "{key}.count: must be 1..={MAX_VALUES}, found {count}"
                    ));
                }
                if self.log && (a <= 0.0 || b <= 0.0) {
                    return Err(format!("{key}: `log = true` needs `from` and `to` > 0"));
                }
                let t = |i: i64| {
                    if count == 1 {
                        0.0
                    } else {
                        i as f64 / (count - 1) as f64
                    }
                };
                let xs: Vec<f64> = (0..count)
                    .map(|i| {
                        if self.log {
                            a * (b / a).powf(t(i))
                        } else {
                            a + (b - a) * t(i)
                        }
                    })
                    .collect();
                if ints {
                    // Integer ends give integers: rounded, duplicates dropped.
                    let mut out: Vec<ParamValue> = Vec::new();
                    for x in xs {
                        let v = ParamValue::Int(x.round() as i64);
                        if !out.contains(&v) {
                            out.push(v);
                        }
                    }
                    out
                } else {
                    xs.into_iter().map(|x| ParamValue::Float(tidy(x))).collect()
                }
            }
        };
        Ok(out)
    }
}

/// The values of one parameter from its config entry: a list or a range table.
pub fn values_of(v: &toml::Value, key: &str) -> Result<Vec<ParamValue>, String> {
    match v {
        toml::Value::Array(items) => {
            if items.is_empty() {
                return Err(format!("{key}: the list of values is empty"));
            }
            items.iter().enumerate().map(|(i, x)| ParamValue::from_toml(x, &format!("{key}[{i}]"))).collect()
        }
        toml::Value::Table(_) => {
            let r: RawRange = v.clone().try_into().map_err(|e: toml::de::Error| format!("{key}: {}", e.message().trim()))?;
            r.values(key)
        }
        other => Err(format!(
            "{key}: expected a list of values or a range table {{ from, to, step }}, found the single value {other}; put a single value in [fixed]"
        )),
    }
}

/// One axis of the grid: one parameter, or several that vary together (zip).
#[derive(Debug, Clone, PartialEq)]
pub struct Dimension {
    /// Parameter names.
    pub names: Vec<String>,
    /// The tuples of values, one per position along the axis (each as long as `names`).
    pub tuples: Vec<Vec<ParamValue>>,
}

/// A full parameter assignment: the parameters of one sweep point, in order.
pub type Point = Vec<(String, ParamValue)>;

/// The parameters that vary, as axes of a Cartesian product.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Grid {
    /// Axes, outermost first: the last one changes fastest.
    pub dims: Vec<Dimension>,
}

impl Grid {
    /// Names of all varying parameters, in order.
    pub fn names(&self) -> Vec<String> {
        self.dims
            .iter()
            .flat_map(|d| d.names.iter().cloned())
            .collect()
    }

    /// Number of points (1 for an empty grid).
    pub fn len(&self) -> usize {
        self.dims.iter().map(|d| d.tuples.len()).product()
    }

    /// True if the grid has no points (an axis without values).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// All points, in row-major order (the first axis changes slowest).
    pub fn points(&self) -> Vec<Point> {
        let mut out: Vec<Point> = vec![Vec::new()];
        for d in &self.dims {
            let mut next = Vec::with_capacity(out.len() * d.tuples.len());
            for p in &out {
                for t in &d.tuples {
                    let mut q = p.clone();
                    q.extend(d.names.iter().cloned().zip(t.iter().cloned()));
                    next.push(q);
                }
            }
            out = next;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn range(s: &str) -> Result<Vec<String>, String> {
        let v: toml::Value =
            toml::from_str::<toml::Table>(&format!("r = {s}")).unwrap()["r"].clone();
        values_of(&v, "vary.r").map(|v| v.iter().map(|x| x.to_string()).collect())
    }

    #[test]
    fn ranges() {
        assert_eq!(
            range("{ from = 5, to = 20, step = 5 }").unwrap(),
            ["5", "10", "15", "20"]
        );
        assert_eq!(
            range("{ from = 5, to = 22, step = 5 }").unwrap(),
            ["5", "10", "15", "20"]
        );
        assert_eq!(
            range("{ from = 0.1, to = 0.5, step = 0.1 }").unwrap(),
            ["0.1", "0.2", "0.3", "0.4", "0.5"]
        );
        assert_eq!(
            range("{ from = 10, to = 1, step = -3 }").unwrap(),
            ["10", "7", "4", "1"]
        );
        assert_eq!(
            range("{ from = 1, to = 1000, count = 4, log = true }").unwrap(),
            ["1", "10", "100", "1000"]
        );
        assert_eq!(
            range("{ from = 1, to = 4, count = 8, log = true }").unwrap(),
            ["1", "2", "3", "4"]
        );
        assert_eq!(
            range("{ from = 0.0, to = 1.0, count = 3 }").unwrap(),
            ["0", "0.5", "1"]
        );
        assert_eq!(
            range("[\"exact\", \"midpoint\"]").unwrap(),
            ["exact", "midpoint"]
        );
    }

    #[test]
    fn bad_ranges_name_the_key() {
        for bad in [
            "{ from = 1, to = 5 }",
            "{ from = 1, to = 5, step = 0 }",
            "{ from = 1, to = 5, step = -1 }",
            "{ from = 0, to = 5, count = 3, log = true }",
            "{ from = 1, to = 5, step = 1, count = 3 }",
            "{ from = 1, to = 5, stpe = 1 }",
            "{ from = \"a\", to = 5, step = 1 }",
            "[]",
            "3",
        ] {
            let e = range(bad).unwrap_err();
            assert!(e.contains("vary.r"), "{bad}: {e}");
        }
    }

    #[test]
    fn product_order() {
        let g = Grid {
            dims: vec![
                Dimension {
                    names: vec!["a".into()],
                    tuples: vec![vec![ParamValue::Int(1)], vec![ParamValue::Int(2)]],
                },
                Dimension {
                    names: vec!["b".into(), "c".into()],
                    tuples: vec![
                        vec![ParamValue::Int(3), ParamValue::Int(4)],
                        vec![ParamValue::Int(5), ParamValue::Int(6)],
                    ],
                },
            ],
        };
        let p: Vec<String> = g
            .points()
            .iter()
            .map(|p| {
                p.iter()
                    .map(|(k, v)| format!("{k}={v}"))
                    .collect::<Vec<_>>()
                    .join(",")
            })
            .collect();
        assert_eq!(
            p,
            ["a=1,b=3,c=4", "a=1,b=5,c=6", "a=2,b=3,c=4", "a=2,b=5,c=6"]
        );
        assert_eq!(Grid::default().points().len(), 1);
    }
}
