//! The real-Slurm integration test of `geneva slurm script`: a single-node Slurm cluster on
//! localhost (munged, slurmctld, slurmd from Debian's `slurm-wlm` and `munge`, started in the
//! foreground from a temporary folder with a generated `slurm.conf`), a small sweep submitted as
//! 4 array tasks plus the dependent merge job, and a byte-for-byte comparison of the merged
//! results with a one-machine run. Every daemon it started is stopped by its process id (and
//! only those), also when the test fails. Runs only as root on Debian; otherwise it says why it
//! is skipped.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Debian packages of a single-node cluster.
pub const PACKAGES: &[&str] = &["slurm-wlm", "munge"];
/// The sweep submitted (8 runs of the `fast` scenario) and its shard count.
const SWEEP: &str = "scenarios/sweeps/fast.toml";
const SHARDS: usize = 4;
const JOB_TIMEOUT: Duration = Duration::from_secs(300);

/// Files that must be byte-identical between the merged and the one-machine folder.
const OUTPUTS: &[&str] = &[
    "results.csv",
    "summary.csv",
    "recommendation.md",
    "heatmap_alpha_rms.png",
    "heatmap_omega_rms.png",
    "manifest.json",
];

/// Daemons we started, stopped by pid when dropped.
struct Daemons {
    children: Vec<(String, Child)>,
}

impl Drop for Daemons {
    fn drop(&mut self) {
        // Reverse order: slurmd, slurmctld, then munged (they need it to shut down cleanly).
        while let Some((name, mut child)) = self.children.pop() {
            let pid = child.id();
            if let Ok(Some(_)) = child.try_wait() {
                eprintln!("xtask slurm: {name} (pid {pid}) had already exited");
                continue;
            }
            let _ = Command::new("kill")
                .args(["-TERM", &pid.to_string()])
                .status();
            let deadline = Instant::now() + Duration::from_secs(15);
            loop {
                match child.try_wait() {
                    Ok(Some(_)) => break,
                    Ok(None) if Instant::now() < deadline => {
                        std::thread::sleep(Duration::from_millis(100))
                    }
                    _ => {
                        let _ = child.kill();
                        let _ = child.wait();
                        break;
                    }
                }
            }
            eprintln!("xtask slurm: stopped {name} (pid {pid})");
        }
    }
}

impl Daemons {
    fn start(&mut self, name: &str, mut command: Command, log: &Path) -> Result<(), String> {
        let out = std::fs::File::create(log).map_err(|e| format!("{}: {e}", log.display()))?;
        let err = out.try_clone().map_err(|e| e.to_string())?;
        command.stdout(out).stderr(err).stdin(Stdio::null());
        let child = command
            .spawn()
            .map_err(|e| format!("could not start {name}: {e}"))?;
        eprintln!("xtask slurm: started {name} (pid {})", child.id());
        self.children.push((name.to_string(), child));
        Ok(())
    }

    /// Fails if a daemon has already exited.
    fn check_alive(&mut self, tmp: &Path) -> Result<(), String> {
        for (name, child) in &mut self.children {
            if let Ok(Some(status)) = child.try_wait() {
                return Err(format!(
                    "{name} exited ({status}); its log: {}",
                    tmp.join("log").join(format!("{name}.log")).display()
                ));
            }
        }
        Ok(())
    }
}

