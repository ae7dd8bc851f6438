//! `PlyTable::parse` on arbitrary bytes (headers, ASCII and binary bodies).
//!
//! Properties: never panics, never aborts on a huge declared size (the sizes are checked
//! against the body before anything is allocated); a table it accepts is consistent: one
//! column per name, each `len` long, every value finite and the positions `x`, `y`, `z`
//! within ±`MAX_POSITION`.
#![no_main]

use evogs::data::ply::{MAX_POSITION, PlyTable};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(t) = PlyTable::parse(data) else {
        return;
    };
    assert_eq!(t.names.len(), t.columns.len(), "one column per name");
    for (name, col) in t.names.iter().zip(&t.columns) {
        assert_eq!(col.len(), t.len, "column `{name}` has the table's length");
        assert!(
            col.iter().all(|v| v.is_finite()),
            "column `{name}` is finite"
        );
        if matches!(name.as_str(), "x" | "y" | "z") {
            assert!(
                col.iter().all(|v| v.abs() <= MAX_POSITION),
                "position `{name}` in range"
            );
        }
    }
});
