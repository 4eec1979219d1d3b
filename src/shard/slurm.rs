//! Slurm job scripts for the shards of a study: an `sbatch` array script (task I runs shard I/N),
//! a merge script for a job that depends on the whole array, and `submit.sh`, which submits both.
//!
//! Nothing a user gives reaches a script unchecked: the values of `#SBATCH` directives are
//! checked against Slurm's own grammar ([`check_time`], [`check_mem`], [`check_partition`]), a
//! path that lands in a directive may hold none of the characters a directive line splits,
//! comments or expands on ([`check_directive_path`]), no path may hold a line break or another
//! control character ([`check_path`]), and every word of a command is shell-quoted
//! ([`shell_quote`]). [`check_script`] reads a script back as the shell would and is what the
//! fuzzing of these arguments checks every accepted script with.

use std::path::{Path, PathBuf};

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SlurmError {
    #[error("--time `{text}`: {why} (Slurm's forms: MM, MM:SS, HH:MM:SS, D-HH, D-HH:MM, D-HH:MM:SS, or UNLIMITED)")]
    Time { text: String, why: String },
    #[error("--mem `{text}`: {why} (Slurm's form: a whole number with an optional unit K, M, G or T, e.g. 8G)")]
    Mem { text: String, why: String },
    #[error("--partition `{text}`: {why} (Slurm partition names: letters, digits, `_`, `-` and `.`, several separated by commas)")]
    Partition { text: String, why: String },
    #[error("{what} {path:?}: {why}")]
    Path {
        what: String,
        path: PathBuf,
        why: String,
    },
    #[error("--shards {shards}: {why}")]
    Shards { shards: usize, why: String },
    #[error("--cpus-per-task {cpus}: must be at least 1")]
    Cpus { cpus: usize },
    /// A generated script that does not read back as written: a broken invariant of this
    /// module, never a property of the input.
    #[error("internal error: the generated {file} does not read back as written: {why}")]
    Generated { file: String, why: String },
}

/// Longest value of a directive or a path in a script, characters.
const MAX_LEN: usize = 4096;
/// Slurm's largest array index by default (`MaxArraySize` = 1001).
pub const MAX_ARRAY_TASKS: usize = 1001;

/// `--time`: `MM`, `MM:SS`, `HH:MM:SS`, `D-HH`, `D-HH:MM`, `D-HH:MM:SS` (the leading field any
/// whole number, the others below 60, hours after days below 24), or `UNLIMITED`/`INFINITE`.
pub fn check_time(text: &str) -> Result<(), SlurmError> {
    let bad = |why: &str| SlurmError::Time {
        text: text.into(),
        why: why.into(),
    };
    if matches!(text, "UNLIMITED" | "INFINITE" | "unlimited" | "infinite") {
        return Ok(());
    }
    if text.is_empty() || text.len() > 32 {
        return Err(bad("not a time limit"));
    }
    let number = |s: &str, max: Option<u64>, name: &str| -> Result<u64, SlurmError> {
        if s.is_empty() || !s.bytes().all(|b| b.is_ascii_digit()) {
            return Err(bad(&format!("{name} `{s}` is not a whole number")));
        }
        let v: u64 = s
            .parse()
            .map_err(|_| bad(&format!("{name} `{s}` is too large")))?;
        if v > 100_000_000 {
            return Err(bad(&format!("{name} `{s}` is too large")));
        }
        match max {
            Some(m) if v >= m => Err(bad(&format!("{name} `{s}` must be below {m}"))),
            _ => Ok(v),
        }
    };
    let (days, clock) = match text.split_once('-') {
        Some((d, rest)) => (Some(d), rest),
        None => (None, text),
    };
    let parts: Vec<&str> = clock.split(':').collect();
    match (days, parts.as_slice()) {
        (None, [m]) => number(m, None, "minutes").map(drop),
        (None, [m, s]) => {
            number(m, None, "minutes")?;
            number(s, Some(60), "seconds").map(drop)
        }
        (None, [h, m, s]) => {
            number(h, None, "hours")?;
            number(m, Some(60), "minutes")?;
            number(s, Some(60), "seconds").map(drop)
        }
        (Some(d), rest) if !rest.is_empty() && rest.len() <= 3 => {
            number(d, None, "days")?;
            number(rest[0], Some(24), "hours")?;
            for (part, name) in rest[1..].iter().zip(["minutes", "seconds"]) {
                number(part, Some(60), name)?;
            }
            Ok(())
        }
        _ => Err(bad("not one of Slurm's time forms")),
    }
}

