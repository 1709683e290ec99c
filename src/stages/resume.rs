//! The one rule by which `--resume` continues a run, for the pillar and the sheared
//! disks alike. A checkpoint records the options its run computes with (JSON, the
//! run-only ones left out); the resumed run must compute with the same. Options added
//! in a later version are absent from older checkpoints, so a key recorded on one side
//! only counts as equal when its value there is the option's default: the old run
//! computed exactly what the default computes.

use crate::error::{Error, Result};
use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::{Map, Value};
use std::collections::BTreeSet;
use std::fmt;

/// Options that say how a run proceeds, not what it computes: a resumed run may change
/// them, and they enter no cache key.
pub const RUN_ONLY: [&str; 4] = ["resume", "quiet", "checkpoint_every", "checkpoint_interval"];

/// An option on which the interrupted run (`then`) and this one (`now`) disagree;
/// `None` where that side does not have the key.
#[derive(Debug, Clone, PartialEq)]
pub struct Difference {
    pub key: String,
    pub then: Option<Value>,
    pub now: Option<Value>,
}

impl fmt::Display for Difference {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let show = |v: &Option<Value>| v.as_ref().map_or("not set".to_string(), Value::to_string);
        write!(
            f,
            "{}: then {}, now {}",
            self.key,
            show(&self.then),
            show(&self.now)
        )
    }
}

/// `v` (an options struct serialised, or a checkpoint's record) as a JSON object
/// without the run-only keys.
pub fn physics(v: Value) -> Map<String, Value> {
    let mut m = match v {
        Value::Object(m) => m,
        _ => Map::new(),
    };
    for k in RUN_ONLY {
        m.remove(k);
    }
    m
}

/// A checkpoint's recorded options as a JSON object (run-only keys dropped), or an error
/// naming the checkpoint.
pub fn recorded(ckpt: &std::path::Path, then: &str) -> Result<Map<String, Value>> {
    match serde_json::from_str::<Value>(then) {
        Ok(v @ Value::Object(_)) => Ok(physics(v)),
        Ok(_) | Err(_) => Err(Error::input(
            ckpt.display(),
            format!("the recorded options are not a JSON object: {then}"),
        )),
    }
}

/// Every option on which `then` and `now` disagree, by key; `defaults` settles the keys
/// that only one side has.
pub fn differences(
    then: &Map<String, Value>,
    now: &Map<String, Value>,
    defaults: &Map<String, Value>,
) -> Vec<Difference> {
    let keys: BTreeSet<&String> = then.keys().chain(now.keys()).collect();
    keys.into_iter()
        .filter(|k| !RUN_ONLY.contains(&k.as_str()))
        .filter_map(|k| {
            let (a, b) = (then.get(k), now.get(k));
            let same = match (a, b) {
                (Some(a), Some(b)) => a == b,
                (Some(v), None) | (None, Some(v)) => defaults.get(k) == Some(v),
                (None, None) => true,
            };
            (!same).then(|| Difference {
                key: k.clone(),
                then: a.cloned(),
                now: b.cloned(),
            })
        })
        .collect()
}

/// Refuse a resume whose options differ, naming every differing key with both values;
/// `note` (may be empty) is added to explain a particular key.
pub fn refuse_differences(diffs: &[Difference], note: &str) -> Result<()> {
    if diffs.is_empty() {
        return Ok(());
    }
    let list: Vec<String> = diffs.iter().map(ToString::to_string).collect();
    Err(Error::param(
        "resume",
        format!(
            "the options differ from the interrupted run's: {}{note}",
            list.join("; ")
        ),
    ))
}

/// The options a resume runs with when the command line gave only `given` (keys of the
/// options' JSON): every other option takes the interrupted run's recorded value.
/// Returns them and the options so taken whose value differs from `opt`'s (what the
/// caller would have used otherwise). Fields the options do not serialise (threads,
/// testing aids) come back at their defaults: the caller restores them.
pub fn adopt<T: Serialize + DeserializeOwned>(
    opt: &T,
    then: &Map<String, Value>,
    given: &BTreeSet<String>,
) -> Result<(T, Vec<(String, Value)>)> {
    let mut now = serde_json::to_value(opt).expect("options serialise");
    let obj = now.as_object_mut().expect("options are an object");
    let mut taken = Vec::new();
    for (k, v) in then {
        if given.contains(k) || RUN_ONLY.contains(&k.as_str()) {
            continue;
        }
        // A key that today's options lack is left to `differences` to judge.
        if let Some(cur) = obj.get_mut(k)
            && cur != v
        {
            *cur = v.clone();
            taken.push((k.clone(), v.clone()));
        }
    }
    let opt = serde_json::from_value(now).map_err(|e| {
        Error::param(
            "resume",
            format!("the interrupted run's recorded options do not read as this version's: {e}"),
        )
    })?;
    Ok((opt, taken))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn obj(v: Value) -> Map<String, Value> {
        physics(v)
    }

    #[test]
    fn a_key_on_one_side_only_is_equal_iff_it_holds_the_default() {
        let defaults = obj(json!({"strain": 0.3, "law": "linear"}));
        let then = obj(json!({"strain": 0.3}));
        assert!(
            differences(
                &then,
                &obj(json!({"strain": 0.3, "law": "linear"})),
                &defaults
            )
            .is_empty()
        );
        let d = differences(
            &then,
            &obj(json!({"strain": 0.3, "law": "hertz"})),
            &defaults,
        );
        assert_eq!(d.len(), 1);
        assert_eq!(d[0].to_string(), "law: then not set, now \"hertz\"");
        // A key recorded then but unknown now (no default): refused.
        let d = differences(&obj(json!({"from_step": 5})), &Map::new(), &defaults);
        assert_eq!(d[0].to_string(), "from_step: then 5, now not set");
    }

    #[test]
    fn every_difference_is_named_and_run_only_keys_are_ignored() {
        let then = obj(json!({"strain": 0.3, "seed": 1, "n": 5}));
        let mut now = obj(json!({"strain": 0.5, "seed": 2, "n": 5}));
        now.insert("quiet".into(), json!(true));
        now.insert("checkpoint_every".into(), json!(100));
        let d = differences(&then, &now, &Map::new());
        let msg = refuse_differences(&d, "").unwrap_err().to_string();
        assert!(
            msg.contains("seed: then 1, now 2") && msg.contains("strain: then 0.3, now 0.5"),
            "{msg}"
        );
        assert_eq!(d.len(), 2);
    }

    #[test]
    fn adopt_takes_what_was_not_given() {
        #[derive(Serialize, serde::Deserialize, Default)]
        struct O {
            seed: u64,
            strain: f64,
            quiet: bool,
        }
        let then = obj(json!({"seed": 7, "strain": 0.05, "quiet": false}));
        let cli = O {
            seed: 1,
            strain: 0.05,
            quiet: true,
        };
        let (o, taken) = adopt(&cli, &then, &BTreeSet::new()).unwrap();
        assert_eq!((o.seed, o.strain, o.quiet), (7, 0.05, true));
        assert_eq!(taken, vec![("seed".to_string(), json!(7))]);
        let given = BTreeSet::from(["seed".to_string()]);
        let (o, taken) = adopt(&cli, &then, &given).unwrap();
        assert_eq!(o.seed, 1);
        assert!(taken.is_empty());
    }
}
