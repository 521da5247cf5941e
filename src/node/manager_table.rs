//! The manager's merge rule (paper §3.2): per entry, among the nodes whose
//! entry is terminated, the minimum `deepest`.
//!
//! With `+inf` standing for "not terminated" this is simply the entry-wise
//! minimum, an idempotent, commutative and associative operation (a
//! semilattice): the manager may merge tables in any order, any number of
//! times, and merging its own result back changes nothing. See
//! [`super::table`] for why the result is a valid ERT certificate for every
//! node.

use super::table::{SharedTable, TableError};

/// The merge of `a` and `b`: per entry `min(a, b)`. Both must have the same shape.
pub fn merge_tables(a: &SharedTable, b: &SharedTable) -> Result<SharedTable, TableError> {
    let mut out = a.clone();
    merge_into(&mut out, b)?;
    Ok(out)
}

/// Merges `t` into the manager's table `acc` in place; returns the number
/// of entries whose value got smaller.
pub fn merge_into(acc: &mut SharedTable, t: &SharedTable) -> Result<usize, TableError> {
    if (acc.nx, acc.ny) != (t.nx, t.ny) || acc.deepest.len() != t.deepest.len() {
        return Err(TableError::Shape {
            got: (t.nx, t.ny),
            want: (acc.nx, acc.ny),
        });
    }
    if let Some(e) = t.deepest.iter().position(|d| d.is_nan()) {
        return Err(TableError::NonFinite(e));
    }
    let mut changed = 0;
    for (a, &d) in acc.deepest.iter_mut().zip(&t.deepest) {
        if d < *a {
            *a = d;
            changed += 1;
        }
    }
    Ok(changed)
}

/// The merge of all `tables` (an empty table of shape `nx x ny` if none).
pub fn merge_all<'a>(
    nx: u16,
    ny: u16,
    tables: impl IntoIterator<Item = &'a SharedTable>,
) -> Result<SharedTable, TableError> {
    let mut acc = SharedTable::empty(nx, ny);
    for t in tables {
        merge_into(&mut acc, t)?;
    }
    Ok(acc)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn table() -> impl Strategy<Value = SharedTable> {
        proptest::collection::vec(
            prop_oneof![
                Just(f32::INFINITY),
                -10.0f32..100.0,
                Just(0.0f32),
                Just(-0.0f32)
            ],
            6,
        )
        .prop_map(|deepest| SharedTable {
            nx: 3,
            ny: 2,
            deepest,
        })
    }

    fn same(a: &SharedTable, b: &SharedTable) -> bool {
        a.deepest.iter().zip(&b.deepest).all(|(x, y)| x == y)
    }

    proptest! {
        #[test]
        fn merge_is_a_semilattice(a in table(), b in table(), c in table()) {
            let ab = merge_tables(&a, &b).unwrap();
            prop_assert!(same(&ab, &merge_tables(&b, &a).unwrap()));
            prop_assert!(same(&merge_tables(&a, &a).unwrap(), &a));
            let l = merge_tables(&ab, &c).unwrap();
            let r = merge_tables(&a, &merge_tables(&b, &c).unwrap()).unwrap();
            prop_assert!(same(&l, &r));
            // Min over the terminated entries; not terminated only if neither is.
            for e in 0..6 {
                let want = match (a.terminated(e), b.terminated(e)) {
                    (false, false) => f32::INFINITY,
                    (true, false) => a.deepest[e],
                    (false, true) => b.deepest[e],
                    (true, true) => a.deepest[e].min(b.deepest[e]),
                };
                prop_assert_eq!(ab.deepest[e], want);
            }
            let all = merge_all(3, 2, [&a, &b, &c]).unwrap();
            prop_assert!(same(&all, &l));
        }
    }

    #[test]
    fn shape_mismatch_is_an_error() {
        assert!(merge_tables(&SharedTable::empty(2, 2), &SharedTable::empty(4, 1)).is_err());
    }
}
