//! The study's protocols (`full`, `sparse:K`, `future:TAU`, `backward:TAU`) and the held-out
//! sets each one is judged on.
//!
//! | protocol | trains on | held-out sets |
//! |---|---|---|
//! | `full` | every training view | the test split |
//! | `sparse:K` | the training views at every K-th distinct time | the test split; the training-camera views at the dropped times |
//! | `future:TAU` | training views with `t ≤ TAU` | test `t ≤ TAU` (interpolation); test `t > TAU` (extrapolation), also in two bins split at `TAU + 0.4·(1 − TAU)`; the `future` split if the dataset has one |
//! | `backward:TAU` | training views with `t ≥ TAU` | test `t ≥ TAU` (interpolation); test `t < TAU` (extrapolation); the `future` split if any |

use crate::app::error::{CommandError, CommandResult};
use evogs::config::{DataConfig, Protocol};
use evogs::data::{Dataset, SplitName, View};
use evogs::train::views::supervised_indices;
use serde::{Deserialize, Serialize};
use std::fmt;

/// Slack on time comparisons (times are read from JSON with a few decimals).
const TIME_EPS: f64 = 1e-9;

/// A training protocol with its parameter, as written on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(into = "String", try_from = "String")]
pub enum StudyProtocol {
    /// Every training view.
    Full,
    /// Every K-th distinct training time (K ≥ 2).
    Sparse(usize),
    /// Training views with `t ≤ TAU`, `0 < TAU < 1`.
    Future(f64),
    /// Training views with `t ≥ TAU`, `0 < TAU < 1`.
    Backward(f64),
}

impl StudyProtocol {
    /// The default protocols of `evogs study`.
    #[must_use]
    pub fn defaults() -> Vec<Self> {
        vec![Self::Full, Self::Sparse(4), Self::Future(0.75)]
    }

    /// Parses a comma-separated list (`full,sparse:4,future:0.75`); duplicates are an error.
    ///
    /// # Errors
    /// An unknown protocol, a bad parameter, an empty list or a repeated protocol.
    pub fn parse_list(s: &str) -> Result<Vec<Self>, String> {
        let mut out: Vec<Self> = Vec::new();
        for part in s.split(',') {
            let p: Self = part.trim().parse()?;
            if out.contains(&p) {
                return Err(format!("protocol `{p}` is listed twice"));
            }
            out.push(p);
        }
        Ok(out)
    }

    /// Overrides the protocol fields of a data configuration.
    pub fn apply(self, data: &mut DataConfig) {
        match self {
            Self::Full => data.protocol = Protocol::Full,
            Self::Sparse(k) => {
                data.protocol = Protocol::Sparse;
                data.stride = k;
            }
            Self::Future(tau) => {
                data.protocol = Protocol::Future;
                data.split_time = tau;
            }
            Self::Backward(tau) => {
                data.protocol = Protocol::Backward;
                data.split_time = tau;
            }
        }
    }

    /// A file-name-safe label (`full`, `sparse4`, `future0.75`, `backward0.25`).
    #[must_use]
    pub fn slug(self) -> String {
        self.to_string().replace(':', "")
    }