/// `--mem`: a whole number of megabytes, or with a unit `K`, `M`, `G` or `T` (either case).
pub fn check_mem(text: &str) -> Result<(), SlurmError> {
    let bad = |why: &str| SlurmError::Mem {
        text: text.into(),
        why: why.into(),
    };
    let digits = text.trim_end_matches(['K', 'M', 'G', 'T', 'k', 'm', 'g', 't']);
    if text.len() - digits.len() > 1 {
        return Err(bad("more than one unit"));
    }
    if digits.is_empty() || digits.len() > 15 || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return Err(bad("not a whole number with a unit"));
    }
    Ok(())
}

/// `--partition`: one or more names of letters, digits, `_`, `-` and `.`, separated by commas.
pub fn check_partition(text: &str) -> Result<(), SlurmError> {
    let bad = |why: String| SlurmError::Partition {
        text: text.into(),
        why,
    };
    if text.len() > 256 {
        return Err(bad("too long".into()));
    }
    for name in text.split(',') {
        if name.is_empty() {
            return Err(bad("an empty name".into()));
        }
        if let Some(c) = name
            .chars()
            .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.')))
        {
            return Err(bad(format!("{c:?} is not allowed in a partition name")));
        }
    }
    Ok(())
}

/// A path that goes into a script: valid UTF-8 (the script is text) without a line break or any
/// other control character (each would end the line it stands on).
pub fn check_path<'a>(what: &str, path: &'a Path) -> Result<&'a str, SlurmError> {
    let bad = |why: &str| SlurmError::Path {
        what: what.into(),
        path: path.into(),
        why: why.into(),
    };
    let text = path
        .to_str()
        .ok_or_else(|| bad("is not valid UTF-8, which a script cannot hold"))?;
    if text.is_empty() || text.len() > MAX_LEN {
        return Err(bad("is empty or too long"));
    }
    if text.chars().any(char::is_control) {
        return Err(bad(
            "holds a line break or another control character, which would end a script line",
        ));
    }
    Ok(text)
}

/// A path that goes into an `#SBATCH` directive (the log files): besides [`check_path`], no
/// white space (sbatch splits a directive there), `#` (it starts a comment), `%` (a file-name
/// pattern of Slurm's), quotes or backslashes (sbatch's own quoting).
pub fn check_directive_path<'a>(what: &str, path: &'a Path) -> Result<&'a str, SlurmError> {
    let text = check_path(what, path)?;
    if let Some(c) = text
        .chars()
        .find(|c| c.is_whitespace() || matches!(c, '#' | '%' | '"' | '\'' | '\\'))
    {
        return Err(SlurmError::Path {
            what: what.into(),
            path: path.into(),
            why: format!(
                "holds {c:?}, which an #SBATCH line cannot carry (white space splits it, `#` \
                 starts a comment, `%` is a file-name pattern); choose a folder whose path has \
                 none of them (--scripts)"
            ),
        });
    }
    Ok(text)
}

/// `word` for bash: as it is when it holds only characters the shell gives no meaning, else in
/// single quotes (a quote inside as `'\''`).
pub fn shell_quote(word: &str) -> String {
    let plain = !word.is_empty()
        && word.chars().all(|c| {
            c.is_ascii_alphanumeric()
                || matches!(c, '_' | '-' | '.' | '/' | ',' | ':' | '=' | '+' | '@')
        });
    if plain {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', "'\\''"))
    }
}

/// Words quoted and joined by spaces.
fn command(words: &[String]) -> String {
    words
        .iter()
        .map(|w| shell_quote(w))
        .collect::<Vec<_>>()
        .join(" ")
}

/// What the tasks run, as words (quoted when the script is written).
#[derive(Debug, Clone, PartialEq)]
pub struct Job {
    /// The study's arguments before `--out`: `["sweep", "/abs/s.toml"]`.
    pub study: Vec<String>,
    /// The merge's arguments: `["sweep", "merge", "/abs/out", "--sweep", "/abs/s.toml"]`.
    pub merge: Vec<String>,
    /// In words, for the scripts' comments.
    pub what: String,
}

