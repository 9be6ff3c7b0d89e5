//! Which frames `soupray render` renders, and what each frame's files are
//! called: `--frames SPEC`, `--frame N` and `--start/--end/--step` resolve
//! to one ordered list of frame numbers; `--out DIR` and `--name PATTERN`
//! give each frame its EXR, PNG preview and JSON build-log paths; and
//! `check_output_dir` proves the output directory is writable before any
//! frame is rendered, so a farm job fails in seconds rather than after the
//! first (possibly hour-long) frame.
//!
//! Conventions, chosen to match what farm templates and Blender do:
//! - A SPEC is a comma-separated list of `N`, `A-B` (inclusive) and
//!   `A-B:STEP` items, e.g. `1-10,15,20-30:2`. Frames may be negative
//!   (`-5`, `-10--1`, `-3-3:2`). Frames render in the order written; a frame
//!   listed twice renders once, at its first place.
//! - A range's end is an upper bound that is never passed: `1-10:4` is
//!   1, 5, 9. When the step does not land on the end, the end is not
//!   rendered (a farm chunk must not render a frame that belongs to no
//!   chunk), and the resolution says so in a note rather than silently.
//! - In a name pattern, the last run of `#` becomes the frame number,
//!   zero-padded to the run's length, the sign counting towards the width
//!   as in Blender and C's `%0*d`: frame 7 with `####` is `0007`, frame -7 is
//!   `-007`, frame 12345 is `12345` (the width is a minimum, never a cut).

use crate::UsageError;
use std::path::{Path, PathBuf};

/// Most frames one invocation may render. A typo like `1-100000000` would
/// otherwise allocate gigabytes of frame numbers before failing elsewhere.
pub const MAX_FRAMES: usize = 1_000_000;

/// An ordered list of frames to render, plus notes the caller must show the
/// user (e.g. that a stepped range stops short of its end).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FrameList {
    pub frames: Vec<i64>,
    pub notes: Vec<String>,
}

/// Parses a frame SPEC (`1-10,15,20-30:2`). Errors are `UsageError`s
/// (exit code 2) that quote the offending item and show the fix.
pub fn parse_frame_spec(spec: &str) -> Result<FrameList, UsageError> {
    let trimmed = spec.trim();
    if trimmed.is_empty() {
        return Err(UsageError(
            "--frames: the frame list is empty; give frames like 1-10,15,20-30:2".into(),
        ));
    }
    let mut list = FrameList {
        frames: Vec::new(),
        notes: Vec::new(),
    };
    let mut seen = std::collections::HashSet::new();
    for raw in trimmed.split(',') {
        let item = raw.trim();
        if item.is_empty() {
            return Err(UsageError(format!(
                "--frames {spec:?}: an empty item (two commas, or a comma at an end); \
                 separate items with single commas, like 1-10,15"
            )));
        }
        let (start, end, step) = parse_item(item)?;
        if let Some(note) = short_of_end_note(&format!("{item:?}"), start, end, step) {
            list.notes.push(note);
        }
        push_range(&mut list.frames, &mut seen, start, end, step, item)?;
    }
    Ok(list)
}

