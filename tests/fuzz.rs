//! Fuzzing every parser of user input (`geneva_vision::fuzz`): a short campaign per parser in CI
//! (`GENEVA_FUZZ_INPUTS`, default 3,000), a million under `cargo xtask fuzz`; plus the named
//! regressions the campaigns found and the refusals of absurd sizes, with this binary's counting
//! allocator measuring each input's peak allocation.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::{Path, PathBuf};

use geneva_vision::fuzz::{self, AllocMeter, Bounds, Fault, Target};

/// Counts the bytes live on each thread and their peak since the last reset.
struct Counting;

thread_local! {
    static LIVE: Cell<isize> = const { Cell::new(0) };
    static PEAK: Cell<isize> = const { Cell::new(0) };
    static BASE: Cell<isize> = const { Cell::new(0) };
}

fn add(delta: isize) {
    // `try_with`: the thread-locals may be gone while a thread exits.
    let _ = LIVE.try_with(|live| {
        let now = live.get() + delta;
        live.set(now);
        let _ = PEAK.try_with(|p| {
            if now > p.get() {
                p.set(now)
            }
        });
    });
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        add(layout.size() as isize);
        System.alloc(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        add(-(layout.size() as isize));
        System.dealloc(ptr, layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        add(layout.size() as isize);
        System.alloc_zeroed(layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        add(new_size as isize - layout.size() as isize);
        System.realloc(ptr, layout, new_size)
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

fn reset() {
    let live = LIVE.with(Cell::get);
    BASE.with(|b| b.set(live));
    PEAK.with(|p| p.set(live));
}

fn peak_bytes() -> usize {
    (PEAK.with(Cell::get) - BASE.with(Cell::get)).max(0) as usize
}

const METER: AllocMeter = AllocMeter { reset, peak_bytes };

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn inputs_per_parser() -> u64 {
    std::env::var("GENEVA_FUZZ_INPUTS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3_000)
}

fn seed() -> u64 {
    std::env::var("GENEVA_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20261123)
}

/// Every parser, `GENEVA_FUZZ_INPUTS` inputs each: no panic, hang, allocation above the bound,
/// empty, unnamed or repeating error. Prints the count, wall time and peak allocation per parser.
#[test]
fn every_parser_survives_generated_inputs() {
    let count = inputs_per_parser();
    let mut failed = Vec::new();
    let mut total_s = 0.0;
    println!("fuzz: seed {}, {count} inputs per parser", seed());
    for target in Target::ALL {
        let report = fuzz::campaign(
            target,
            &repo(),
            seed(),
            count,
            Bounds::default(),
            Some(METER),
        )
        .unwrap_or_else(|e| panic!("{}: seed files: {e}", target.name()));
        println!("{report}");
        total_s += report.wall.as_secs_f64();
        for f in &report.failures {
            failed.push(format!(
                "{} input {}: {:?}\n  input: {:?}",
                target.name(),
                f.index,
                f.fault,
                String::from_utf8_lossy(&f.input)
            ));
        }
    }
    println!("fuzz: {:.1} s in all", total_s);
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

/// The harness can fail: a panic, a repeated cause and an unnamed file are each caught.
#[test]
fn the_checks_catch_what_they_name() {
    let segments = vec!["a.toml: cannot read: gone".to_string(), "gone".to_string()];
    assert_eq!(
        geneva_vision::errors::repeated_segment(&segments),
        Some("gone".to_string())
    );
    assert_eq!(
        geneva_vision::errors::repeated_segment(&["a.toml: cannot read".into(), "gone".into()]),
        None
    );
    let caught = std::panic::catch_unwind(|| panic!("boom")).map_err(|_| ());
    assert!(caught.is_err());
    // A well-formed refusal passes; the same error without the file name fails for a parser
    // that knows its file.
    let path = Path::new("x/tracks.csv");
    let (verdict, _, _) = fuzz::check_one(
        Target::TracksCsv,
        b"frame,t_s\n",
        path,
        &Bounds::default(),
        None,
    );
    assert_eq!(verdict, Ok(false));
    let unnamed: fuzz::Rejection = "missing columns".into();
    assert!(matches!(
        fuzz::check_rejection(Target::TracksCsv, &unnamed, path),
        Some(Fault::Unnamed(_))
    ));
}

/// Prints input `GENEVA_FUZZ_SHOW` (`target:index`) of the campaign's seed, to study a report: a
/// tool, run by `cargo xtask fuzz --show target:index`, not a check.
#[test]
#[ignore = "a tool, not a check: `cargo xtask fuzz --show target:index` runs it"]
fn show_input() {
    let spec = std::env::var("GENEVA_FUZZ_SHOW").expect("GENEVA_FUZZ_SHOW=target:index");
    let (name, index) = spec.split_once(':').expect("target:index");
    let target = Target::ALL
        .into_iter()
        .find(|t| t.name() == name)
        .expect("target");
    let corpus = fuzz::corpus(target, &repo()).unwrap();
    let bytes = fuzz::input(seed(), target, index.parse().unwrap(), &corpus);
    println!("{}", String::from_utf8_lossy(&bytes));
    let path = target.pseudo_path(&repo());
    println!(
        "{:?}",
        fuzz::check_one(target, &bytes, &path, &Bounds::default(), Some(METER))
    );
}

/// Inputs are a function of (seed, target, index) only.
#[test]
fn inputs_are_reproducible() {
    let corpus = fuzz::corpus(Target::Showinfo, &repo()).unwrap();
    let a: Vec<_> = (0..50)
        .map(|k| fuzz::input(7, Target::Showinfo, k, &corpus))
        .collect();
    let b: Vec<_> = (0..50)
        .map(|k| fuzz::input(7, Target::Showinfo, k, &corpus))
        .collect();
    assert_eq!(a, b);
}

/// Parses `bytes` as `target` under the allocation meter: must refuse, allocating under 64 MiB
/// (the work a refusal does: no buffer sized by the claim), with a message containing `needle`.
fn refuses_small(target: Target, bytes: &[u8], needle: &str) {
    let path = target.pseudo_path(&repo());
    reset();
    let result = fuzz::parse(target, bytes, &path);
    let peak = peak_bytes();
    let e = match result {
        Ok(()) => panic!(
            "{}: accepted {:?}",
            target.name(),
            String::from_utf8_lossy(bytes)
        ),
        Err(e) => geneva_vision::errors::chain(e.as_ref()).join(": "),
    };
    assert!(e.contains(needle), "{e}");
    assert!(peak < 64 << 20, "{}: {peak} bytes for {e}", target.name());
}

/// Headers and fields claiming absurd sizes are refused without allocating for them.
#[test]
fn absurd_sizes_are_refused_without_allocating() {
    refuses_small(
        Target::ScenarioToml,
        b"extend = \"fast.toml\"\nduration_s = 1e12\n",
        "duration_s",
    );
    refuses_small(
        Target::ScenarioToml,
        b"extend = \"fast.toml\"\n[camera]\nwidth_px = 1000000000000\n",
        "width_px",
    );
    refuses_small(
        Target::TimestampsCsv,
        b"frame,t_s\n1000000000000,0.0\n1000000000002,0.1\n",
        "line 3",
    );
    refuses_small(
        Target::Showinfo,
        b"[Parsed_showinfo_0 @ 0x1] n:1000000000000 pts:0 pts_time:0 duration:1\n[Parsed_showinfo_0 @ 0x1] n:   0 pts:1 pts_time:0.1 duration:1\n",
        "showinfo",
    );
    refuses_small(
        Target::TracksCsv,
        b"frame,t_s,marker_id,x0_px,y0_px,x1_px,y1_px,x2_px,y2_px,x3_px,y3_px\n1000000000000,0,0,1,1,2,1,2,2,1,2\n",
        "not a frame number",
    );
    refuses_small(
        Target::VideoProbeJson,
        br#"{"streams":[{"width":1000000000000,"height":1000000000000,"nb_frames":"1000000000000"}],"frames":[]}"#,
        "beyond any camera",
    );
}

/// Regression (found by the campaign: a CR-only file made one 70 MB header line): the header's
/// duplicate check scanned every earlier name, quadratic in the column count (10⁵ columns ran
/// for minutes); a line past `MAX_LINE_BYTES` is now refused naming its line.
#[test]
fn tracks_header_of_many_columns_is_refused_within_the_bound() {
    let many: String = (0..60_000).map(|k| format!("c{k},")).collect();
    let path = Target::TracksCsv.pseudo_path(&repo());
    let (verdict, took, _) = fuzz::check_one(
        Target::TracksCsv,
        format!("{many}\n0,0\n").as_bytes(),
        &path,
        &Bounds::default(),
        None,
    );
    assert_eq!(verdict, Ok(false), "{took:?}");
    let long = format!("{}\n", "frame,".repeat(20_000));
    let e = fuzz::parse(Target::TracksCsv, long.as_bytes(), &path).unwrap_err();
    assert!(e.to_string().contains("line 1: line longer than"), "{e}");
}