/// Everything the scripts are made of.
#[derive(Debug, Clone, PartialEq)]
pub struct ScriptSpec {
    pub job: Job,
    /// The study's output folder (absolute).
    pub out: PathBuf,
    /// The folder of the scripts and of `logs/` (absolute).
    pub scripts: PathBuf,
    /// The geneva binary the nodes run (absolute).
    pub geneva: PathBuf,
    pub shards: usize,
    pub cpus_per_task: usize,
    pub partition: Option<String>,
    pub time: Option<String>,
    pub mem: Option<String>,
}

/// A job name from the output folder's name: the characters a name may hold, others as `_`.
fn job_name(out: &Path) -> String {
    let name: String = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
        .chars()
        .take(64)
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect();
    if name.is_empty() {
        "study".into()
    } else {
        name
    }
}

/// Text for a comment line: control characters (none pass [`check_path`]) shown escaped.
fn comment(text: &str) -> String {
    text.chars()
        .flat_map(|c| {
            if c.is_control() {
                c.escape_default().collect::<Vec<_>>()
            } else {
                vec![c]
            }
        })
        .collect()
}

/// The three scripts, (file name, text), after every check above; any refusal names the option.
pub fn scripts(spec: &ScriptSpec) -> Result<Vec<(&'static str, String)>, SlurmError> {
    if spec.shards == 0 || spec.shards > MAX_ARRAY_TASKS {
        return Err(SlurmError::Shards {
            shards: spec.shards,
            why: format!("must be 1 to {MAX_ARRAY_TASKS} (Slurm's default MaxArraySize)"),
        });
    }
    if spec.cpus_per_task == 0 {
        return Err(SlurmError::Cpus {
            cpus: spec.cpus_per_task,
        });
    }
    let out = check_path("--out", &spec.out)?;
    check_path("--geneva", &spec.geneva)?;
    check_path("--scripts", &spec.scripts)?;
    let logs = spec.scripts.join("logs");
    let logs_text = check_directive_path("the Slurm log folder", &logs)?;
    for word in spec.job.study.iter().chain(&spec.job.merge) {
        check_path("an argument of the job", Path::new(word))?;
    }
    let mut common = String::new();
    if let Some(p) = &spec.partition {
        check_partition(p)?;
        common.push_str(&format!("#SBATCH --partition={p}\n"));
    }
    if let Some(t) = &spec.time {
        check_time(t)?;
        common.push_str(&format!("#SBATCH --time={t}\n"));
    }
    if let Some(m) = &spec.mem {
        check_mem(m)?;
        common.push_str(&format!("#SBATCH --mem={m}\n"));
    }
    let name = job_name(&spec.out);
    let (n, cpus) = (spec.shards, spec.cpus_per_task);
    let geneva = shell_quote(check_path("--geneva", &spec.geneva)?);
    let mut study = spec.job.study.clone();
    study.extend(["--out".to_string(), out.to_string()]);
    let shards = format!(
        "#!/bin/bash\n\
         # {what} as {n} Slurm array tasks: task I runs shard I/{n} into {out_q}/shards/I/.\n\
         # Generated by `geneva slurm script`; re-running a task resumes its shard.\n\
         #SBATCH --job-name=geneva-{name}\n\
         #SBATCH --array=0-{last}\n\
         #SBATCH --cpus-per-task={cpus}\n\
         {common}\
         #SBATCH --output={logs_text}/shard-%a.log\n\
         set -euo pipefail\n\
         export RAYON_NUM_THREADS=\"${{SLURM_CPUS_PER_TASK:-{cpus}}}\"\n\
         exec {geneva} {study} --shard \"${{SLURM_ARRAY_TASK_ID}}/{n}\"\n",
        what = comment(&spec.job.what),
        out_q = comment(&shell_quote(out)),
        last = n - 1,
        study = command(&study),
    );
    let merge = format!(
        "#!/bin/bash\n\
         # Merges the shards of {out_q} (runs after every array task succeeded).\n\
         #SBATCH --job-name=geneva-{name}-merge\n\
         #SBATCH --cpus-per-task=1\n\
         {common}\
         #SBATCH --output={logs_text}/merge.log\n\
         set -euo pipefail\n\
         exec {geneva} {merge}\n",
        out_q = comment(&shell_quote(out)),
        merge = command(&spec.job.merge),
    );
    let quoted = |file: &str| -> Result<String, SlurmError> {
        let p = spec.scripts.join(file);
        Ok(shell_quote(check_path("--scripts", &p)?))
    };
    let submit = format!(
        "#!/bin/bash\n\
         # Submits the array job, then the merge job that waits for all its tasks to succeed.\n\
         set -euo pipefail\n\
         array=$(sbatch --parsable {shards_q})\n\
         array=${{array%%;*}}\n\
         merge=$(sbatch --parsable --dependency=afterok:\"$array\" --kill-on-invalid-dep=yes {merge_q})\n\
         echo \"array job $array, merge job ${{merge%%;*}}\"\n",
        shards_q = quoted("shards.sbatch")?,
        merge_q = quoted("merge.sbatch")?,
    );
    let scripts = vec![
        ("shards.sbatch", shards),
        ("merge.sbatch", merge),
        ("submit.sh", submit),
    ];
    for (file, text) in &scripts {
        check_script(file, text, spec).map_err(|why| SlurmError::Generated {
            file: file.to_string(),
            why,
        })?;
    }
    Ok(scripts)
}

