//! The project's one quantile and its Markdown tables: the tool's real-data
//! summary (`scans --summary`, `log --summary`, `docs`'s real-data tables)
//! and the test kit's evaluations (`host-tests`: `eval::Summary`, the
//! accuracy tables) use this file, the latter through a `#[path]` module, so
//! that every median and p90 in the project is the same statistic.

/// The `q`-quantile (`q ∈ [0, 1]`) of `values` by **nearest rank**: the
/// smallest value with at least `⌈q·n⌉` of the `n` values at or below it, i.e.
/// the value of rank `max(1, ⌈q·n⌉)` in ascending order. It is always one of
/// the values (no interpolation); the median of an even count is the lower
/// middle value. NaN for an empty slice. `q` is clamped to `[0, 1]`.
pub fn quantile(values: &[f64], q: f64) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let rank = ((q.clamp(0.0, 1.0) * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    sorted[rank - 1]
}

/// The header of a Markdown table: the column names, then the separator
/// line.
pub fn markdown_header(columns: &[&str]) -> String {
    format!(
        "| {} |\n|{}\n",
        columns.join(" | "),
        "---|".repeat(columns.len())
    )
}

/// One row of a Markdown table.
pub fn markdown_row<S: AsRef<str>>(cells: &[S]) -> String {
    let cells: Vec<&str> = cells.iter().map(AsRef::as_ref).collect();
    format!("| {} |\n", cells.join(" | "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantile_is_nearest_rank() {
        let v = [5.0, 1.0, 4.0, 2.0, 3.0];
        assert_eq!(quantile(&v, 0.5), 3.0);
        assert_eq!(quantile(&v, 0.9), 5.0);
        assert_eq!(quantile(&v, 0.2), 1.0);
        assert_eq!(quantile(&v, 0.21), 2.0);
        assert_eq!(quantile(&v, 0.0), 1.0);
        assert_eq!(quantile(&v, 1.0), 5.0);
        // Even count: the lower middle value, not the mean of the two.
        assert_eq!(quantile(&[4.0, 1.0, 3.0, 2.0], 0.5), 2.0);
        // 10 values: p90 is the 9th.
        let ten: Vec<f64> = (1..=10).map(f64::from).collect();
        assert_eq!(quantile(&ten, 0.9), 9.0);
        assert!(quantile(&[], 0.5).is_nan());
    }

    #[test]
    fn markdown_tables() {
        assert_eq!(markdown_header(&["a", "b c"]), "| a | b c |\n|---|---|\n");
        assert_eq!(markdown_row(&["1", "–"]), "| 1 | – |\n");
        assert_eq!(
            markdown_row(&[String::from("x"), String::new()]),
            "| x |  |\n"
        );
    }
}
