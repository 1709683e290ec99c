//! The one writer of a command's `manifest.json`: every command that leaves a directory
//! of results (simulate pillar, simulate shear and its ramps, quickstart) records the
//! same head — tool, version, command, options — followed by what is its own, and writes
//! it last, atomically, so that a directory holding a manifest holds a finished run.
//! (Pipeline runs keep their own record, `runs/<id>/manifest.json`, written by
//! `pipeline::record` through the same atomic write.)

use crate::error::Result;
use crate::io::atomic_write_str;
use serde::Serialize;
use std::path::Path;

/// The file name, in every result directory.
pub const MANIFEST: &str = "manifest.json";

/// Write `out/manifest.json`: `tool`, `tool_version`, `command` and `options`, and
/// every key of `body` (a JSON object; anything else goes under `result`).
pub fn write(
    out: &Path,
    command: &str,
    options: &impl Serialize,
    body: serde_json::Value,
) -> Result<()> {
    let mut m = serde_json::Map::new();
    m.insert("tool".into(), super::TOOL.into());
    m.insert("tool_version".into(), super::VERSION.into());
    m.insert("command".into(), command.into());
    m.insert(
        "options".into(),
        serde_json::to_value(options).expect("options serialise"),
    );
    if let serde_json::Value::Object(b) = body {
        for (k, v) in b {
            m.insert(k, v);
        }
    } else {
        m.insert("result".into(), body);
    }
    atomic_write_str(
        &out.join(MANIFEST),
        &serde_json::to_string_pretty(&serde_json::Value::Object(m)).expect("json"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_head_and_the_body_are_written() {
        let d = std::env::temp_dir().join(format!("pp-manifest-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        write(
            &d,
            "simulate pillar",
            &serde_json::json!({"n": 3}),
            serde_json::json!({"steps": 7}),
        )
        .unwrap();
        let text = std::fs::read_to_string(d.join(MANIFEST)).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["tool"], "pillar-pipe");
        assert_eq!(v["command"], "simulate pillar");
        assert_eq!(v["options"]["n"], 3);
        assert_eq!(v["steps"], 7);
        std::fs::remove_dir_all(&d).unwrap();
    }
}
