//! Error histograms: bin counts (pure) and stacked histogram panels drawn as step outlines.

use super::{stacked_png, Panel, PlotError, Series, MEASURED};
use std::path::Path;

/// Counts of the finite `values` in `bins` equal bins spanning [min, max]; returns
/// (bin low edge, bin width, counts). Empty input gives no bins.
pub fn histogram_counts(values: &[f64], bins: usize) -> (f64, f64, Vec<usize>) {
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() || bins == 0 {
        return (0.0, 0.0, Vec::new());
    }
    let lo = finite.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    // A constant series still needs a positive width to be drawn.
    let width = if hi > lo {
        (hi - lo) / bins as f64
    } else {
        1.0
    };
    let mut counts = vec![0usize; bins];
    for v in finite {
        let i = (((v - lo) / width) as usize).min(bins - 1);
        counts[i] += 1;
    }
    (lo, width, counts)
}

/// One PNG with a histogram panel per (title, x label, values).
pub fn histogram_png(
    path: &Path,
    panels: &[(String, String, Vec<f64>)],
    bins: usize,
) -> Result<(), PlotError> {
    let panels: Vec<Panel> = panels
        .iter()
        .map(|(title, x_label, values)| {
            let (lo, width, counts) = histogram_counts(values, bins);
            let mut points = Vec::with_capacity(2 * counts.len() + 2);
            points.push((lo, 0.0));
            for (i, c) in counts.iter().enumerate() {
                let x0 = lo + i as f64 * width;
                points.push((x0, *c as f64));
                points.push((x0 + width, *c as f64));
            }
            points.push((lo + counts.len() as f64 * width, 0.0));
            Panel {
                title: title.clone(),
                x_label: x_label.clone(),
                y_label: "frames".into(),
                series: vec![Series::line("count", points, MEASURED)],
            }
        })
        .collect();
    stacked_png(path, &panels, 900, 350)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_cover_every_finite_value_once() {
        let v = [0.0, 0.1, 0.5, 0.99, 1.0, f64::NAN];
        let (lo, w, c) = histogram_counts(&v, 2);
        assert_eq!(lo, 0.0);
        assert_eq!(w, 0.5);
        assert_eq!(c, vec![2, 3]);
        assert_eq!(histogram_counts(&[2.0, 2.0], 4).2, vec![2, 0, 0, 0]);
    }
}
