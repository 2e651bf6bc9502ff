//! Result tables (markdown and CSV) and the small statistics the studies report.

/// A table with a bold title and a caption giving its exact parameters; rendered as markdown
/// for the report and as CSV (RFC 4180 quoting) for the data files.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    /// Title (bold in markdown).
    pub title: String,
    /// One paragraph: what was run, with which parameters.
    pub caption: String,
    /// Column names.
    pub header: Vec<String>,
    /// Rows, each as long as the header.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// An empty table.
    pub fn new(title: &str, caption: &str, header: &[&str]) -> Self {
        Self {
            title: title.into(),
            caption: caption.into(),
            header: header.iter().map(|&h| h.into()).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row; missing trailing cells are left empty.
    ///
    /// # Panics
    /// If the row has more cells than the header (a bug in the study).
    pub fn row(&mut self, mut cells: Vec<String>) {
        assert!(
            cells.len() <= self.header.len(),
            "table `{}`: row of {} cells for {} columns",
            self.title,
            cells.len(),
            self.header.len()
        );
        cells.resize(self.header.len(), String::new());
        self.rows.push(cells);
    }

    /// A row whose run failed: the leading cells, then the error in the next cell.
    pub fn failed_row(&mut self, mut lead: Vec<String>, error: &str) {
        lead.push(error.replace('\n', " "));
        lead.truncate(self.header.len());
        self.row(lead);
    }

    /// The table as markdown (title, caption, pipe table).
    pub fn markdown(&self) -> String {
        let mut s = format!("**{}**\n\n{}\n\n", self.title, self.caption);
        let line = |cells: &[String]| {
            let cells: Vec<String> = cells.iter().map(|c| c.replace('|', "\\|")).collect();
            format!("| {} |\n", cells.join(" | "))
        };
        s += &line(&self.header);
        s += &line(&vec!["---".to_string(); self.header.len()]);
        for r in &self.rows {
            s += &line(r);
        }
        s.push('\n');
        s
    }

    /// The header and rows as CSV (fields with a comma, quote or line break are quoted).
    pub fn csv(&self) -> String {
        let field = |c: &String| {
            if c.contains([',', '"', '\n', '\r']) {
                format!("\"{}\"", c.replace('"', "\"\""))
            } else {
                c.clone()
            }
        };
        let mut s = String::new();
        for r in std::iter::once(&self.header).chain(&self.rows) {
            s += &r.iter().map(field).collect::<Vec<_>>().join(",");
            s.push('\n');
        }
        s
    }
}

/// Engineering formatting: three significant digits with a k/M/G suffix.
pub fn si(x: f64) -> String {
    let (v, suffix) = match x.abs() {
        a if a >= 1e9 => (x / 1e9, "G"),
        a if a >= 1e6 => (x / 1e6, "M"),
        a if a >= 1e3 => (x / 1e3, "k"),
        _ => (x, ""),
    };
    format!("{v:.3}{suffix}")
}

/// Median of a sample (NaN when empty).
pub fn median(mut xs: Vec<f64>) -> f64 {
    if xs.is_empty() {
        return f64::NAN;
    }
    xs.sort_by(f64::total_cmp);
    let m = xs.len() / 2;
    if xs.len().is_multiple_of(2) {
        0.5 * (xs[m - 1] + xs[m])
    } else {
        xs[m]
    }
}

/// Spread of a sample: (largest − smallest) / median, the relative range (0 for one value,
/// NaN when empty).
pub fn spread(xs: &[f64]) -> f64 {
    let lo = xs.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (hi - lo) / median(xs.to_vec())
}

/// Mean and sample standard deviation (divisor n − 1; 0 for one value; NaN when empty).
pub fn mean_sd(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean, var.sqrt())
}

/// Least-squares slope of `y` against `x`, if at least two distinct `x`.
pub fn slope(points: &[(f64, f64)]) -> Option<f64> {
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    (points.len() >= 2 && sxx > 0.0).then(|| sxy / sxx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_sample_deviation_of_known_samples() {
        // 2, 4, 4, 4, 5, 5, 7, 9: mean 5, squared deviations 32, sample variance 32/7.
        let (m, sd) = mean_sd(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]);
        assert_eq!(m, 5.0);
        assert!((sd - (32.0f64 / 7.0).sqrt()).abs() < 1e-15);
        assert_eq!(mean_sd(&[3.0]), (3.0, 0.0));
        assert!(mean_sd(&[]).0.is_nan());
    }

    #[test]
    fn slope_of_an_exact_line_and_of_too_few_points() {
        let line: Vec<(f64, f64)> = (0..5).map(|i| (i as f64, 2.5 * i as f64 - 1.0)).collect();
        assert!((slope(&line).unwrap() - 2.5).abs() < 1e-12);
        assert_eq!(slope(&line[..1]), None);
        assert_eq!(slope(&[(1.0, 2.0), (1.0, 3.0)]), None);
    }

    #[test]
    fn median_and_spread_of_small_samples() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(Vec::new()).is_nan());
        assert!((spread(&[1.0, 2.0, 4.0]) - 1.5).abs() < 1e-12);
    }

    #[test]
    fn csv_quotes_fields_that_need_it() {
        let mut t = Table::new("t", "c", &["a", "b"]);
        t.row(vec!["1,5".into(), "say \"hi\"".into()]);
        t.row(vec!["x".into()]);
        assert_eq!(t.csv(), "a,b\n\"1,5\",\"say \"\"hi\"\"\"\nx,\n");
        assert!(t.markdown().contains("| 1,5 | say \"hi\" |"));
    }
}
