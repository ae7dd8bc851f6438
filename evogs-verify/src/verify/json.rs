//! Reading reference-vector JSON with the JSON path of every value, so that a missing field
//! or a wrong shape is reported as `file: case.inputs.means[3]: expected 3 numbers`.

use serde_json::Value;

/// A dimension of any length in a shape passed to [`Node::nums`].
pub(crate) const ANY: usize = usize::MAX;

/// A value that is missing or has the wrong type or shape.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Malformed {
    /// JSON path of the offending value (e.g. `case.runs[1].results[4].x_final`).
    pub path: String,
    /// What was expected there.
    pub expected: String,
}

pub(crate) type Res<T> = Result<T, Malformed>;

/// A JSON value with its path.
#[derive(Clone, Debug)]
pub(crate) struct Node<'a> {
    v: &'a Value,
    path: String,
}

fn describe(shape: &[usize]) -> String {
    let dims: Vec<String> = shape
        .iter()
        .map(|&d| {
            if d == ANY {
                "N".to_string()
            } else {
                d.to_string()
            }
        })
        .collect();
    if dims.is_empty() {
        "a number".to_string()
    } else {
        format!("an array of shape [{}]", dims.join(", "))
    }
}

impl<'a> Node<'a> {
    /// The document root.
    pub(crate) fn root(v: &'a Value) -> Self {
        Self {
            v,
            path: String::new(),
        }
    }

    /// The JSON path (`(top level)` for the root).
    pub(crate) fn path(&self) -> &str {
        if self.path.is_empty() {
            "(top level)"
        } else {
            &self.path
        }
    }

    fn err<T>(&self, expected: impl Into<String>) -> Res<T> {
        Err(Malformed {
            path: self.path().to_string(),
            expected: expected.into(),
        })
    }

    fn child_path(&self, key: &str) -> String {
        if self.path.is_empty() {
            key.to_string()
        } else {
            format!("{}.{key}", self.path)
        }
    }

    /// The raw value.
    pub(crate) fn value(&self) -> &'a Value {
        self.v
    }

    /// The member `key` (an error naming the path if missing).
    pub(crate) fn get(&self, key: &str) -> Res<Self> {
        match self.v.get(key) {
            Some(v) => Ok(Self {
                v,
                path: self.child_path(key),
            }),
            None if self.v.is_object() => Err(Malformed {
                path: self.child_path(key),
                expected: "a member (missing)".to_string(),
            }),
            None => self.err(format!("an object with member `{key}`")),
        }
    }

    /// The member `key`, if present.
    pub(crate) fn opt(&self, key: &str) -> Option<Self> {
        self.get(key).ok()
    }

    /// The member names of an object (empty for other values).
    pub(crate) fn keys(&self) -> Vec<&'a str> {
        self.v
            .as_object()
            .map(|o| o.keys().map(String::as_str).collect())
            .unwrap_or_default()
    }

    /// The elements of an array.
    pub(crate) fn items(&self) -> Res<Vec<Self>> {
        match self.v.as_array() {
            Some(a) => Ok(a
                .iter()
                .enumerate()
                .map(|(i, v)| Self {
                    v,
                    path: format!("{}[{i}]", self.path),
                })
                .collect()),
            None => self.err("an array"),
        }
    }

    /// A number.
    pub(crate) fn f64(&self) -> Res<f64> {
        self.v.as_f64().map_or_else(|| self.err("a number"), Ok)
    }

    /// A non-negative integer.
    pub(crate) fn usize(&self) -> Res<usize> {
        self.v
            .as_u64()
            .and_then(|u| usize::try_from(u).ok())
            .map_or_else(|| self.err("a non-negative integer"), Ok)
    }

    /// A boolean.
    pub(crate) fn bool(&self) -> Res<bool> {
        self.v.as_bool().map_or_else(|| self.err("a boolean"), Ok)
    }

    /// A string.
    pub(crate) fn str(&self) -> Res<&'a str> {
        self.v.as_str().map_or_else(|| self.err("a string"), Ok)
    }

    /// Walks a nested array of the given shape, calling `leaf` on every element (row-major).
    fn walk(
        &self,
        shape: &[usize],
        full: &[usize],
        leaf: &mut dyn FnMut(&Self) -> Res<()>,
    ) -> Res<()> {
        let Some((&d, rest)) = shape.split_first() else {
            return leaf(self);
        };
        let items = match self.items() {
            Ok(a) if d == ANY || a.len() == d => a,
            _ => return self.err(describe(full)),
        };
        for it in &items {
            it.walk(rest, full, leaf)?;
        }
        Ok(())
    }

    /// All numbers of a nested array of shape `shape` (`ANY` for any length), row-major.
    pub(crate) fn nums(&self, shape: &[usize]) -> Res<Vec<f64>> {
        let mut out = Vec::new();
        self.walk(shape, shape, &mut |n| {
            out.push(n.f64()?);
            Ok(())
        })?;
        Ok(out)
    }

    /// All integers of a nested array of shape `shape`, row-major.
    pub(crate) fn ints(&self, shape: &[usize]) -> Res<Vec<i64>> {
        let mut out = Vec::new();
        self.walk(shape, shape, &mut |n| match n.v.as_i64() {
            Some(i) => {
                out.push(i);
                Ok(())
            }
            None => n.err("an integer"),
        })?;
        Ok(out)
    }

    /// All booleans of a nested array of shape `shape`, row-major.
    pub(crate) fn bools(&self, shape: &[usize]) -> Res<Vec<bool>> {
        let mut out = Vec::new();
        self.walk(shape, shape, &mut |n| {
            out.push(n.bool()?);
            Ok(())
        })?;
        Ok(out)
    }

    /// A 3-vector.
    pub(crate) fn vec3(&self) -> Res<[f64; 3]> {
        let v = self.nums(&[3])?;
        Ok([v[0], v[1], v[2]])
    }

    /// A 4-vector.
    pub(crate) fn vec4(&self) -> Res<[f64; 4]> {
        let v = self.nums(&[4])?;
        Ok([v[0], v[1], v[2], v[3]])
    }

    /// A 3×3 matrix (row-major).
    pub(crate) fn mat3(&self) -> Res<[[f64; 3]; 3]> {
        let v = self.nums(&[3, 3])?;
        Ok(core::array::from_fn(|i| {
            core::array::from_fn(|j| v[3 * i + j])
        }))
    }

    /// A 4×4 matrix (row-major).
    pub(crate) fn mat4(&self) -> Res<[[f64; 4]; 4]> {
        let v = self.nums(&[4, 4])?;
        Ok(core::array::from_fn(|i| {
            core::array::from_fn(|j| v[4 * i + j])
        }))
    }
}

/// Booleans as 0/1 integers (for exact rows).
pub(crate) fn bools_as_ints(b: &[bool]) -> Vec<i64> {
    b.iter().map(|&x| i64::from(x)).collect()
}