/// One item: `N`, `A-B` or `A-B:STEP`, as (start, end, step).
fn parse_item(item: &str) -> Result<(i64, i64, i64), UsageError> {
    let bad = |why: &str| {
        UsageError(format!(
            "--frames: bad item {item:?}: {why}; items are N, A-B or A-B:STEP \
             (e.g. 7, 1-10, 20-30:2, -5--1)"
        ))
    };
    let (range, step) = match item.split_once(':') {
        Some((r, s)) => (r.trim(), Some(s.trim())),
        None => (item, None),
    };
    let (a, rest) =
        split_number(range).ok_or_else(|| bad("it does not start with a frame number"))?;
    let start: i64 = a
        .parse()
        .map_err(|_| bad("the frame number is out of range"))?;
    let rest = rest.trim_start();
    let end = if rest.is_empty() {
        None
    } else {
        let Some(after_dash) = rest.strip_prefix('-') else {
            return Err(bad("expected '-' between the two ends of a range"));
        };
        let (b, tail) = split_number(after_dash.trim_start())
            .ok_or_else(|| bad("the range has no end frame number after '-'"))?;
        if !tail.trim().is_empty() {
            return Err(bad("unexpected text after the range"));
        }
        Some(
            b.parse::<i64>()
                .map_err(|_| bad("the frame number is out of range"))?,
        )
    };
    let step = match step {
        None => 1,
        Some(s) => {
            if end.is_none() {
                return Err(bad("a :STEP needs a range A-B before it"));
            }
            let step: i64 = s
                .parse()
                .map_err(|_| bad("the step after ':' is not a whole number"))?;
            if step < 1 {
                return Err(bad("the step must be 1 or more"));
            }
            step
        }
    };
    let end = end.unwrap_or(start);
    if end < start {
        return Err(UsageError(format!(
            "--frames: the range {item:?} runs backwards ({start} is after {end}); \
             write it as {end}-{start}"
        )));
    }
    Ok((start, end, step))
}

/// Splits an optionally negative decimal number off the front of `s`.
fn split_number(s: &str) -> Option<(&str, &str)> {
    let digits_from = usize::from(s.starts_with('-'));
    let len = s[digits_from..]
        .bytes()
        .take_while(u8::is_ascii_digit)
        .count();
    if len == 0 {
        return None;
    }
    Some(s.split_at(digits_from + len))
}

/// Appends start, start+step, ... up to and including `end` if on the step,
/// skipping frames already listed; refuses more than `MAX_FRAMES`.
fn push_range(
    frames: &mut Vec<i64>,
    seen: &mut std::collections::HashSet<i64>,
    start: i64,
    end: i64,
    step: i64,
    what: &str,
) -> Result<(), UsageError> {
    // Count in i128: `end - start` overflows i64 for extreme ranges.
    let count = (end as i128 - start as i128) / step as i128 + 1;
    if count + frames.len() as i128 > MAX_FRAMES as i128 {
        return Err(UsageError(format!(
            "{what}: {count} frames is more than the {MAX_FRAMES} one run may render; \
             split the job into smaller chunks"
        )));
    }
    for k in 0..count as i64 {
        let f = start + k * step;
        if seen.insert(f) {
            frames.push(f);
        }
    }
    Ok(())
}

/// The note for a stepped range whose last frame falls short of its end.
fn short_of_end_note(what: &str, start: i64, end: i64, step: i64) -> Option<String> {
    let last = last_on_step(start, end, step);
    (last != end).then(|| {
        format!(
            "{what}: the step {step} from {start} does not land on the end {end}; \
             the last frame rendered is {last} (the end is never passed)"
        )
    })
}

fn last_on_step(start: i64, end: i64, step: i64) -> i64 {
    let n = (end as i128 - start as i128) / step as i128;
    (start as i128 + n * step as i128) as i64
}

/// The frame-selection flags of `render`, as given (before resolution).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FrameArgs {
    /// `--frames SPEC`.
    pub frames: Option<String>,
    /// `--frame N`.
    pub frame: Option<i64>,
    /// `--start N`.
    pub start: Option<i64>,
    /// `--end N`.
    pub end: Option<i64>,
    /// `--step N` (with --start/--end, or alone over the scene's range).
    pub step: Option<i64>,
}

