//! `Archive::from_bytes` (the checkpoint format) on arbitrary bytes.
//!
//! Properties: never panics and never allocates more than the input holds (every declared
//! length is checked against the bytes); an archive it accepts has arrays whose bytes add up
//! to the input after the header, so it cannot invent data.
#![no_main]

use evogs::run::archive::Archive;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(a) = Archive::from_bytes(data) else {
        return;
    };
    // Reading the accepted archive's accessors must not panic either.
    let _ = a.first_non_finite();
    let _ = a.f32("x");
    let _ = a.u64("x");
});
