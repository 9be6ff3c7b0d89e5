//! `soupray report DIR`: reads the per-frame build logs a render wrote into
//! DIR and shows, per frame, the BVH build, trace and total times, the
//! triangle count and the SAH cost, plus the median of each column.
//!
//! The table always goes to the terminal. Unless `--no-files` is given, it
//! is also written as CSV (`DIR/report.csv`, or `--csv FILE`) and drawn as a
//! PNG chart (`DIR/report.png`, or `--chart FILE`) of those five measures
//! over the frames. Both files are written atomically, and neither is a
//! `.json`, so reports never mistake them for frame logs. The CSV has one
//! row per frame in frame order, then a last row whose `frame` is `median`.
//!
//! The chart is drawn by `plotters` into memory and encoded by `image`, with
//! the DejaVu Sans Mono font embedded in the binary (`assets/fonts/`), so it
//! needs no system fonts, fontconfig or other system libraries.

use crate::output::{read_log, write_atomic, OutputError};
use anyhow::Context as _;
use std::path::{Path, PathBuf};

/// Tabulate a render's per-frame build logs: build, trace and total time,
/// triangles, SAH cost, estimated error and mean spp per frame, with medians.
///
/// DIR is a render's --out directory (its `<name>.####.json` logs). Writes
/// DIR/report.csv and DIR/report.png unless told otherwise. Example:
///
///   soupray report out/walk
///   soupray report out/walk --csv /tmp/walk.csv --chart /tmp/walk.png
#[derive(clap::Args, Debug, Clone)]
pub struct ReportArgs {
    /// The directory holding the frame logs.
    #[arg(value_name = "DIR")]
    pub dir: PathBuf,
    /// Where to write the CSV table [default: DIR/report.csv].
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Where to write the PNG chart [default: DIR/report.png].
    #[arg(long, value_name = "FILE")]
    pub chart: Option<PathBuf>,
    /// Only print the table; write no CSV or chart.
    #[arg(long, conflicts_with_all = ["csv", "chart"])]
    pub no_files: bool,
}

/// One frame's line of the report.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub frame: i64,
    pub build_ms: f64,
    pub trace_ms: f64,
    pub total_ms: f64,
    pub triangles: u64,
    pub sah_cost: f64,
    /// The frame's estimated relative error (the log's
    /// `noise.estimated_mean`).
    pub noise: f64,
    /// Mean samples per pixel (`noise.spp_mean`).
    pub spp_mean: f64,
    /// The log's file name.
    pub log: String,
}

/// The median of each measure (for an even count, the mean of the middle
/// two).
#[derive(Debug, Clone, PartialEq)]
pub struct Medians {
    pub build_ms: f64,
    pub trace_ms: f64,
    pub total_ms: f64,
    pub triangles: f64,
    pub sah_cost: f64,
    pub noise: f64,
    pub spp_mean: f64,
}

/// The median of `v` (NaN for none).
pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        (v[m - 1] + v[m]) / 2.0
    }
}

impl Medians {
    pub fn of(rows: &[Row]) -> Medians {
        let col = |f: fn(&Row) -> f64| median(rows.iter().map(f).collect());
        Medians {
            build_ms: col(|r| r.build_ms),
            trace_ms: col(|r| r.trace_ms),
            total_ms: col(|r| r.total_ms),
            triangles: col(|r| r.triangles as f64),
            sah_cost: col(|r| r.sah_cost),
            noise: col(|r| r.noise),
            spp_mean: col(|r| r.spp_mean),
        }
    }
}