/// Resolves the flags to the frames to render. `scene_range` is the scene's
/// own first and last frame (from its animation length and --fps), used for
/// whatever the flags leave open: no flags renders the whole animation;
/// `--start` alone runs to the scene's last frame, `--end` alone starts at
/// its first. `--frames`, `--frame` and `--start/--end` exclude each other.
///
/// A chunk `--start S --end E --step K` renders S, S+K, ... up to E and never
/// past it; when E is not on the step, a note says where it stopped.
pub fn resolve_frames(args: &FrameArgs, scene_range: (i64, i64)) -> Result<FrameList, UsageError> {
    let ranged = args.start.is_some() || args.end.is_some();
    let ways = [args.frames.is_some(), args.frame.is_some(), ranged];
    if ways.iter().filter(|&&w| w).count() > 1 {
        return Err(UsageError(
            "--frames, --frame and --start/--end each choose the frames; give only one of them"
                .into(),
        ));
    }
    if args.step.is_some() && (args.frames.is_some() || args.frame.is_some()) {
        return Err(UsageError(
            "--step goes with --start/--end; inside --frames write the step as A-B:STEP".into(),
        ));
    }
    if let Some(spec) = &args.frames {
        return parse_frame_spec(spec);
    }
    if let Some(f) = args.frame {
        return Ok(FrameList {
            frames: vec![f],
            notes: vec![],
        });
    }
    let start = args.start.unwrap_or(scene_range.0);
    let end = args.end.unwrap_or(scene_range.1);
    let step = args.step.unwrap_or(1);
    if step < 1 {
        return Err(UsageError(format!(
            "--step {step}: the step must be 1 or more"
        )));
    }
    if end < start {
        let from = |given: Option<i64>, flag: &str| {
            if given.is_some() {
                flag.to_string()
            } else {
                format!("{flag} (the scene's)")
            }
        };
        return Err(UsageError(format!(
            "{} {start} is after {} {end}; the range would be empty: swap them or fix the chunk",
            from(args.start, "--start"),
            from(args.end, "--end"),
        )));
    }
    let mut list = FrameList {
        frames: Vec::new(),
        notes: Vec::new(),
    };
    let what = format!("--start {start} --end {end} --step {step}");
    if let Some(note) = short_of_end_note(&what, start, end, step) {
        list.notes.push(note);
    }
    push_range(
        &mut list.frames,
        &mut std::collections::HashSet::new(),
        start,
        end,
        step,
        &what,
    )?;
    Ok(list)
}

/// The default `--name`: `<stem>.####.exr`.
pub fn default_name_pattern(scene: &Path) -> String {
    format!("{}.####.exr", scene_stem(scene))
}

/// The default `--out`: `out/<stem>/`.
pub fn default_out_dir(scene: &Path) -> PathBuf {
    Path::new("out").join(scene_stem(scene))
}

/// The scene file's name without its extension (`walk` for `shots/walk.glb`).
pub fn scene_stem(scene: &Path) -> String {
    scene
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "frame".into())
}

/// A checked `--name` pattern: a plain file name ending in `.exr` with at
/// least one run of `#`; its last run is where the frame number goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NamePattern {
    pattern: String,
    /// Byte range of the last `#` run, if any.
    hashes: Option<(usize, usize)>,
}

impl NamePattern {
    /// Checks a pattern. `frame_count` is how many frames will use it: a
    /// pattern without `#` is accepted for one frame only, since every frame
    /// would otherwise overwrite the same file.
    pub fn new(pattern: &str, frame_count: usize) -> Result<Self, UsageError> {
        if pattern.contains('/') || pattern.contains('\\') {
            return Err(UsageError(format!(
                "--name {pattern:?}: the name is a file name, not a path; \
                 choose the directory with --out"
            )));
        }
        let lower = pattern.to_ascii_lowercase();
        if !lower.ends_with(".exr") || lower.len() == 4 {
            return Err(UsageError(format!(
                "--name {pattern:?}: the name must end in .exr (the PNG preview and the \
                 .json log take the same name with their own extension), e.g. shot.####.exr"
            )));
        }
        let end = pattern.rfind('#').map(|i| i + 1);
        let hashes = end.map(|end| {
            let start = pattern[..end].trim_end_matches('#').len();
            (start, end)
        });
        if hashes.is_none() && frame_count > 1 {
            return Err(UsageError(format!(
                "--name {pattern:?} has no # for the frame number, so all {frame_count} frames \
                 would overwrite one file; put #### where the number goes, e.g. shot.####.exr"
            )));
        }
        Ok(NamePattern {
            pattern: pattern.to_string(),
            hashes,
        })
    }

