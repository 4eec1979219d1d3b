//! Scenarios compiled into the binary, so the default job runs with no files at all.
//! The files under `scenarios/` are the source of truth; these are the same bytes.

/// The scenario `geneva demo` and `cargo xtask demo` run.
pub const DEFAULT_SCENARIO: &str = "seed-internal-4k";

const BUILTINS: &[(&str, &str)] = &[
    (
        "seed-internal-4k",
        include_str!("../../scenarios/seed-internal-4k.toml"),
    ),
    (
        "seed-external-4k",
        include_str!("../../scenarios/seed-external-4k.toml"),
    ),
    ("fast", include_str!("../../scenarios/fast.toml")),
];

/// The text of the built-in scenario `name` (with or without `.toml`).
pub fn builtin_text(name: &str) -> Option<&'static str> {
    let name = name.trim_end_matches(".toml");
    BUILTINS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, text)| *text)
}

/// Names of all built-in scenarios.
pub fn builtin_names() -> Vec<&'static str> {
    BUILTINS.iter().map(|(n, _)| *n).collect()
}