/// The words of one shell command line as bash reads them, or why the line is more than one
/// command of plain words: unquoted words, single-quoted text, double-quoted text whose only
/// expansion is `${NAME}` / `${NAME:-word}` (kept as written), nothing else.
pub fn shell_words(line: &str) -> Result<Vec<String>, String> {
    let mut words = Vec::new();
    let mut word = String::new();
    let mut in_word = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            ' ' => {
                if in_word {
                    words.push(std::mem::take(&mut word));
                    in_word = false;
                }
            }
            '\'' => {
                in_word = true;
                loop {
                    match chars.next() {
                        Some('\'') => break,
                        Some(x) => word.push(x),
                        None => return Err("an unclosed single quote".into()),
                    }
                }
            }
            '\\' => {
                in_word = true;
                word.push(chars.next().ok_or("a backslash at the end")?);
            }
            '"' => {
                in_word = true;
                loop {
                    match chars.next() {
                        Some('"') => break,
                        Some('$') => {
                            if chars.next() != Some('{') {
                                return Err("a `$` expansion other than ${NAME}".into());
                            }
                            word.push_str("${");
                            loop {
                                match chars.next() {
                                    Some('}') => break,
                                    Some(x) if x.is_ascii_alphanumeric() || "_:-".contains(x) => {
                                        word.push(x)
                                    }
                                    _ => return Err("a `${` expansion of more than a name".into()),
                                }
                            }
                            word.push('}');
                        }
                        Some(x @ ('`' | '\\' | '!')) => {
                            return Err(format!("{x:?} inside double quotes"))
                        }
                        Some(x) => word.push(x),
                        None => return Err("an unclosed double quote".into()),
                    }
                }
            }
            c if c.is_ascii_alphanumeric() || "_-./,:=+@%".contains(c) => {
                in_word = true;
                word.push(c);
            }
            other => return Err(format!("{other:?} outside quotes")),
        }
    }
    if in_word {
        words.push(word);
    }
    Ok(words)
}