    /// The held-out sets of this protocol on `ds` (the views of each, by split and index).
    ///
    /// # Errors
    /// A protocol that leaves nothing to train on or nothing held out that it is meant to
    /// measure: no test views, no training view inside the protocol's range, or no test view
    /// beyond `TAU`.
    pub fn held_out_sets(self, ds: &Dataset) -> CommandResult<Vec<HeldOutSet>> {
        let root = |cause: String| CommandError::at(&ds.root, cause);
        if ds.test.is_empty() {
            return Err(root(
                "the dataset has no test views, so there is nothing to evaluate".to_string(),
            ));
        }
        let mut cfg = DataConfig {
            protocol: Protocol::Full,
            stride: 2,
            split_time: 0.5,
            ..evogs::config::TrainConfig::fast().data
        };
        self.apply(&mut cfg);
        let supervised = supervised_indices(&ds.train, &cfg);
        if supervised.is_empty() {
            return Err(root(format!(
                "protocol `{self}` leaves no training view to train on"
            )));
        }
        let test = |keep: &dyn Fn(f64) -> bool| -> Vec<usize> {
            (0..ds.test.len())
                .filter(|&i| keep(ds.test[i].time))
                .collect()
        };
        let mut sets = Vec::new();
        match self {
            Self::Full => sets.push(HeldOutSet::new("test", SplitName::Test, test(&|_| true))),
            Self::Sparse(k) => {
                sets.push(HeldOutSet::new("test", SplitName::Test, test(&|_| true)));
                let dropped: Vec<usize> = (0..ds.train.len())
                    .filter(|i| supervised.binary_search(i).is_err())
                    .collect();
                if dropped.is_empty() {
                    return Err(root(format!(
                        "protocol `{self}` drops no training time (the training views \
                         have fewer than 2 distinct times per stride of {k})"
                    )));
                }
                sets.push(HeldOutSet::new(
                    "train views at dropped times",
                    SplitName::Train,
                    dropped,
                ));
            }
            Self::Future(tau) => {
                let beyond = test(&|t| t > tau + TIME_EPS);
                if beyond.is_empty() && ds.future.is_empty() {
                    return Err(root(format!(
                        "protocol `{self}` needs test views with t > {tau} (or a \
                         future split); the test times lie in {}",
                        time_span(&ds.test)
                    )));
                }
                sets.push(HeldOutSet::new(
                    &format!("test t <= {tau}"),
                    SplitName::Test,
                    test(&|t| t <= tau + TIME_EPS),
                ));
                sets.push(HeldOutSet::new(
                    &format!("test t > {tau}"),
                    SplitName::Test,
                    beyond,
                ));
                // The extrapolated stretch in two bins, the first 40 % of it (0.75 → 0.85)
                // and the rest: how the error grows with the distance from the window.
                let mid = round_time(tau + 0.4 * (1.0 - tau));
                sets.push(HeldOutSet::new(
                    &format!("test t in ({tau}, {mid}]"),
                    SplitName::Test,
                    test(&|t| t > tau + TIME_EPS && t <= mid + TIME_EPS),
                ));
                sets.push(HeldOutSet::new(
                    &format!("test t in ({mid}, 1]"),
                    SplitName::Test,
                    test(&|t| t > mid + TIME_EPS),
                ));
            }
            Self::Backward(tau) => {
                let before = test(&|t| t < tau - TIME_EPS);
                if before.is_empty() {
                    return Err(root(format!(
                        "protocol `{self}` needs test views with t < {tau}; the test \
                         times lie in {}",
                        time_span(&ds.test)
                    )));
                }
                sets.push(HeldOutSet::new(
                    &format!("test t >= {tau}"),
                    SplitName::Test,
                    test(&|t| t >= tau - TIME_EPS),
                ));
                sets.push(HeldOutSet::new(
                    &format!("test t < {tau}"),
                    SplitName::Test,
                    before,
                ));
            }
        }
        if matches!(self, Self::Future(_) | Self::Backward(_)) && !ds.future.is_empty() {
            sets.push(HeldOutSet::new(
                "future split",
                SplitName::Future,
                (0..ds.future.len()).collect(),
            ));
        }
        sets.retain(|s| !s.indices.is_empty());
        Ok(sets)
    }
}

/// `t` rounded to six decimals (a bin edge that prints as it was meant: 0.85, not
/// 0.8500000000000001).
fn round_time(t: f64) -> f64 {
    (t * 1e6).round() / 1e6
}

fn time_span(views: &[View]) -> String {
    let (a, b) = views
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v.time), b.max(v.time))
        });
    format!("[{a}, {b}]")
}

impl fmt::Display for StudyProtocol {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Full => f.write_str("full"),
            Self::Sparse(k) => write!(f, "sparse:{k}"),
            Self::Future(t) => write!(f, "future:{t}"),
            Self::Backward(t) => write!(f, "backward:{t}"),
        }
    }
}

