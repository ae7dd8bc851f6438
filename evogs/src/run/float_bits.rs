//! The bit patterns of a JSON value's floating-point numbers, kept beside the JSON text of
//! checkpoint metadata so that reading it back is exact.
//!
//! JSON text parsed by `serde_json`'s default (fast, not correctly rounded) parser can come
//! back an ulp off, which would make a resumed run drift from an uninterrupted one. The
//! writer stores [`float_bits`] of the metadata, the reader puts them back with
//! [`restore_float_bits`].

use serde_json::Value;

/// The bit pattern of every floating-point number of `v` (not integers), in the order of a
/// depth-first walk (maps in key order, arrays in element order).
#[must_use]
pub(super) fn float_bits(v: &Value) -> Vec<u64> {
    let mut bits = Vec::new();
    visit_floats(&mut v.clone(), &mut |x| bits.push(x.to_bits()));
    bits
}

/// Puts the bit patterns of [`float_bits`] back into `v`, in the same order.
///
/// # Errors
/// `bits` does not hold exactly one pattern per floating-point number of `v`.
pub(super) fn restore_float_bits(v: &mut Value, bits: &[u64]) -> Result<(), String> {
    let mut next = bits.iter();
    let mut missing = false;
    visit_floats(v, &mut |x| match next.next() {
        Some(&b) => *x = f64::from_bits(b),
        None => missing = true,
    });
    if missing || next.next().is_some() {
        return Err("metadata float bits do not match the metadata".into());
    }
    Ok(())
}

/// Calls `f` on every floating-point number of `v` (not integers), depth first, in the
/// order of the map's keys and the arrays' elements, and stores what `f` leaves.
fn visit_floats(v: &mut Value, f: &mut impl FnMut(&mut f64)) {
    match v {
        Value::Number(n) if n.is_f64() => {
            if let Some(mut x) = n.as_f64() {
                f(&mut x);
                if let Some(m) = serde_json::Number::from_f64(x) {
                    *n = m;
                }
            }
        }
        Value::Array(a) => a.iter_mut().for_each(|x| visit_floats(x, f)),
        Value::Object(o) => o.values_mut().for_each(|x| visit_floats(x, f)),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn bits_go_back_where_they_came_from() {
        let v = json!({"b": [0.1, 2, {"c": -0.0}], "a": 1e-300});
        let bits = float_bits(&v);
        assert_eq!(bits.len(), 3, "three floats, the integer is not one");
        let mut w = v.clone();
        restore_float_bits(&mut w, &bits).expect("restored");
        assert_eq!(w, v, "unchanged");
        assert!(
            restore_float_bits(&mut w, &bits[..2]).is_err(),
            "too few patterns"
        );
        assert!(
            restore_float_bits(&mut w, &[0, 0, 0, 0]).is_err(),
            "too many patterns"
        );
    }
}