/// The frame logs in `dir` as rows sorted by frame (then file name), and
/// a note for each `.json` file that is not a frame log.
pub fn collect_rows(dir: &Path) -> anyhow::Result<(Vec<Row>, Vec<String>)> {
    let input_error = |detail: String| crate::input::InputError {
        path: dir.to_path_buf(),
        detail,
    };
    let entries = std::fs::read_dir(dir).map_err(|e| {
        input_error(format!(
            "cannot read the directory ({e}); give the --out directory of a render"
        ))
    })?;
    let mut rows = Vec::new();
    let mut skipped = Vec::new();
    for entry in entries {
        let path = entry
            .map_err(|e| input_error(format!("cannot list the directory ({e})")))?
            .path();
        let is_json = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        let hidden = path
            .file_name()
            .is_some_and(|n| n.to_string_lossy().starts_with('.'));
        if !is_json || hidden || !path.is_file() {
            continue;
        }
        match read_log(&path) {
            Ok(log) => rows.push(Row {
                frame: log.frame,
                build_ms: log.timings_ms.build,
                trace_ms: log.timings_ms.trace,
                total_ms: log.timings_ms.total,
                triangles: log.triangles,
                sah_cost: log.build.sah_cost,
                noise: log.noise.estimated_mean,
                spp_mean: log.noise.spp_mean,
                log: path
                    .file_name()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .into_owned(),
            }),
            Err(e @ OutputError::BadLog { .. }) => skipped.push(format!("skipped {e}")),
            Err(e) => return Err(e.into()),
        }
    }
    if rows.is_empty() {
        return Err(input_error(format!(
            "no per-frame logs (<name>.####.json) found; give the --out directory \
             of a render{}",
            if skipped.is_empty() {
                String::new()
            } else {
                format!(
                    " ({} other .json files were not frame logs: {})",
                    skipped.len(),
                    skipped.join("; ")
                )
            }
        ))
        .into());
    }
    rows.sort_by(|a, b| a.frame.cmp(&b.frame).then_with(|| a.log.cmp(&b.log)));
    Ok((rows, skipped))
}

/// The terminal table.
pub fn format_table(rows: &[Row], m: &Medians) -> String {
    let mut s = format!(
        "{:>8} {:>11} {:>11} {:>11} {:>11} {:>9} {:>9} {:>9}\n",
        "frame",
        "build ms",
        "trace ms",
        "total ms",
        "triangles",
        "SAH cost",
        "est. err",
        "mean spp"
    );
    for r in rows {
        s += &format!(
            "{:>8} {:>11.2} {:>11.1} {:>11.1} {:>11} {:>9.2} {:>9.5} {:>9.1}\n",
            r.frame,
            r.build_ms,
            r.trace_ms,
            r.total_ms,
            r.triangles,
            r.sah_cost,
            r.noise,
            r.spp_mean
        );
    }
    s += &format!(
        "{:>8} {:>11.2} {:>11.1} {:>11.1} {:>11} {:>9.2} {:>9.5} {:>9.1}\n",
        "median", m.build_ms, m.trace_ms, m.total_ms, m.triangles, m.sah_cost, m.noise, m.spp_mean
    );
    s
}

/// Quotes a CSV field when it needs it (RFC 4180).
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The CSV table: full-precision numbers, one row per frame, then medians.
pub fn format_csv(rows: &[Row], m: &Medians) -> String {
    let mut s = String::from(
        "frame,build_ms,trace_ms,total_ms,triangles,sah_cost,noise_estimate,spp_mean,log\n",
    );
    for r in rows {
        s += &format!(
            "{},{},{},{},{},{},{},{},{}\n",
            r.frame,
            r.build_ms,
            r.trace_ms,
            r.total_ms,
            r.triangles,
            r.sah_cost,
            r.noise,
            r.spp_mean,
            csv_field(&r.log)
        );
    }
    s += &format!(
        "median,{},{},{},{},{},{},{},\n",
        m.build_ms, m.trace_ms, m.total_ms, m.triangles, m.sah_cost, m.noise, m.spp_mean
    );
    s
}

/// Chart size in pixels.
pub const CHART_SIZE: (u32, u32) = (1200, 1200);

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSansMono.ttf");

pub(crate) fn register_font() -> anyhow::Result<()> {
    static REGISTERED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, FONT)
            .is_ok()
    });
    anyhow::ensure!(ok, "the embedded chart font could not be loaded");
    Ok(())
}

