//! Prints the work–precision tables of docs/adaptive.md: end-time error against field
//! evaluations for the adaptive pairs (Dormand–Prince 5(4), Bogacki–Shampine 3(2)) and for
//! fixed-step methods (RK4, Heun, Dormand–Prince's tableau with fixed steps), on Kepler
//! (e = 0.6, one period) and Van der Pol (μ = 1).
//!
//! `cargo run --release -p evogs-ode --example work_precision`

#[path = "../benches/common/work_precision.rs"]
mod work_precision;

use work_precision::{Problem, cost_at, methods, study};

fn main() {
    for problem in Problem::ALL {
        let pts = study(problem);
        println!("## {}\n", problem.name());
        println!("Field evaluations to reach an end-time error (max norm), interpolated:\n");
        let targets = [1e-3, 1e-4, 1e-6, 1e-8, 1e-10];
        print!("| method |");
        for t in targets {
            print!(" err {t:.0e} |");
        }
        println!("\n|---|{}", "---:|".repeat(targets.len()));
        for m in methods(&pts) {
            let mine: Vec<&_> = pts.iter().filter(|p| p.method == m).collect();
            print!("| {m} |");
            for t in targets {
                match cost_at(&mine, t) {
                    Some(c) => print!(" {:.0} |", c),
                    None => print!(" – |"),
                }
            }
            println!();
        }
        println!("\nRaw points (tolerance or steps, evaluations, error):\n");
        println!("| method | tol / N | nfev | error |\n|---|---:|---:|---:|");
        for p in &pts {
            let setting = if p.method.contains("fixed") {
                format!("{}", p.setting)
            } else {
                format!("{:.0e}", p.setting)
            };
            println!(
                "| {} | {setting} | {} | {:.2e} |",
                p.method, p.nfev, p.error
            );
        }
        println!();
    }
}
