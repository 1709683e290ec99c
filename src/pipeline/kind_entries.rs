// Included by `build.rs` (no `use`, no crate paths): read by hand from what each arm
// of `exec::execute` calls. The dispatch itself (exec, params, the runner) is not an
// entry: parameters reach the key as the stage's resolved parameters.

/// Each stage kind (by name) and the modules its stage function lives in; a kind's
/// source key covers the files reachable from these in the import graph.
pub const KIND_ENTRIES: &[(&str, &[&str])] = &[
    // `force` reads an ingest stage's force sensor (`ingest-force`).
    ("ingest", &["src/stages/ingest.rs", "src/stages/force.rs"]),
    ("simulate", &["src/stages/simulate/mod.rs"]),
    ("kinematics", &["src/stages/kinematics.rs"]),
    ("fit", &["src/stages/fit/mod.rs"]),
    ("compare", &["src/stages/compare.rs"]),
    ("report", &["src/stages/report/mod.rs"]),
    ("shear", &["src/stages/shear/mod.rs"]),
    ("sweep", &["src/stages/sweep.rs"]),
    ("ramp", &["src/stages/shear/mod.rs"]),
    ("render", &["src/stages/render.rs"]),
    ("track", &["src/stages/track.rs"]),
];