fn output(command: &mut Command) -> Result<String, String> {
    let out = command
        .output()
        .map_err(|e| format!("could not run {command:?}: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "{command:?} failed ({}): {}{}",
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

fn free_port() -> Result<u16, String> {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .map_err(|e| format!("no free port on 127.0.0.1: {e}"))
}

/// Whether the test ran (and passed: a failure is an error) or why it could not.
#[derive(Debug, PartialEq)]
pub enum Outcome {
    Ran,
    Skipped(String),
}

/// The test; `geneva` is the binary to put in the scripts.
pub fn integration_test(geneva: &Path) -> Result<Outcome, String> {
    if !crate::system::is_root() {
        return Ok(Outcome::Skipped(
            "it needs root (to install slurm-wlm and munge and start their daemons)".into(),
        ));
    }
    if !Path::new("/etc/debian_version").exists() || !crate::system::has_dpkg() {
        return Ok(Outcome::Skipped("not a Debian system".into()));
    }
    crate::system::ensure(PACKAGES)?;
    let started = Instant::now();
    let tmp = std::env::temp_dir().join(format!("geneva-slurm-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    let result = cluster_test(&tmp, geneva);
    if result.is_ok() {
        let _ = std::fs::remove_dir_all(&tmp);
    } else {
        eprintln!("xtask slurm: logs kept in {}", tmp.display());
    }
    result?;
    eprintln!(
        "xtask slurm: integration test passed in {:.0} s",
        started.elapsed().as_secs_f64()
    );
    Ok(Outcome::Ran)
}

fn cluster_test(tmp: &Path, geneva: &Path) -> Result<(), String> {
    let dirs = ["munge", "state", "spool", "log", "work"];
    for d in dirs {
        std::fs::create_dir_all(tmp.join(d)).map_err(|e| format!("{}: {e}", tmp.display()))?;
    }
    // munged wants its socket folder open to all and its key folder closed to others.
    let munge = tmp.join("munge");
    let key = munge.join("key").join("munge.key");
    std::fs::create_dir_all(munge.join("key")).map_err(|e| e.to_string())?;
    let mut bytes = vec![0u8; 1024];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut bytes))
        .map_err(|e| format!("/dev/urandom: {e}"))?;
    std::fs::write(&key, bytes).map_err(|e| e.to_string())?;
    output(
        Command::new("chown")
            .args(["-R", "munge:munge"])
            .arg(&munge),
    )?;
    output(Command::new("chmod").arg("0755").arg(&munge))?;
    output(Command::new("chmod").arg("0700").arg(munge.join("key")))?;
    output(Command::new("chmod").arg("0400").arg(&key))?;
    let socket = munge.join("munge.socket");
    let mut daemons = Daemons {
        children: Vec::new(),
    };
    let mut munged = Command::new("setpriv");
    munged
        .args([
            "--reuid=munge",
            "--regid=munge",
            "--init-groups",
            "munged",
            "--foreground",
        ])
        .arg(format!("--key-file={}", key.display()))
        .arg(format!("--socket={}", socket.display()))
        .arg(format!("--pid-file={}", munge.join("munged.pid").display()))
        .arg(format!("--log-file={}", munge.join("munged.log").display()))
        .arg(format!(
            "--seed-file={}",
            munge.join("munged.seed").display()
        ));
    daemons.start("munged", munged, &tmp.join("log/munged.log"))?;
    wait_for("munged's socket", Duration::from_secs(20), || {
        daemons.check_alive(tmp)?;
        Ok(socket.exists())
    })?;

    // The node's real CPUs and memory, as slurmd itself reports them.
    let node_line = output(Command::new("slurmd").arg("-C"))?
        .lines()
        .find(|l| l.starts_with("NodeName="))
        .ok_or("slurmd -C printed no NodeName line")?
        .to_string();
    let node = node_line
        .split_whitespace()
        .next()
        .and_then(|w| w.strip_prefix("NodeName="))
        .ok_or("slurmd -C: no node name")?
        .to_string();
    let conf = tmp.join("slurm.conf");
    let text = format!(
        "# Generated by `cargo xtask test`: a single-node cluster on localhost.\n\
         ClusterName=geneva-test\n\
         SlurmctldHost={node}(127.0.0.1)\n\
         SlurmctldPort={ctld_port}\n\
         SlurmdPort={d_port}\n\
         SlurmUser=root\n\
         SlurmdUser=root\n\
         AuthType=auth/munge\n\
         CredType=cred/munge\n\
         AuthInfo=socket={socket}\n\
         StateSaveLocation={tmp}/state\n\
         SlurmdSpoolDir={tmp}/spool\n\
         SlurmctldPidFile={tmp}/slurmctld.pid\n\
         SlurmdPidFile={tmp}/slurmd.pid\n\
         SlurmctldLogFile={tmp}/log/slurmctld.daemon.log\n\
         SlurmdLogFile={tmp}/log/slurmd.daemon.log\n\
         ProctrackType=proctrack/linuxproc\n\
         TaskPlugin=task/none\n\
         SelectType=select/cons_tres\n\
         SelectTypeParameters=CR_Core\n\
         JobAcctGatherType=jobacct_gather/none\n\
         AccountingStorageType=accounting_storage/none\n\
         JobCompType=jobcomp/none\n\
         MpiDefault=none\n\
         ReturnToService=2\n\
         SchedulerType=sched/backfill\n\
         MinJobAge=600\n\
         {node_line} NodeAddr=127.0.0.1 State=UNKNOWN\n\
         PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n",
        ctld_port = free_port()?,
        d_port = free_port()?,
        socket = socket.display(),
        tmp = tmp.display(),
    );
    std::fs::write(&conf, text).map_err(|e| e.to_string())?;
    let env = |c: &mut Command| {
        c.env("SLURM_CONF", &conf);
    };
    let mut ctld = Command::new("slurmctld");
    ctld.args(["-D", "-i", "-f"]).arg(&conf);
    daemons.start("slurmctld", ctld, &tmp.join("log/slurmctld.log"))?;
    let mut slurmd = Command::new("slurmd");
    slurmd.args(["-D", "-N", &node, "-f"]).arg(&conf);
    daemons.start("slurmd", slurmd, &tmp.join("log/slurmd.log"))?;
    wait_for("the node to be idle", Duration::from_secs(60), || {
        daemons.check_alive(tmp)?;
        let mut sinfo = Command::new("sinfo");
        sinfo.args(["-h", "-o", "%T"]);
        env(&mut sinfo);
        Ok(output(&mut sinfo).is_ok_and(|s| s.trim() == "idle"))
    })?;

    // The one-machine reference, then the same sweep as an array job and a merge job.
    let work = tmp.join("work");
    let sweep = std::path::absolute(SWEEP).map_err(|e| e.to_string())?;
    output(
        Command::new(geneva)
            .arg("sweep")
            .arg(&sweep)
            .arg("--out")
            .arg(work.join("single")),
    )?;
    let merged = work.join("cluster");
    let printed = output(
        Command::new(geneva)
            .args(["slurm", "script"])
            .arg(&sweep)
            .arg("--out")
            .arg(&merged)
            .args(["--shards", &SHARDS.to_string(), "--time", "00:10:00"])
            .args(["--cpus-per-task", "1", "--mem", "1G"]),
    )?;
    let submit_line = printed
        .lines()
        .skip_while(|l| !l.starts_with("submit with:"))
        .nth(1)
        .ok_or_else(|| format!("no submit command in: {printed}"))?
        .trim()
        .to_string();
    let mut submit = Command::new("bash");
    submit.arg("-c").arg(&submit_line);
    env(&mut submit);
    let ids = output(&mut submit)?;
    let words: Vec<&str> = ids.split_whitespace().collect();
    let (array, merge) = match words.as_slice() {
        ["array", "job", a, "merge", "job", m] => {
            (a.trim_end_matches(',').to_string(), m.to_string())
        }
        _ => return Err(format!("unexpected submit output: {ids}")),
    };
    eprintln!("xtask slurm: submitted array job {array} ({SHARDS} tasks) and merge job {merge}");
    let waited = wait_for("the jobs to finish", JOB_TIMEOUT, || {
        daemons.check_alive(tmp)?;
        let mut q = Command::new("squeue");
        q.args(["-h", "-o", "%i %T", "-j", &format!("{array},{merge}")]);
        env(&mut q);
        Ok(output(&mut q).map(|s| s.trim().is_empty()).unwrap_or(false))
    });
    if let Err(e) = waited {
        let mut cancel = Command::new("scancel");
        cancel.args([&array, &merge]);
        env(&mut cancel);
        let _ = output(&mut cancel);
        return Err(e);
    }
    for id in [&array, &merge] {
        let mut show = Command::new("scontrol");
        show.args(["show", "job", id]);
        env(&mut show);
        let state = output(&mut show)?;
        let tasks = state.matches("JobState=COMPLETED").count();
        eprintln!("xtask slurm: job {id}: {tasks} task(s) COMPLETED");
    }
    let mut show = Command::new("scontrol");
    show.args(["show", "job", &merge]);
    env(&mut show);
    let state = output(&mut show)?;
    if !state.contains("JobState=COMPLETED") {
        return Err(format!(
            "merge job {merge} did not complete:\n{state}\nlogs: {}",
            merged.with_file_name("cluster-slurm/logs").display()
        ));
    }
    for f in OUTPUTS {
        let a =
            std::fs::read(work.join("single").join(f)).map_err(|e| format!("single/{f}: {e}"))?;
        let b = std::fs::read(merged.join(f)).map_err(|e| format!("cluster/{f}: {e}"))?;
        if a != b {
            return Err(format!(
                "{f}: the merged Slurm result differs from the one-machine run"
            ));
        }
    }
    eprintln!(
        "xtask slurm: {} merged files equal the one-machine run byte for byte",
        OUTPUTS.len()
    );
    drop(daemons);
    Ok(())
}

fn wait_for(
    what: &str,
    timeout: Duration,
    mut ready: impl FnMut() -> Result<bool, String>,
) -> Result<(), String> {
    let deadline = Instant::now() + timeout;
    while Instant::now() < deadline {
        if ready()? {
            return Ok(());
        }
        std::thread::sleep(Duration::from_millis(500));
    }
    Err(format!(
        "timed out after {} s waiting for {what}",
        timeout.as_secs()
    ))
}

/// The geneva binary that `cargo test` built for the integration tests, or `GENEVA_BIN`.
pub fn test_binary() -> Result<PathBuf, String> {
    if let Some(bin) = std::env::var_os("GENEVA_BIN") {
        return Ok(PathBuf::from(bin));
    }
    let bin = target_dir().join("debug").join("geneva");
    if bin.exists() {
        Ok(bin)
    } else {
        geneva_binary()
    }
}

fn target_dir() -> PathBuf {
    let dir = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("target"));
    std::path::absolute(&dir).unwrap_or(dir)
}

/// The geneva binary of the test build (built if needed), or `GENEVA_BIN`.
pub fn geneva_binary() -> Result<PathBuf, String> {
    if let Some(bin) = std::env::var_os("GENEVA_BIN") {
        return Ok(PathBuf::from(bin));
    }
    let mut build = crate::cargo();
    build.args(["build", "--profile", "test", "--bin", "geneva"]);
    crate::run(build)?;
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("target"));
    let bin =
        std::path::absolute(target.join("debug").join("geneva")).map_err(|e| e.to_string())?;
    if bin.exists() {
        Ok(bin)
    } else {
        Err(format!("{}: not built", bin.display()))
    }
}
