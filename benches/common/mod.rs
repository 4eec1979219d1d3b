//! Helpers shared by the benchmark binaries.

/// Peak resident memory of this process so far (VmHWM), MB; NaN where /proc is unavailable.
#[allow(dead_code)] // not every bench binary prints it
pub fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1).map(str::to_string))
        })
        .and_then(|v| v.parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

/// The machine's load averages over 1, 5 and 15 minutes (`/proc/loadavg`), as printed beside a
/// wall time: on a shared machine a figure means little without the load it was measured under.
#[allow(dead_code)] // not every bench binary prints it
pub fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .map_or_else(|| "unknown".to_string(), |l| format!("{l} (1/5/15 min)"))
}

/// CPU time this process has used so far (user + system, all threads), s; NaN where /proc is
/// unavailable. On a shared machine, CPU time ÷ cores bounds from below the wall time the same
/// work takes with the cores to itself, a figure the load does not distort as much as the wall
/// time.
#[allow(dead_code)] // not every bench binary prints it
pub fn cpu_time_s() -> f64 {
    // Fields 14 and 15 of /proc/self/stat (after the parenthesised command name), in USER_HZ
    // ticks, which Linux fixes at 100 a second for user space.
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            let rest = s.rsplit_once(')')?.1;
            let f: Vec<&str> = rest.split_whitespace().collect();
            // `rest` starts at field 3 (state).
            let ticks = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
            Some(ticks / 100.0)
        })
        .unwrap_or(f64::NAN)
}
