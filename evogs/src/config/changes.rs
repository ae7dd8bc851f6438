//! The differences between two configurations, key by key, and which of them a resumed run
//! may take: a resume continues its checkpoint's model, data and optimiser exactly, so only
//! the keys that decide how long it runs and what it records besides may change
//! ([`RESUMABLE_KEYS`]).

use super::TrainConfig;

/// Keys a resumed run may change: how long it runs (`schedule.iterations`), when it writes
/// checkpoints and log rows, how many decoded frames it keeps in memory, and how the
/// dataset's layout is named (the data itself is compared by its fingerprint). None of them
/// changes an iteration's arithmetic.
pub const RESUMABLE_KEYS: &[&str] = &[
    "schedule.iterations",
    "schedule.checkpoint_every",
    "schedule.checkpoint_minutes",
    "schedule.log_every",
    "data.cache_mb",
    "data.format",
];

/// One key whose value differs between two configurations.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConfigChange {
    /// The dotted key (`field.width`, `dynamics.motion`).
    pub key: String,
    /// The value before, as TOML text (`unset` for an absent optional key).
    pub from: String,
    /// The value after, as TOML text.
    pub to: String,
}

impl ConfigChange {
    /// Whether a resumed run may take this change ([`RESUMABLE_KEYS`]).
    #[must_use]
    pub fn resumable(&self) -> bool {
        RESUMABLE_KEYS.contains(&self.key.as_str())
    }
}

impl std::fmt::Display for ConfigChange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {} → {}", self.key, self.from, self.to)
    }
}

/// Every key whose value differs from `from` to `to`, in the order of the TOML tables.
#[must_use]
pub fn changes(from: &TrainConfig, to: &TrainConfig) -> Vec<ConfigChange> {
    let (mut a, mut b) = (Vec::new(), Vec::new());
    if let (Ok(va), Ok(vb)) = (toml::Value::try_from(from), toml::Value::try_from(to)) {
        flatten("", &va, &mut a);
        flatten("", &vb, &mut b);
    }
    let value_of = |list: &[(String, String)], key: &str| {
        list.iter()
            .find(|(k, _)| k == key)
            .map_or_else(|| "unset".to_string(), |(_, v)| v.clone())
    };
    let mut keys: Vec<&String> = a.iter().map(|(k, _)| k).collect();
    for (k, _) in &b {
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    keys.into_iter()
        .filter_map(|key| {
            let (x, y) = (value_of(&a, key), value_of(&b, key));
            (x != y).then(|| ConfigChange {
                key: key.clone(),
                from: x,
                to: y,
            })
        })
        .collect()
}

/// The leaves of a TOML value as (dotted key, TOML text); arrays are leaves.
fn flatten(prefix: &str, v: &toml::Value, out: &mut Vec<(String, String)>) {
    match v {
        toml::Value::Table(t) => {
            for (k, x) in t {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&key, x, out);
            }
        }
        leaf => out.push((prefix.to_string(), leaf.to_string())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Motion;

    #[test]
    fn equal_configurations_have_no_changes() {
        assert!(changes(&TrainConfig::fast(), &TrainConfig::fast()).is_empty());
    }

    #[test]
    fn each_changed_key_is_named_with_both_values() {
        let a = TrainConfig::fast();
        let mut b = a.clone();
        b.field.width = a.field.width * 2;
        b.dynamics.motion = Motion::Deformation;
        b.schedule.iterations = a.schedule.iterations + 100;
        b.data.times_file = Some("times.txt".into());
        let c = changes(&a, &b);
        let keys: Vec<&str> = c.iter().map(|c| c.key.as_str()).collect();
        assert_eq!(
            keys.len(),
            4,
            "{c:?}: the width, the motion, the iterations and the times file"
        );
        let width = c.iter().find(|c| c.key == "field.width").expect("width");
        assert_eq!(
            (width.from.clone(), width.to.clone()),
            (a.field.width.to_string(), b.field.width.to_string())
        );
        assert!(!width.resumable());
        let motion = c
            .iter()
            .find(|c| c.key == "dynamics.motion")
            .expect("motion");
        assert_eq!(motion.to, "\"deformation\"");
        assert!(!motion.resumable());
        let iters = c
            .iter()
            .find(|c| c.key == "schedule.iterations")
            .expect("iterations");
        assert!(iters.resumable());
        let times = c
            .iter()
            .find(|c| c.key == "data.times_file")
            .expect("times file");
        assert_eq!(times.from, "unset");
        assert!(!times.resumable());
    }

    #[test]
    fn a_float_that_differs_in_its_last_bit_is_a_change() {
        let a = TrainConfig::fast();
        let mut b = a.clone();
        b.optim.position_lr_init = f64::from_bits(a.optim.position_lr_init.to_bits() + 1);
        assert_eq!(changes(&a, &b).len(), 1);
    }
}
