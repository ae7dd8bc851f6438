//! Links evogs-math, evogs-ode and evogs-splat into a `#![no_std]` static library.
//!
//! The exported function exercises a little of each crate so the code is really compiled
//! and linked, not just type-checked.
#![no_std]

use core::alloc::{GlobalAlloc, Layout};
use evogs_math::{Quat, Vec3, so3::exp_quat, update::exp_update_left};

/// Never called: the check only needs the allocator symbol to exist.
struct NoAlloc;

// SAFETY: returning null is always a valid (failing) allocation; dealloc is never reached.
unsafe impl GlobalAlloc for NoAlloc {
    unsafe fn alloc(&self, _layout: Layout) -> *mut u8 {
        core::ptr::null_mut()
    }
    unsafe fn dealloc(&self, _ptr: *mut u8, _layout: Layout) {}
}

#[global_allocator]
static ALLOCATOR: NoAlloc = NoAlloc;

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    loop {}
}

/// Rotates a quaternion by a world-frame rate: pulls real code from the core crates.
#[unsafe(no_mangle)]
pub extern "C" fn evogs_nostd_check(w: f64, x: f64, y: f64, z: f64, dt: f64) -> f64 {
    let q = exp_update_left(Quat::new(w, x, y, z), Vec3::new(x, y, z), dt);
    exp_quat(Vec3::new(q.x, q.y, q.z)).w
}