/// Draws the chart as RGB pixels: four panels over the frames (build ms;
/// trace and total ms; triangles; SAH cost; estimated relative error; mean
/// spp), each with its median dashed.
pub fn render_chart(rows: &[Row]) -> anyhow::Result<Vec<u8>> {
    use plotters::prelude::*;
    register_font()?;
    let (w, h) = CHART_SIZE;
    let mut buf = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let panels = root.split_evenly((3, 2));
        let frames: Vec<f64> = rows.iter().map(|r| r.frame as f64).collect();
        let (lo, hi) = frames
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &f| (a.min(f), b.max(f)));
        let x_range = if hi > lo { lo..hi } else { lo - 1.0..hi + 1.0 };
        type Series<'a> = (&'a str, RGBColor, Vec<f64>);
        let panel_specs: [(&str, Vec<Series>); 6] = [
            (
                "BVH build (ms)",
                vec![("build", BLUE, rows.iter().map(|r| r.build_ms).collect())],
            ),
            (
                "trace and total (ms)",
                vec![
                    ("trace", RED, rows.iter().map(|r| r.trace_ms).collect()),
                    ("total", BLACK, rows.iter().map(|r| r.total_ms).collect()),
                ],
            ),
            (
                "triangles",
                vec![(
                    "triangles",
                    RGBColor(0, 140, 0),
                    rows.iter().map(|r| r.triangles as f64).collect(),
                )],
            ),
            (
                "SAH cost",
                vec![(
                    "SAH cost",
                    MAGENTA,
                    rows.iter().map(|r| r.sah_cost).collect(),
                )],
            ),
            (
                "estimated relative error",
                vec![(
                    "error",
                    RGBColor(200, 100, 0),
                    rows.iter().map(|r| r.noise).collect(),
                )],
            ),
            (
                "mean samples per pixel",
                vec![(
                    "spp",
                    RGBColor(0, 120, 160),
                    rows.iter().map(|r| r.spp_mean).collect(),
                )],
            ),
        ];
        for (area, (title, series)) in panels.iter().zip(panel_specs) {
            let ymax = series
                .iter()
                .flat_map(|s| s.2.iter().copied())
                .filter(|v| v.is_finite())
                .fold(0.0f64, f64::max);
            let ymax = if ymax > 0.0 { ymax * 1.1 } else { 1.0 };
            let mut chart = ChartBuilder::on(area)
                .caption(title, ("sans-serif", 18))
                .margin(12)
                .x_label_area_size(36)
                .y_label_area_size(70)
                .build_cartesian_2d(x_range.clone(), 0.0..ymax)
                .map_err(plot_err)?;
            chart
                .configure_mesh()
                .x_desc("frame")
                .x_label_formatter(&|x| format!("{x:.0}"))
                .y_label_formatter(&|y| format_axis(*y))
                .label_style(("sans-serif", 12))
                .draw()
                .map_err(plot_err)?;
            for (name, color, values) in &series {
                let points: Vec<(f64, f64)> =
                    frames.iter().copied().zip(values.iter().copied()).collect();
                let m = median(values.clone());
                chart
                    .draw_series(LineSeries::new(points.clone(), color.stroke_width(2)))
                    .map_err(plot_err)?
                    .label(format!("{name} (median {})", format_axis(m)))
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                    });
                chart
                    .draw_series(points.iter().map(|&p| Circle::new(p, 3, color.filled())))
                    .map_err(plot_err)?;
                chart
                    .draw_series(DashedLineSeries::new(
                        [(x_range.start, m), (x_range.end, m)],
                        6,
                        4,
                        color.mix(0.6).stroke_width(1),
                    ))
                    .map_err(plot_err)?;
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::LowerRight)
                .label_font(("sans-serif", 12))
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()
                .map_err(plot_err)?;
        }
        root.present().map_err(plot_err)?;
    }
    Ok(buf)
}

pub(crate) fn format_axis(v: f64) -> String {
    let a = v.abs();
    if !v.is_finite() {
        "-".into()
    } else if a >= 1e6 {
        format!("{:.2}M", v / 1e6)
    } else if a >= 1e4 {
        format!("{:.1}k", v / 1e3)
    } else if a >= 100.0 || a == 0.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.2}")
    }
}

pub(crate) fn plot_err<E: std::error::Error + Send + Sync + 'static>(e: E) -> anyhow::Error {
    anyhow::anyhow!("drawing the chart failed: {e}")
}

/// Writes the chart as a PNG, atomically.
pub fn write_chart(path: &Path, rows: &[Row]) -> anyhow::Result<()> {
    let pixels = render_chart(rows)?;
    let (w, h) = CHART_SIZE;
    write_rgb_png(path, &pixels, w, h)
}

/// Writes 8-bit RGB pixels as a PNG, atomically.
pub(crate) fn write_rgb_png(path: &Path, pixels: &[u8], w: u32, h: u32) -> anyhow::Result<()> {
    use image::ImageEncoder as _;
    write_atomic(path, |out| {
        image::codecs::png::PngEncoder::new(out)
            .write_image(pixels, w, h, image::ExtendedColorType::Rgb8)
            .map_err(|e| OutputError::Encode {
                path: path.to_path_buf(),
                format: "PNG chart",
                message: e.to_string(),
            })
    })?;
    Ok(())
}