/// Checks that `text` is the script `file` of `spec` and nothing else: its lines are the
/// template's, every directive one `--key=value` word, and every command the words intended.
pub fn check_script(file: &str, text: &str, spec: &ScriptSpec) -> Result<(), String> {
    let geneva = spec.geneva.to_string_lossy().into_owned();
    let mut study: Vec<String> = vec![geneva.clone()];
    study.extend(spec.job.study.iter().cloned());
    study.extend([
        "--out".to_string(),
        spec.out.to_string_lossy().into_owned(),
        "--shard".to_string(),
        format!("${{SLURM_ARRAY_TASK_ID}}/{}", spec.shards),
    ]);
    let mut merge: Vec<String> = vec![geneva];
    merge.extend(spec.job.merge.iter().cloned());
    let directives = 4 + [&spec.partition, &spec.time, &spec.mem]
        .iter()
        .filter(|v| v.is_some())
        .count();
    let mut commands: Vec<Vec<String>> = Vec::new();
    let (mut comments, mut sbatch) = (0, 0);
    for (k, line) in text.lines().enumerate() {
        if k == 0 {
            if line != "#!/bin/bash" {
                return Err(format!("line 1 is {line:?}"));
            }
        } else if let Some(d) = line.strip_prefix("#SBATCH ") {
            let ok = d.starts_with("--")
                && d.split_once('=').is_some_and(|(key, value)| {
                    key[2..].chars().all(|c| c.is_ascii_lowercase() || c == '-')
                        && !value.is_empty()
                        && !value
                            .chars()
                            .any(|c| c.is_whitespace() || "#\"'\\".contains(c))
                });
            if !ok {
                return Err(format!("line {} is not one directive: {line:?}", k + 1));
            }
            sbatch += 1;
        } else if line.starts_with("# ") {
            comments += 1;
        } else if file == "submit.sh" {
            // Its own `$(…)` and `${…}`: only the quoted script paths are words of ours.
            if let Some(q) = line
                .strip_prefix("array=$(sbatch --parsable ")
                .or_else(|| line.split_once("--kill-on-invalid-dep=yes ").map(|x| x.1))
            {
                let words = shell_words(q.strip_suffix(')').unwrap_or(q))
                    .map_err(|e| format!("line {}: {e}: {line:?}", k + 1))?;
                if words.len() != 1 {
                    return Err(format!("line {}: {words:?}", k + 1));
                }
            }
            commands.push(Vec::new());
        } else {
            commands.push(shell_words(line).map_err(|e| format!("line {}: {e}: {line:?}", k + 1))?);
        }
    }
    let expected: (usize, usize, usize) = match file {
        "shards.sbatch" => (2, directives, 3),
        "merge.sbatch" => (1, directives - 1, 2),
        _ => (1, 0, 0),
    };
    if (comments, sbatch) != (expected.0, expected.1) {
        return Err(format!(
            "{comments} comment(s) and {sbatch} directive(s), expected {} and {}",
            expected.0, expected.1
        ));
    }
    let last = commands.last().cloned().unwrap_or_default();
    match file {
        "shards.sbatch" | "merge.sbatch" => {
            let want = if file == "shards.sbatch" {
                &study
            } else {
                &merge
            };
            if commands.len() != expected.2
                || last.first().map(String::as_str) != Some("exec")
                || last[1..] != want[..]
            {
                return Err(format!("its command is {last:?}, not {want:?}"));
            }
        }
        _ => {
            if commands.len() != 5 {
                return Err(format!("{} lines of commands, expected 5", commands.len()));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slurm_time_and_memory_forms_are_accepted_and_anything_else_refused() {
        for ok in [
            "30",
            "30:00",
            "01:00:00",
            "2-0",
            "2-12",
            "2-12:30",
            "2-12:30:59",
            "0",
            "UNLIMITED",
        ] {
            check_time(ok).unwrap_or_else(|e| panic!("{ok}: {e}"));
        }
        for bad in [
            "",
            "01:00:00\necho pwned",
            "1 --wrap=x",
            "1:2:3:4",
            "1-25",
            "1-1:60",
            "00:60:00",
            "-1",
            "1-",
            "1h",
            "99999999999999999999",
        ] {
            let e = check_time(bad).unwrap_err().to_string();
            assert!(e.contains("--time") && e.contains("MM:SS"), "{bad:?}: {e}");
        }
        for ok in ["8G", "8000", "512m", "1T", "0"] {
            check_mem(ok).unwrap_or_else(|e| panic!("{ok}: {e}"));
        }
        for bad in ["8G --wrap=x", "", "G", "8GB", "8.5G", "8G\n", "-8G"] {
            let e = check_mem(bad).unwrap_err().to_string();
            assert!(e.contains("--mem"), "{bad:?}: {e}");
        }
        for ok in ["gpu", "debug,long", "a_b-c.d"] {
            check_partition(ok).unwrap_or_else(|e| panic!("{ok}: {e}"));
        }
        for bad in ["gpu\nrm -rf ~", "gpu long", "", "a,,b", "a;b", "gpu#x"] {
            let e = check_partition(bad).unwrap_err().to_string();
            assert!(e.contains("--partition"), "{bad:?}: {e}");
        }
    }

    #[test]
    fn quoted_words_read_back_as_the_same_words() {
        for w in [
            "plain",
            "/a b/c",
            "it's",
            "$(rm -rf ~)",
            "`x`",
            "a\"b",
            "x;y",
            "%a",
            "#c",
            "-",
        ] {
            let q = shell_quote(w);
            assert_eq!(shell_words(&q).unwrap(), vec![w.to_string()], "{q}");
        }
        assert!(shell_words("a; b").is_err());
        assert!(shell_words("a $(b)").is_err());
    }
}
