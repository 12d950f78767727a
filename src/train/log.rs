//! The training log: one CSV row per step (`log.csv`) and a loss-curve picture (`loss.png`,
//! log-scale y, one line per term and one for the held-out frames' loss, labelled with a
//! built-in 3×5 pixel font so no font files are needed).

use std::fs::OpenOptions;
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::picture::draw::{line, text};
use crate::picture::Picture;
use crate::user_file;

/// Declares the row type of a training log and its [`CsvRow`] impl: `step` (steps done after
/// the row's step, the first column) and the `f64` columns, each named in the CSV header by the
/// string beside it, `seconds` among them. A log read back may lack the columns past
/// `min_columns` (logs written before they were added): they read as NaN.
macro_rules! log_row {
    (
        $(#[$meta:meta])*
        pub struct $name:ident (min_columns = $min:literal) {
            $(#[$step_doc:meta])*
            step,
            $($(#[$doc:meta])* $field:ident = $column:literal,)*
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct $name {
            $(#[$step_doc])*
            pub step: u64,
            $($(#[$doc])* pub $field: f64,)*
        }

        impl $crate::train::log::CsvRow for $name {
            const HEADER: &'static str = concat!("step" $(, ",", $column)*);
            const MIN_COLUMNS: usize = $min;

            fn step(&self) -> u64 {
                self.step
            }

            fn set_seconds(&mut self, seconds: f64) {
                self.seconds = seconds;
            }

            fn values(&self) -> Vec<f64> {
                vec![self.step as f64 $(, self.$field)*]
            }

            fn from_values(values: &[f64]) -> Self {
                let mut columns = values.iter().copied().skip(1);
                $name {
                    step: values.first().copied().unwrap_or(0.0) as u64,
                    $($field: columns.next().unwrap_or(f64::NAN),)*
                }
            }
        }
    };
}
pub(crate) use log_row;

log_row! {
    /// One step's numbers (weighted terms are not stored: the config holds the weights).
    pub struct LogRow (min_columns = 8) {
        /// Steps done after this one.
        step,
        /// Eq. 4's total.
        total = "total",
        /// L_rec (or masked).
        rec = "rec",
        /// L_reg, unweighted.
        arap = "arap",
        /// L_joints, unweighted.
        joints = "joints",
        /// L_area, unweighted.
        area = "area",
        /// σ used.
        sigma = "sigma",
        /// Training seconds so far.
        seconds = "seconds",
        /// Eq. 4's total on the held-out frames after this step (NaN where not measured).
        held_out = "held_out",
        /// The sampled poses' vertex loss, unweighted (NaN without sampled poses).
        vertex = "vertex",
        /// The guide's vertex loss, unweighted (NaN where the guide is off).
        guide = "guide",
    }
}

/// A row of a training log: numbers in the order of its header (declared by `log_row!`).
pub trait CsvRow: Copy {
    /// The CSV header.
    const HEADER: &'static str;
    /// The fewest columns a row read back may have (logs written before a column was added).
    const MIN_COLUMNS: usize;
    /// Steps done after this row's step.
    fn step(&self) -> u64;
    /// Sets the training seconds so far (every training log has the column).
    fn set_seconds(&mut self, seconds: f64);
    /// The row's values, one per header column.
    fn values(&self) -> Vec<f64>;
    /// The row from `MIN_COLUMNS` to all of the header's values (missing ones are NaN).
    fn from_values(values: &[f64]) -> Self;
}

/// Appends rows to a log CSV (`log.csv`); on resume, rows past the checkpoint are dropped first
/// so the log has each step once.
pub struct TrainLog<R: CsvRow = LogRow> {
    path: PathBuf,
    rows: Vec<R>,
}

impl<R: CsvRow> TrainLog<R> {
    /// Opens (or creates) the log at `path`, keeping the rows with `step <= keep_through`.
    ///
    /// # Errors
    /// [`Error::Io`]/[`Error::Format`] naming the file.
    pub fn open(path: &Path, keep_through: u64) -> Result<Self> {
        let mut rows = Vec::new();
        if path.exists() {
            let text = user_file::read_text(path, user_file::DATA)?;
            for (n, line) in text.lines().enumerate().skip(1) {
                let v: Vec<f64> = line
                    .split(',')
                    .map(str::parse)
                    .collect::<std::result::Result<_, _>>()
                    .map_err(|_| Error::format(path, format!("line {}: not numbers", n + 1)))?;
                let columns = R::HEADER.split(',').count();
                if !(R::MIN_COLUMNS..=columns).contains(&v.len()) {
                    return Err(Error::format(
                        path,
                        format!("line {}: {} columns, expected {columns}", n + 1, v.len()),
                    ));
                }
                let row = R::from_values(&v);
                if row.step() <= keep_through {
                    rows.push(row);
                }
            }
        }
        let mut text = format!("{}\n", R::HEADER);
        for r in &rows {
            text.push_str(&csv_line(r));
        }
        crate::atomic_file::write_atomic(path, text.as_bytes())?;
        Ok(TrainLog {
            path: path.to_path_buf(),
            rows,
        })
    }

    /// Appends one row to the file.
    ///
    /// # Errors
    /// [`Error::Io`] naming the file.
    pub fn push(&mut self, row: R) -> Result<()> {
        let mut file = OpenOptions::new()
            .append(true)
            .open(&self.path)
            .map_err(|e| Error::io(&self.path, e))?;
        file.write_all(csv_line(&row).as_bytes()).map_err(|e| Error::io(&self.path, e))?;
        self.rows.push(row);
        Ok(())
    }

    /// All rows so far.
    pub fn rows(&self) -> &[R] {
        &self.rows
    }
}

fn csv_line(row: &impl CsvRow) -> String {
    let values: Vec<String> = row.values().iter().map(f64::to_string).collect();
    format!("{}\n", values.join(","))
}

/// One line of a loss plot: a name, a colour, and one value per row (NaN where not measured:
/// the line joins the measured ones).
pub struct Curve<'a> {
    /// The legend's label.
    pub name: &'a str,
    /// RGB in [0, 1].
    pub colour: [f32; 3],
    /// The plotted values.
    pub values: Vec<f64>,
}

/// One line of a log's plot: its legend's label, its colour (RGB in [0, 1]) and its value in
/// each row (NaN where not measured).
pub type Series<'a, R> = (&'a str, [f32; 3], &'a dyn Fn(&R) -> f64);

/// The `series` of a log's `rows` over their steps, as [`plot_curves`] draws them.
pub fn plot_rows<R: CsvRow>(rows: &[R], series: &[Series<R>]) -> Picture {
    let curves: Vec<Curve> = series
        .iter()
        .map(|&(name, colour, value)| Curve {
            name,
            colour,
            values: rows.iter().map(value).collect(),
        })
        .collect();
    let steps: Vec<u64> = rows.iter().map(CsvRow::step).collect();
    plot_curves(&steps, &curves)
}

/// The loss curves (total, rec, the regularisers weighted by `weights` (arap, joints, area) as
/// summed, and the held-out frames' total where measured) on a log-scale y axis.
pub fn plot(rows: &[LogRow], weights: [f64; 3]) -> Picture {
    plot_rows(
        rows,
        &[
            ("total", [0.0, 0.0, 0.0], &|r| r.total),
            ("rec", [0.1, 0.35, 0.9], &|r| r.rec),
            ("arap", [0.95, 0.5, 0.0], &|r| r.arap * weights[0]),
            ("joints", [0.1, 0.65, 0.2], &|r| r.joints * weights[1]),
            ("area", [0.7, 0.1, 0.6], &|r| r.area * weights[2]),
            ("held-out", [0.85, 0.1, 0.1], &|r| r.held_out),
        ],
    )
}

/// Curves over steps (`steps[i]` is the step of each curve's `values[i]`) on a log-scale y axis,
/// with a legend; values that are not positive and finite are left out.
pub fn plot_curves(steps: &[u64], curves: &[Curve]) -> Picture {
    let (w, h, left, bottom, top, right) = (720u32, 400u32, 44i64, 20i64, 24i64, 12i64);
    let mut pic = Picture::filled(w, h, [1.0, 1.0, 1.0, 1.0]);
    let positive: Vec<f64> = curves
        .iter()
        .flat_map(|c| c.values.iter().copied())
        .filter(|v| *v > 0.0 && v.is_finite())
        .collect();
    let (lo, hi) = positive.iter().fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
    let (lo, hi) = if positive.is_empty() {
        (-3.0, 0.0)
    } else {
        (lo.log10().floor(), hi.log10().ceil().max(lo.log10().floor() + 1.0))
    };
    let last = steps.last().map_or(1, |s| (*s).max(1)) as f64;
    let px = |step: f64| left + ((step / last) * (w as i64 - left - right) as f64) as i64;
    let py = |v: f64| top + ((hi - v.log10()) / (hi - lo) * (h as i64 - top - bottom) as f64) as i64;
    let grey = [0.85, 0.85, 0.85];
    for decade in lo as i64..=hi as i64 {
        let y = py(10f64.powi(decade as i32));
        line(&mut pic, [left, y], [w as i64 - right, y], grey);
        text(&mut pic, &format!("1e{decade}"), [2, y - 2], [0.3, 0.3, 0.3]);
    }
    line(&mut pic, [left, top], [left, h as i64 - bottom], [0.0; 3]);
    line(&mut pic, [left, h as i64 - bottom], [w as i64 - right, h as i64 - bottom], [0.0; 3]);
    text(&mut pic, "0", [left, h as i64 - bottom + 6], [0.3; 3]);
    let last_label = format!("step {}", last as u64);
    text(
        &mut pic,
        &last_label,
        [w as i64 - right - 4 * last_label.len() as i64, h as i64 - bottom + 6],
        [0.3; 3],
    );
    let mut legend_x = left + 8;
    for curve in curves {
        let (name, colour) = (curve.name, &curve.colour);
        let mut prev: Option<[i64; 2]> = None;
        for (&step, &v) in steps.iter().zip(&curve.values) {
            if v.is_nan() {
                // Not measured at this step (the held-out loss): join the measured ones.
                continue;
            }
            let p = (v > 0.0 && v.is_finite()).then(|| [px(step as f64), py(v)]);
            if let (Some(a), Some(b)) = (prev, p) {
                line(&mut pic, a, b, *colour);
            }
            prev = p;
        }
        line(&mut pic, [legend_x, 10], [legend_x + 10, 10], *colour);
        text(&mut pic, name, [legend_x + 14, 8], *colour);
        legend_x += 14 + 4 * name.len() as i64 + 16;
    }
    pic
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(step: u64, total: f64) -> LogRow {
        LogRow {
            step,
            total,
            rec: total / 2.0,
            arap: 1e-5,
            joints: 0.0,
            area: 0.0,
            sigma: 1.0,
            seconds: step as f64,
            held_out: if step.is_multiple_of(2) { 2.0 / step as f64 } else { f64::NAN },
            vertex: if step.is_multiple_of(2) { 3.0 / step as f64 } else { f64::NAN },
            guide: if step.is_multiple_of(2) { 4.0 / step as f64 } else { f64::NAN },
        }
    }

    #[test]
    fn reopening_keeps_rows_up_to_the_checkpoint() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("log.csv");
        let mut log = TrainLog::<LogRow>::open(&path, 0).unwrap();
        for s in 1..=5 {
            log.push(row(s, 1.0 / s as f64)).unwrap();
        }
        let log = TrainLog::<LogRow>::open(&path, 3).unwrap();
        assert_eq!(log.rows().iter().map(|r| r.step).collect::<Vec<_>>(), [1, 2, 3]);
        assert_eq!(std::fs::read_to_string(&path).unwrap().lines().count(), 4);
        assert_eq!(log.rows()[1], row(2, 0.5), "measured held-out, vertex and guide losses read back");
        assert!(
            log.rows()[0].held_out.is_nan() && log.rows()[0].vertex.is_nan() && log.rows()[0].guide.is_nan(),
            "unmeasured ones read back as NaN"
        );
    }

    #[test]
    fn the_plot_draws_each_series_in_its_colour() {
        let rows: Vec<LogRow> = (1..=50).map(|s| row(s, 1.0 / s as f64)).collect();
        let pic = plot(&rows, [2500.0, 1e4, 0.0]);
        let count = |c: [f32; 3]| pic.pixels.iter().filter(|p| p[..3] == c).count();
        assert!(count([0.1, 0.35, 0.9]) > 300, "rec line");
        assert!(count([0.95, 0.5, 0.0]) > 300, "arap line");
        assert!(count([0.85, 0.1, 0.1]) > 300, "held-out line, joined across unmeasured steps");
    }
}