/// Runs `soupray report`.
pub fn run_report(args: &ReportArgs) -> anyhow::Result<()> {
    let (rows, skipped) = collect_rows(&args.dir)?;
    for note in &skipped {
        eprintln!("soupray: note: {note}");
    }
    let medians = Medians::of(&rows);
    print!("{}", format_table(&rows, &medians));
    if args.no_files {
        return Ok(());
    }
    let csv = args
        .csv
        .clone()
        .unwrap_or_else(|| args.dir.join("report.csv"));
    let chart = args
        .chart
        .clone()
        .unwrap_or_else(|| args.dir.join("report.png"));
    let text = format_csv(&rows, &medians);
    write_atomic(&csv, |out| {
        use std::io::Write as _;
        out.write_all(text.as_bytes())
            .map_err(|source| OutputError::Io {
                path: csv.clone(),
                action: "write",
                source,
            })
    })
    .context("writing the CSV (choose another place with --csv FILE, or --no-files)")?;
    write_chart(&chart, &rows)
        .context("writing the chart (choose another place with --chart FILE, or --no-files)")?;
    eprintln!("wrote {} and {}", csv.display(), chart.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(frame: i64, build: f64, trace: f64, tris: u64, sah: f64) -> Row {
        Row {
            frame,
            build_ms: build,
            trace_ms: trace,
            total_ms: build + trace + 1.0,
            triangles: tris,
            sah_cost: sah,
            noise: 0.01,
            spp_mean: 16.0,
            log: format!("s.{frame:04}.json"),
        }
    }

    #[test]
    fn medians_odd_and_even() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(vec![7.0]), 7.0);
        assert!(median(vec![]).is_nan());
        let rows = [row(1, 10.0, 100.0, 5, 2.0), row(2, 30.0, 300.0, 8, 4.0)];
        let m = Medians::of(&rows);
        assert_eq!((m.build_ms, m.trace_ms, m.total_ms), (20.0, 200.0, 221.0));
        assert_eq!((m.triangles, m.sah_cost), (6.5, 3.0));
    }

    #[test]
    fn table_and_csv_text() {
        let rows = [row(-1, 1.5, 20.0, 12, 3.25), row(2, 2.5, 40.0, 14, 3.75)];
        let m = Medians::of(&rows);
        let t = format_table(&rows, &m);
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(lines.len(), 4);
        assert!(
            lines[1].trim_start().starts_with("-1 ") && lines[1].contains("3.25"),
            "{t}"
        );
        assert!(
            lines[3].trim_start().starts_with("median") && lines[3].contains("3.50"),
            "{t}"
        );
        let c = format_csv(&rows, &m);
        assert_eq!(
            c,
            "frame,build_ms,trace_ms,total_ms,triangles,sah_cost,noise_estimate,spp_mean,log\n\
             -1,1.5,20,22.5,12,3.25,0.01,16,s.-001.json\n\
             2,2.5,40,43.5,14,3.75,0.01,16,s.0002.json\n\
             median,2,30,33,13,3.5,0.01,16,\n"
        );
        assert_eq!(csv_field("a,\"b\""), "\"a,\"\"b\"\"\"");
    }

    #[test]
    fn command_line() {
        use clap::{CommandFactory as _, Parser};
        #[derive(Parser)]
        struct Cli {
            #[command(flatten)]
            report: ReportArgs,
        }
        Cli::command().debug_assert();
        let a = Cli::try_parse_from(["report", "out/walk", "--csv", "t.csv"]).unwrap();
        assert_eq!(a.report.dir, Path::new("out/walk"));
        assert_eq!(a.report.csv.as_deref(), Some(Path::new("t.csv")));
        assert!(Cli::try_parse_from(["report", "d", "--csv", "t.csv", "--no-files"]).is_err());
    }

    #[test]
    fn chart_draws_something_for_one_frame() {
        let px = render_chart(&[row(5, 1.0, 2.0, 3, 4.0)]).unwrap();
        assert!(px.iter().any(|&b| b < 128), "text and lines are drawn");
    }
}