impl std::str::FromStr for StudyProtocol {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (name, arg) = match s.split_once(':') {
            Some((n, a)) => (n, Some(a)),
            None => (s, None),
        };
        let tau = |a: Option<&str>| -> Result<f64, String> {
            let a =
                a.ok_or_else(|| format!("protocol `{name}` needs a split time: `{name}:TAU`"))?;
            let t: f64 = a
                .parse()
                .map_err(|_| format!("`{s}`: `{a}` is not a number"))?;
            if t > 0.0 && t < 1.0 {
                Ok(t)
            } else {
                Err(format!("`{s}`: the split time must lie in (0, 1)"))
            }
        };
        match name {
            "full" if arg.is_none() => Ok(Self::Full),
            "full" => Err(format!("`{s}`: protocol `full` takes no parameter")),
            "sparse" => {
                let a = arg.ok_or("protocol `sparse` needs a stride: `sparse:K`")?;
                let k: usize = a
                    .parse()
                    .map_err(|_| format!("`{s}`: `{a}` is not a whole number"))?;
                if k < 2 {
                    return Err(format!("`{s}`: the stride K must be at least 2"));
                }
                Ok(Self::Sparse(k))
            }
            "future" => Ok(Self::Future(tau(arg)?)),
            "backward" => Ok(Self::Backward(tau(arg)?)),
            _ => Err(format!(
                "unknown protocol `{s}` (full, sparse:K, future:TAU, backward:TAU)"
            )),
        }
    }
}

impl From<StudyProtocol> for String {
    fn from(p: StudyProtocol) -> Self {
        p.to_string()
    }
}

impl TryFrom<String> for StudyProtocol {
    type Error = String;
    fn try_from(s: String) -> Result<Self, String> {
        s.parse()
    }
}

/// Views held out from training and evaluated together.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HeldOutSet {
    /// What the set is (`test`, `test t > 0.75`, ...): a row of the study's table.
    pub name: String,
    /// The split the views come from.
    pub split: SplitName,
    /// Indices into that split.
    pub indices: Vec<usize>,
}

impl HeldOutSet {
    fn new(name: &str, split: SplitName, indices: Vec<usize>) -> Self {
        Self {
            name: name.to_string(),
            split,
            indices,
        }
    }

