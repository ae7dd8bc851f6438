//! The SE(3) rigid-body example (`examples/quadrotor_se3.rs`) as a test: the discrete
//! adjoint of the adaptive solve on SE(3) × ℝ⁶ matches central differences of the solve with
//! its steps held fixed to finite-difference accuracy, and those of fresh adaptive solves to
//! about the tolerance.

#[allow(dead_code, reason = "the example's `main` is not called here")]
#[path = "../../examples/quadrotor_se3.rs"]
mod quadrotor_se3;

#[test]
fn adjoint_of_the_adaptive_rigid_body_matches_finite_differences() {
    for tol in [1e-6, 1e-8] {
        let r = quadrotor_se3::run(tol);
        assert!(r.stats.accepted > 5, "{tol}: {:?}", r.stats);
        let fixed = r.rel_diff(&r.fd_fixed);
        assert!(
            fixed < 1e-7,
            "tol {tol}: adjoint vs FD (steps fixed) {fixed:e}: {r:?}"
        );
        let resolved = r.rel_diff(&r.fd_resolved);
        assert!(
            resolved < 1e3 * tol,
            "tol {tol}: adjoint vs FD (re-solved) {resolved:e}: {r:?}"
        );
    }
}
