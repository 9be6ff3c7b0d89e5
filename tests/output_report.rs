//! `soupray report` on synthetic frame logs: the rows and medians, the CSV
//! it writes, the PNG chart, and the errors for directories without logs.

use soupray::cli::report::{collect_rows, run_report, ReportArgs, CHART_SIZE};
use soupray::output::{write_log, FrameLog};
use std::path::Path;

fn log(frame: i64, build: f64, trace: f64, tris: u64, sah: f64) -> FrameLog {
    let mut l = FrameLog::new();
    l.frame = frame;
    l.scene = "walk.glb".into();
    l.triangles = tris;
    l.timings_ms.build = build;
    l.timings_ms.trace = trace;
    l.timings_ms.total = build + trace + 10.0;
    l.build.sah_cost = sah;
    // The estimated error falls and the spp rises with the frame.
    l.noise.estimated_mean = 0.5 / (frame + 2) as f64;
    l.noise.spp_mean = 16.0 * (frame + 2) as f64;
    l
}

fn write_logs(dir: &Path) {
    // Written out of order; frame -1 included.
    for (f, b, t, n, s) in [
        (2, 12.0, 300.0, 1200, 40.5),
        (-1, 10.0, 100.0, 1000, 42.0),
        (0, 14.0, 200.0, 1100, 41.0),
        (1, 30.0, 900.0, 1500, 39.0),
    ] {
        write_log(&dir.join(format!("walk.{f:04}.json")), &log(f, b, t, n, s)).unwrap();
    }
    // Things a report must not take for frame logs.
    std::fs::write(dir.join("notes.json"), r#"{"owner": "lighting"}"#).unwrap();
    std::fs::write(dir.join("walk.0000.exr"), b"not read").unwrap();
}

#[test]
fn rows_are_sorted_and_foreign_json_skipped() {
    let dir = tempfile::tempdir().unwrap();
    write_logs(dir.path());
    let (rows, skipped) = collect_rows(dir.path()).unwrap();
    let frames: Vec<i64> = rows.iter().map(|r| r.frame).collect();
    assert_eq!(frames, [-1, 0, 1, 2]);
    assert_eq!(rows[0].log, "walk.-001.json");
    assert_eq!(skipped.len(), 1);
    assert!(skipped[0].contains("notes.json"), "{}", skipped[0]);
}

#[test]
fn report_writes_csv_with_medians_and_a_chart() {
    let dir = tempfile::tempdir().unwrap();
    write_logs(dir.path());
    run_report(&ReportArgs {
        dir: dir.path().to_path_buf(),
        csv: None,
        chart: None,
        no_files: false,
    })
    .unwrap();
    let csv = std::fs::read_to_string(dir.path().join("report.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(
        lines[0],
        "frame,build_ms,trace_ms,total_ms,triangles,sah_cost,noise_estimate,spp_mean,log"
    );
    assert_eq!(lines[1], "-1,10,100,120,1000,42,0.5,16,walk.-001.json");
    assert_eq!(lines[4], "2,12,300,322,1200,40.5,0.125,64,walk.0002.json");
    // Medians of four: build (12+14)/2, trace (200+300)/2, total (224+322)/2,
    // triangles (1100+1200)/2, SAH (40.5+41)/2, error (0.25+1/6)/2, spp
    // (32+48)/2.
    assert_eq!(
        lines[5],
        format!(
            "median,13,250,273,1150,40.75,{},40,",
            (0.25 + 0.5 / 3.0) / 2.0
        )
    );
    assert_eq!(lines.len(), 6);

    let chart = image::open(dir.path().join("report.png"))
        .unwrap()
        .to_rgb8();
    assert_eq!(chart.dimensions(), CHART_SIZE);
    let dark = chart
        .pixels()
        .filter(|p| p.0.iter().all(|&c| c < 100))
        .count();
    let white = chart.pixels().filter(|p| p.0 == [255, 255, 255]).count();
    assert!(
        dark > 2000,
        "axes, labels and lines are drawn ({dark} dark pixels)"
    );
    assert!(white > chart.pixels().len() / 2, "mostly background");
    // Coloured series: red for trace, blue for build.
    assert!(chart.pixels().any(|p| p.0 == [255, 0, 0]));
    assert!(chart.pixels().any(|p| p.0 == [0, 0, 255]));

    // A second report reads the same logs: its own files are not logs.
    let (rows, skipped) = collect_rows(dir.path()).unwrap();
    assert_eq!((rows.len(), skipped.len()), (4, 1));
}

#[test]
fn report_files_can_go_elsewhere_or_nowhere() {
    let dir = tempfile::tempdir().unwrap();
    let elsewhere = tempfile::tempdir().unwrap();
    write_logs(dir.path());
    run_report(&ReportArgs {
        dir: dir.path().to_path_buf(),
        csv: Some(elsewhere.path().join("r.csv")),
        chart: Some(elsewhere.path().join("r.png")),
        no_files: false,
    })
    .unwrap();
    assert!(elsewhere.path().join("r.csv").is_file() && elsewhere.path().join("r.png").is_file());
    run_report(&ReportArgs {
        dir: dir.path().to_path_buf(),
        csv: None,
        chart: None,
        no_files: true,
    })
    .unwrap();
    assert!(!dir.path().join("report.csv").exists());
}

#[test]
fn directories_without_logs_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let e = collect_rows(dir.path()).unwrap_err().to_string();
    assert!(
        e.contains("no per-frame logs") && e.contains("--out"),
        "{e}"
    );
    let e = collect_rows(&dir.path().join("missing")).unwrap_err();
    let msg = format!("{e:#}");
    assert!(
        msg.contains("missing") && msg.contains("cannot read"),
        "{msg}"
    );
}
