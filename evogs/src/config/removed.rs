//! Configuration keys that were removed from evogs, and how a TOML document that still sets
//! them is read.
//!
//! The rigidity, rotation-similarity and isometry priors, the local coherence sampling, the
//! snapshot waypoints and the twist velocity lost every measurement (`docs/results.md` keeps
//! their record) and were removed. Every stored run configuration of the builds that had them sets their keys
//! (at their off values unless a run used them), so a key at its off value is dropped
//! silently (the run trained without the technique, and trains on without it); a key at any
//! other value is refused with a message that names it and says it was removed, since the
//! run it describes cannot be reproduced.

/// One removed key: its table, its name, and which of its values meant "off".
struct RemovedKey {
    /// Table (`loss`, `schedule`).
    table: &'static str,
    /// Key within the table.
    key: &'static str,
    /// What the key switched.
    what: &'static str,
    /// Whether `value` left the technique off.
    off: fn(&toml::Value) -> bool,
}

/// A weight: off at zero.
fn zero(v: &toml::Value) -> bool {
    v.as_float() == Some(0.0) || v.as_integer() == Some(0)
}

/// A switch: off when false.
fn not_set(v: &toml::Value) -> bool {
    v.as_bool() == Some(false)
}

/// A size or cadence that did nothing while its technique was off: any number.
fn any_number(v: &toml::Value) -> bool {
    v.is_integer() || v.is_float()
}

/// The removed keys.
const REMOVED_KEYS: [RemovedKey; 8] = [
    RemovedKey {
        table: "loss",
        key: "lambda_rigidity",
        what: "the rigidity prior",
        off: zero,
    },
    RemovedKey {
        table: "loss",
        key: "lambda_rotation",
        what: "the rotation-similarity prior",
        off: zero,
    },
    RemovedKey {
        table: "loss",
        key: "lambda_isometry",
        what: "the isometry prior",
        off: zero,
    },
    RemovedKey {
        table: "loss",
        key: "rigidity_samples",
        what: "the rigidity priors' sample size",
        off: any_number,
    },
    RemovedKey {
        table: "loss",
        key: "coherence_local",
        what: "the local coherence sampling",
        off: not_set,
    },
    RemovedKey {
        table: "schedule",
        key: "snapshot_every",
        what: "the snapshot waypoints' refresh interval",
        off: any_number,
    },
    RemovedKey {
        table: "field",
        key: "twist",
        what: "the twist velocity",
        off: not_set,
    },
    RemovedKey {
        table: "dynamics",
        key: "waypoints",
        what: "the snapshot waypoints",
        off: |v| v.as_str() != Some("snapshot"),
    },
];

/// Drops the removed keys that `doc` sets to their off values (keeping `dynamics.waypoints`,
/// which still exists, when it is not `"snapshot"`).
///
/// # Errors
/// A removed key set to a value that switched its technique on, named with its table.
pub(super) fn drop_removed_keys(doc: &mut toml::Value) -> Result<(), String> {
    for r in &REMOVED_KEYS {
        let Some(table) = doc.get_mut(r.table).and_then(toml::Value::as_table_mut) else {
            continue;
        };
        let Some(value) = table.get(r.key) else {
            continue;
        };
        if !(r.off)(value) {
            return Err(format!(
                "{}.{} = {value}: {} was removed from evogs (it lost every measurement, see \
                 docs/results.md); only its off value is still read: delete the key",
                r.table, r.key, r.what
            ));
        }
        if r.key != "waypoints" {
            table.remove(r.key);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn doc(text: &str) -> toml::Value {
        toml::from_str(text).expect("TOML")
    }

    #[test]
    fn off_values_are_dropped() {
        let mut d = doc(
            "[loss]\nlambda_rigidity = 0.0\nlambda_rotation = 0\nlambda_isometry = 0.0\n\
             rigidity_samples = 512\ncoherence_local = false\nlambda_ssim = 0.2\n\
             [schedule]\nsnapshot_every = 500\niterations = 3\n\
             [dynamics]\nwaypoints = \"off\"\n",
        );
        drop_removed_keys(&mut d).expect("off values read");
        assert_eq!(
            d,
            doc("[loss]\nlambda_ssim = 0.2\n[schedule]\niterations = 3\n\
                 [dynamics]\nwaypoints = \"off\"\n"),
            "only the removed keys dropped"
        );
    }

    #[test]
    fn on_values_are_refused_by_name() {
        for (text, name) in [
            ("[loss]\nlambda_rigidity = 0.3", "loss.lambda_rigidity"),
            ("[loss]\nlambda_rotation = 0.01", "loss.lambda_rotation"),
            ("[loss]\nlambda_isometry = 1", "loss.lambda_isometry"),
            ("[loss]\ncoherence_local = true", "loss.coherence_local"),
            ("[dynamics]\nwaypoints = \"snapshot\"", "dynamics.waypoints"),
        ] {
            let e = drop_removed_keys(&mut doc(text)).expect_err(text);
            assert!(e.starts_with(name) && e.contains("removed"), "{e}");
        }
    }
}