    /// The views of the set.
    #[must_use]
    pub fn views<'a>(&self, ds: &'a Dataset) -> Vec<&'a View> {
        let all = ds.split(self.split);
        self.indices.iter().map(|&i| &all[i]).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn view(time: f64) -> View {
        View {
            file: PathBuf::from(format!("r_{time}.png")),
            time,
            c2w: [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 4.0],
                [0.0, 0.0, 0.0, 1.0],
            ],
            fov_x: 0.7,
            width: 4,
            height: 4,
            image: None,
            decode: evogs::data::image_io::FrameDecode::default(),
        }
    }

    /// Eight training times 0, 1/7, …, 1 and test views at 0.1, 0.5, 0.8, 0.95.
    fn dataset(future: &[f64]) -> Dataset {
        Dataset {
            root: PathBuf::from("tiny"),
            format: evogs::data::DataFormat::Dnerf,
            rig: Vec::new(),
            train: (0..8).map(|i| view(f64::from(i) / 7.0)).collect(),
            val: Vec::new(),
            test: [0.1, 0.5, 0.8, 0.95].iter().map(|&t| view(t)).collect(),
            future: future.iter().map(|&t| view(t)).collect(),
            points: None,
        }
    }

    #[test]
    fn protocols_parse_and_print_back() {
        for s in [
            "full",
            "sparse:4",
            "sparse:2",
            "future:0.75",
            "backward:0.25",
        ] {
            let p: StudyProtocol = s.parse().expect(s);
            assert_eq!(p.to_string(), s, "round trip");
        }
        assert_eq!(
            StudyProtocol::parse_list("full,sparse:4,future:0.75").expect("defaults"),
            StudyProtocol::defaults(),
            "the documented default list"
        );
        assert_eq!(StudyProtocol::Sparse(4).slug(), "sparse4", "slug");
        assert_eq!(StudyProtocol::Future(0.75).slug(), "future0.75", "slug");
    }

    #[test]
    fn bad_protocols_are_rejected_with_a_reason() {
        for (s, why) in [
            ("fuller", "unknown protocol"),
            ("sparse:1", "at least 2"),
            ("sparse:0", "at least 2"),
            ("sparse", "needs a stride"),
            ("sparse:x", "not a whole number"),
            ("future:1", "(0, 1)"),
            ("future:0", "(0, 1)"),
            ("future:1.5", "(0, 1)"),
            ("backward:-0.2", "(0, 1)"),
            ("future:nan", "(0, 1)"),
            ("future", "needs a split time"),
            ("full:3", "no parameter"),
        ] {
            let e = s.parse::<StudyProtocol>().expect_err(s);
            assert!(e.contains(why), "`{s}`: {e}");
        }
        let e = StudyProtocol::parse_list("full,sparse:4,full").expect_err("repeat");
        assert!(e.contains("twice"), "{e}");
    }

    #[test]
    fn full_holds_out_the_test_split() {
        let sets = StudyProtocol::Full
            .held_out_sets(&dataset(&[]))
            .expect("sets");
        assert_eq!(sets.len(), 1, "{sets:?}");
        assert_eq!(sets[0].split, SplitName::Test, "split");
        assert_eq!(sets[0].indices, vec![0, 1, 2, 3], "every test view");
    }

    #[test]
    fn sparse_holds_out_the_test_split_and_the_dropped_training_times() {
        let sets = StudyProtocol::Sparse(3)
            .held_out_sets(&dataset(&[]))
            .expect("sets");
        assert_eq!(sets.len(), 2, "{sets:?}");
        assert_eq!(sets[0].indices, vec![0, 1, 2, 3], "test");
        // Kept: ranks 0, 3, 6; dropped: the rest of the training views.
        assert_eq!(sets[1].split, SplitName::Train, "dropped training views");
        assert_eq!(sets[1].indices, vec![1, 2, 4, 5, 7], "dropped");
    }

    #[test]
    fn future_splits_the_test_views_at_tau_and_adds_the_future_split() {
        let sets = StudyProtocol::Future(0.75)
            .held_out_sets(&dataset(&[1.1, 1.2]))
            .expect("sets");
        let names: Vec<&str> = sets.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "test t <= 0.75",
                "test t > 0.75",
                "test t in (0.75, 0.85]",
                "test t in (0.85, 1]",
                "future split"
            ],
            "rows"
        );
        assert_eq!(sets[0].indices, vec![0, 1], "interpolation");
        assert_eq!(sets[1].indices, vec![2, 3], "extrapolation");
        assert_eq!(sets[2].indices, vec![2], "first bin");
        assert_eq!(sets[3].indices, vec![3], "second bin");
        assert_eq!(sets[4].indices, vec![0, 1], "future split");
        let sets = StudyProtocol::Future(0.75)
            .held_out_sets(&dataset(&[]))
            .expect("no future split");
        assert_eq!(sets.len(), 4, "no future split row without one");
    }

    #[test]
    fn backward_is_the_mirror_image() {
        let sets = StudyProtocol::Backward(0.3)
            .held_out_sets(&dataset(&[]))
            .expect("sets");
        assert_eq!(sets[0].name, "test t >= 0.3", "interpolation");
        assert_eq!(sets[0].indices, vec![1, 2, 3], "interpolation");
        assert_eq!(sets[1].name, "test t < 0.3", "extrapolation");
        assert_eq!(sets[1].indices, vec![0], "extrapolation");
    }

    #[test]
    fn a_protocol_without_frames_to_measure_is_an_error() {
        let e = StudyProtocol::Future(0.97)
            .held_out_sets(&dataset(&[]))
            .expect_err("no test beyond 0.97")
            .to_string();
        assert!(e.contains("t > 0.97"), "{e}");
        let e = StudyProtocol::Backward(0.05)
            .held_out_sets(&dataset(&[]))
            .expect_err("no test before 0.05")
            .to_string();
        assert!(e.contains("t < 0.05"), "{e}");
        let mut ds = dataset(&[]);
        ds.test.clear();
        let e = StudyProtocol::Full
            .held_out_sets(&ds)
            .expect_err("no test")
            .to_string();
        assert!(e.contains("no test views"), "{e}");
        let e = StudyProtocol::Sparse(20)
            .held_out_sets(&dataset(&[]))
            .map(|s| s.len());
        assert_eq!(
            e,
            Ok(2),
            "a stride beyond the times keeps the first time only"
        );
    }
}