    /// The EXR file name of `frame`.
    pub fn file_name(&self, frame: i64) -> String {
        match self.hashes {
            None => self.pattern.clone(),
            Some((a, b)) => format!(
                "{}{}{}",
                &self.pattern[..a],
                format_frame(frame, b - a),
                &self.pattern[b..]
            ),
        }
    }
}

/// `frame` zero-padded to `width` characters, the sign included in the
/// width (Blender's and `%0*d`'s convention): (7, 4) → `0007`,
/// (-7, 4) → `-007`, (12345, 4) → `12345`.
pub fn format_frame(frame: i64, width: usize) -> String {
    format!("{frame:0width$}")
}

/// The files of one frame, all in the output directory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FramePaths {
    pub exr: PathBuf,
    /// The tonemapped preview (`--png`): the EXR's name with `.png`.
    pub png: PathBuf,
    /// The build log: the EXR's name with `.json`.
    pub log: PathBuf,
}

/// The paths of `frame` under `out_dir` with `pattern`.
pub fn frame_paths(out_dir: &Path, pattern: &NamePattern, frame: i64) -> FramePaths {
    let exr = out_dir.join(pattern.file_name(frame));
    FramePaths {
        png: exr.with_extension("png"),
        log: exr.with_extension("json"),
        exr,
    }
}

/// The output directory cannot be used. Carries the directory and the fix.
#[derive(Debug, thiserror::Error)]
#[error("output directory {}: {what}: {source}; {fix}", dir.display())]
pub struct OutputDirError {
    pub dir: PathBuf,
    pub what: &'static str,
    pub fix: &'static str,
    #[source]
    pub source: std::io::Error,
}

/// Creates `dir` (and its parents) if needed and proves files can be
/// created, written, synced and removed in it by doing so with a probe file.
/// Call before rendering anything. Permission bits alone do not tell
/// (read-only mounts, full disks, ACLs, quotas), so this writes for real.
pub fn check_output_dir(dir: &Path) -> Result<(), OutputDirError> {
    let fail = |what, fix, source| OutputDirError {
        dir: dir.to_path_buf(),
        what,
        fix,
        source,
    };
    const FIX: &str = "choose a writable directory with --out, or fix its permissions";
    if dir.exists() && !dir.is_dir() {
        return Err(fail(
            "it is not a directory",
            "give --out a directory, not a file",
            std::io::Error::other("a file of that name exists"),
        ));
    }
    std::fs::create_dir_all(dir).map_err(|e| fail("cannot create it", FIX, e))?;
    let probe = dir.join(format!(".soupray-probe.{}.tmp", std::process::id()));
    let result = (|| {
        use std::io::Write as _;
        let mut f = std::fs::File::create(&probe)?;
        f.write_all(b"soupray write probe\n")?;
        f.sync_all()
    })();
    let removed = std::fs::remove_file(&probe);
    result.map_err(|e| fail("cannot write a file in it", FIX, e))?;
    removed.map_err(|e| {
        fail(
            "cannot remove a file from it (temporary files could not be renamed or cleaned up)",
            FIX,
            e,
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frames(spec: &str) -> Vec<i64> {
        parse_frame_spec(spec).unwrap().frames
    }

    fn err(spec: &str) -> String {
        parse_frame_spec(spec).unwrap_err().0
    }

    #[test]
    fn valid_specs() {
        assert_eq!(frames("7"), vec![7]);
        assert_eq!(frames("1-4"), vec![1, 2, 3, 4]);
        assert_eq!(
            frames("1-10,15,20-30:2"),
            vec![1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 15, 20, 22, 24, 26, 28, 30]
        );
        assert_eq!(frames(" 3 , 1 - 2 "), vec![3, 1, 2]);
        assert_eq!(frames("5-5"), vec![5]);
        assert_eq!(frames("1-10:4"), vec![1, 5, 9]);
    }

    #[test]
    fn negative_frames() {
        assert_eq!(frames("-5"), vec![-5]);
        assert_eq!(frames("-3-1"), vec![-3, -2, -1, 0, 1]);
        assert_eq!(frames("-10--4:3"), vec![-10, -7, -4]);
        assert_eq!(frames("-2--1,-7"), vec![-2, -1, -7]);
    }

    #[test]
    fn duplicates_render_once_in_first_place() {
        assert_eq!(frames("3,1-4,2"), vec![3, 1, 2, 4]);
    }

    #[test]
    fn stepped_range_short_of_end_is_noted() {
        let l = parse_frame_spec("1-10:4").unwrap();
        assert_eq!(l.notes.len(), 1);
        assert!(
            l.notes[0].contains("last frame rendered is 9"),
            "{}",
            l.notes[0]
        );
        assert!(parse_frame_spec("1-9:4").unwrap().notes.is_empty());
    }

    #[test]
    fn bad_specs_say_what_and_how() {
        let e = err("5-2");
        assert!(e.contains("runs backwards") && e.contains("2-5"), "{e}");
        let e = err("a-b");
        assert!(e.contains("\"a-b\"") && e.contains("A-B:STEP"), "{e}");
        let e = err("");
        assert!(e.contains("empty") && e.contains("1-10,15"), "{e}");
        let e = err("   ");
        assert!(e.contains("empty"), "{e}");
        let e = err("1,,2");
        assert!(e.contains("empty item"), "{e}");
        let e = err("1-10:0");
        assert!(e.contains("1 or more"), "{e}");
        let e = err("1-10:x");
        assert!(e.contains("step"), "{e}");
        let e = err("5:2");
        assert!(e.contains("needs a range"), "{e}");
        let e = err("1-");
        assert!(e.contains("no end"), "{e}");
        let e = err("1-2-3");
        assert!(e.contains("unexpected text"), "{e}");
        let e = err("99999999999999999999");
        assert!(e.contains("out of range"), "{e}");
        let e = err("1-100000000");
        assert!(e.contains("smaller chunks"), "{e}");
    }

    #[test]
    fn extreme_ranges_do_not_overflow() {
        let e = err(&format!("{}-{}", i64::MIN, i64::MAX));
        assert!(e.contains("smaller chunks"), "{e}");
        assert_eq!(
            frames(&format!("{}-{}", i64::MAX - 1, i64::MAX)),
            vec![i64::MAX - 1, i64::MAX]
        );
    }

    fn resolve(args: FrameArgs) -> Result<FrameList, UsageError> {
        resolve_frames(&args, (1, 48))
    }

    #[test]
    fn chunk_end_is_never_passed_nor_silently_missed() {
        let l = resolve(FrameArgs {
            start: Some(1),
            end: Some(10),
            step: Some(4),
            ..Default::default()
        })
        .unwrap();
        assert_eq!(l.frames, vec![1, 5, 9]);
        assert_eq!(l.notes.len(), 1, "stopping short of --end must be reported");
        assert!(l.notes[0].contains("--end 10") || l.notes[0].contains("end 10"));
        let l = resolve(FrameArgs {
            start: Some(1),
            end: Some(10),
            step: Some(3),
            ..Default::default()
        })
        .unwrap();
        assert_eq!(l.frames, vec![1, 4, 7, 10]);
        assert!(l.notes.is_empty());
        // The chunk end may lie past the animation: it is honoured as given.
        let l = resolve(FrameArgs {
            start: Some(45),
            end: Some(52),
            ..Default::default()
        })
        .unwrap();
        assert_eq!(l.frames, (45..=52).collect::<Vec<_>>());
    }

    #[test]
    fn open_ends_come_from_the_scene() {
        assert_eq!(
            resolve(FrameArgs::default()).unwrap().frames,
            (1..=48).collect::<Vec<_>>()
        );
        let l = resolve(FrameArgs {
            start: Some(40),
            ..Default::default()
        })
        .unwrap();
        assert_eq!(l.frames, (40..=48).collect::<Vec<_>>());
        let l = resolve(FrameArgs {
            end: Some(3),
            ..Default::default()
        })
        .unwrap();
        assert_eq!(l.frames, vec![1, 2, 3]);
        let l = resolve(FrameArgs {
            step: Some(10),
            ..Default::default()
        })
        .unwrap();
        assert_eq!(l.frames, vec![1, 11, 21, 31, 41]);
        assert_eq!(l.notes.len(), 1);
    }

    #[test]
    fn negative_chunks_and_single_frames() {
        let l = resolve(FrameArgs {
            start: Some(-4),
            end: Some(-1),
            ..Default::default()
        })
        .unwrap();
        assert_eq!(l.frames, vec![-4, -3, -2, -1]);
        let l = resolve(FrameArgs {
            frame: Some(-12),
            ..Default::default()
        })
        .unwrap();
        assert_eq!(l.frames, vec![-12]);
    }

    #[test]
    fn conflicting_or_bad_flags() {
        let e = resolve(FrameArgs {
            frames: Some("1-3".into()),
            frame: Some(2),
            ..Default::default()
        })
        .unwrap_err()
        .0;
        assert!(e.contains("only one"), "{e}");
        let e = resolve(FrameArgs {
            start: Some(10),
            end: Some(2),
            ..Default::default()
        })
        .unwrap_err()
        .0;
        assert!(e.contains("--start 10 is after --end 2"), "{e}");
        let e = resolve(FrameArgs {
            start: Some(60),
            ..Default::default()
        })
        .unwrap_err()
        .0;
        assert!(e.contains("(the scene's)"), "{e}");
        let e = resolve(FrameArgs {
            start: Some(1),
            end: Some(2),
            step: Some(0),
            ..Default::default()
        })
        .unwrap_err()
        .0;
        assert!(e.contains("1 or more"), "{e}");
        let e = resolve(FrameArgs {
            frames: Some("1-3".into()),
            step: Some(2),
            ..Default::default()
        })
        .unwrap_err()
        .0;
        assert!(e.contains("A-B:STEP"), "{e}");
    }

    #[test]
    fn name_patterns() {
        let p = NamePattern::new(&default_name_pattern(Path::new("shots/walk.glb")), 10).unwrap();
        assert_eq!(p.file_name(7), "walk.0007.exr");
        assert_eq!(p.file_name(-7), "walk.-007.exr");
        assert_eq!(p.file_name(0), "walk.0000.exr");
        assert_eq!(p.file_name(12345), "walk.12345.exr");
        let p = NamePattern::new("a#b_##.EXR", 3).unwrap();
        assert_eq!(
            p.file_name(5),
            "a#b_05.EXR",
            "only the last # run is the frame"
        );
        let p = NamePattern::new("still.exr", 1).unwrap();
        assert_eq!(p.file_name(3), "still.exr");
        assert!(NamePattern::new("still.exr", 2)
            .unwrap_err()
            .0
            .contains("no #"));
        assert!(NamePattern::new("x.####.png", 2)
            .unwrap_err()
            .0
            .contains(".exr"));
        assert!(NamePattern::new("d/x.####.exr", 2)
            .unwrap_err()
            .0
            .contains("--out"));
        assert_eq!(format_frame(-1, 3), "-01");
        assert_eq!(format_frame(-1234, 3), "-1234");
    }

    #[test]
    fn frame_files_sit_side_by_side() {
        let p = NamePattern::new("walk.####.exr", 2).unwrap();
        let f = frame_paths(Path::new("out/walk"), &p, 12);
        assert_eq!(f.exr, Path::new("out/walk/walk.0012.exr"));
        assert_eq!(f.png, Path::new("out/walk/walk.0012.png"));
        assert_eq!(f.log, Path::new("out/walk/walk.0012.json"));
        assert_eq!(
            default_out_dir(Path::new("a/b/walk.glb")),
            Path::new("out/walk")
        );
    }

    #[test]
    fn output_dir_is_created_and_probed() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("a/b/c");
        check_output_dir(&dir).unwrap();
        assert!(dir.is_dir());
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            0,
            "the probe is removed"
        );
        let file = tmp.path().join("file");
        std::fs::write(&file, b"x").unwrap();
        let e = check_output_dir(&file).unwrap_err().to_string();
        assert!(e.contains("--out"), "{e}");
    }
}
