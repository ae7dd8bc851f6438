//! The `evogs` command line: a thin clap front end over `evogs_cli::app`. The command line's
//! definition is in `cli`, what each command prints in `output`, the progress display in
//! `terminal`; `run` only dispatches and `main` is the one exit point.
#![allow(
    rustdoc::broken_intra_doc_links,
    rustdoc::invalid_html_tags,
    reason = "the doc comments here are the command line's help text (`A:B:N`, `<split>`), not rustdoc"
)]

mod cli;
mod output;
mod terminal;

use cli::{Cli, Cmd};
use evogs_cli::app::bench::run_bench;
use evogs_cli::app::error::{CommandError, CommandResult};
use evogs_cli::app::evaluate::evaluate_run;
use evogs_cli::app::export::{export, export_sequence};
use evogs_cli::app::inject::inject;
use evogs_cli::app::render::render_sequence;
use evogs_cli::app::scenes::write_scenes;
use evogs_cli::app::study::run_study;
use evogs_cli::app::train::train;
use evogs_verify::check::grad::check_grad;
use evogs_verify::check::order::check_order;
use evogs_verify::verify::{LEGEND, verify_file};
use std::process::ExitCode;
use terminal::Terminal;

/// How a command that ran to its end went: checks (`check-order`, `check-grad`, `verify`)
/// can finish and still report a failure, which exits with code 1 without an error line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Verdict {
    Passed,
    Failed,
}

impl Verdict {
    const fn of(passed: bool) -> Self {
        if passed { Self::Passed } else { Self::Failed }
    }
}

/// The one exit point: a usage error exits with code 2 (one line, from [`cli::parse`]), a
/// failed command with code 1 after one line `Error: ...` (the error's context, then its
/// cause), a failed check with code 1, anything else with 0.
fn main() -> ExitCode {
    let cli = match cli::parse() {
        Ok(cli) => cli,
        Err(code) => return ExitCode::from(u8::try_from(code).unwrap_or(2)),
    };
    #[cfg(feature = "mpi")]
    if evogs_cli::app::cluster::launched_by_mpi() {
        return run_mpi(cli);
    }
    match run(cli) {
        Ok(Verdict::Passed) => ExitCode::SUCCESS,
        Ok(Verdict::Failed) => ExitCode::from(1),
        Err(e) => {
            eprintln!("Error: {e}");
            ExitCode::from(1)
        }
    }
}

/// One process of an MPI job: `train` and `study` share their work with the job's other
/// processes (rank 0 prints and writes; the others are quiet); any other command runs on
/// rank 0 alone. An error on any rank ends the whole job (`MPI_Abort`) after its line.
#[cfg(feature = "mpi")]
fn run_mpi(cli: Cli) -> ExitCode {
    use evogs::train::collective::Collective as _;
    use evogs_cli::app::Silent;
    use evogs_cli::app::cluster::Mpi;
    let mpi = match Mpi::init() {
        Ok(m) => m,
        Err(e) => {
            eprintln!("Error: {e}");
            return ExitCode::from(1);
        }
    };
    let rank = mpi.rank();
    let result = evogs_cli::app::interrupt::install().and_then(|()| {
        let mut term = Terminal::new();
        let mut silent = Silent;
        let rep: &mut dyn evogs_cli::app::Reporter =
            if rank == 0 { &mut term } else { &mut silent };
        match cli.cmd {
            Cmd::Train(args) => {
                let outcome = evogs_cli::app::train::train_with(&args, rep, &mpi)?;
                if rank == 0 {
                    output::train(&outcome);
                }
                Ok(Verdict::Passed)
            }
            Cmd::Study(mut args) => {
                args.command = std::env::args().collect::<Vec<_>>().join(" ");
                let outcome = evogs_cli::app::study::run_study_with(&args, rep, &mpi)?;
                if let Some(o) = outcome {
                    output::study(&o);
                }
                Ok(Verdict::Passed)
            }
            other if rank == 0 => run(Cli { cmd: other }),
            _ => Ok(Verdict::Passed),
        }
    });
    match result {
        Ok(Verdict::Passed) => ExitCode::SUCCESS,
        Ok(Verdict::Failed) => ExitCode::from(1),
        Err(e) => {
            eprintln!("Error: rank {rank} of {}: {e}", mpi.size());
            if mpi.size() > 1 {
                mpi.abort(1);
            }
            ExitCode::from(1)
        }
    }
}

/// Runs one command and prints its result.
fn run(cli: Cli) -> CommandResult<Verdict> {
    evogs_cli::app::interrupt::install()?;
    let mut term = Terminal::new();
    match cli.cmd {
        Cmd::Train(args) => output::train(&train(&args, &mut term)?),
        Cmd::Study(mut args) => {
            args.command = std::env::args().collect::<Vec<_>>().join(" ");
            output::study(&run_study(&args, &mut term)?);
        }
        Cmd::Eval(c) => {
            let (m, path) = evaluate_run(
                &c.run,
                c.split,
                c.time_range,
                c.data.as_deref(),
                c.format,
                &mut term,
            )?;
            output::eval(&m, &path);
        }
        Cmd::Render(c) => output::frames(&render_sequence(&c.into(), None, &mut term)?),
        Cmd::Inject(c) => output::frames(&inject(&c.into(), &mut term)?),
        Cmd::Bench(args) if args.machine => {
            let threads = args.threads.unwrap_or_else(|| {
                std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
            });
            evogs_cli::app::Reporter::info(
                &mut term,
                &format!("measuring this machine's limits on 1 and {threads} thread(s)"),
            );
            output::machine(&evogs_cli::app::bench::machine::measure(threads, false));
        }
        Cmd::Bench(args) => output::bench(&run_bench(&args, &mut term)?, args.json.as_deref()),
        Cmd::Export(c) => match (c.time, c.times) {
            (Some(_), _) if c.force => {
                // clap does not enforce `requires` on a flag whose partner conflicts with a
                // given one, so the rule is checked here.
                return Err(CommandError::new(
                    "--force replaces an earlier sequence and goes with --times; --time \
                     writes one file (a file already there is replaced)",
                ));
            }
            (Some(t), _) => output::export_one(export(&c.run, t, &c.out)?, t, &c.out),
            (None, Some(times)) => {
                let seq = export_sequence(&c.run, times, &c.out, c.force, &mut term)?;
                output::export_sequence(seq.files.len(), seq.gaussians, &c.out);
            }
            (None, None) => {
                return Err(CommandError::new("export needs --time T or --times A:B:N"));
            }
        },
        Cmd::Scenes(args) => output::scenes(&write_scenes(&args, &mut term)?),
        Cmd::View(args) => evogs_cli::app::view::view(&args, &mut term)?,
        Cmd::CheckOrder(c) => {
            let results =
                check_order(c.stepper, c.problem.as_deref()).map_err(CommandError::new)?;
            output::check_order(&results);
            return Ok(Verdict::of(results.iter().all(|r| r.passed)));
        }
        Cmd::CheckGrad => {
            let start = std::time::Instant::now();
            let table = check_grad(usize::MAX);
            output::check_grad(&table, start.elapsed().as_secs_f64());
            return Ok(Verdict::of(table.passed()));
        }
        Cmd::Verify(c) => return Ok(verify(&c.files)),
    }
    Ok(Verdict::Passed)
}

/// `evogs verify`: every file in turn (a file that cannot be read counts as failed and the
/// others are still checked).
fn verify(files: &[std::path::PathBuf]) -> Verdict {
    let mut bad = 0_usize;
    output::verify_legend(LEGEND);
    for f in files {
        match verify_file(f) {
            Ok(r) => {
                output::verify_report(&r);
                bad += usize::from(!r.passed());
            }
            Err(e) => {
                output::verify_error(&e);
                bad += 1;
            }
        }
    }
    output::verify_summary(files.len() - bad, files.len());
    Verdict::of(bad == 0)
}

#[cfg(test)]
mod tests {
    use super::cli::{Cli, Cmd};
    use clap::{CommandFactory, Parser};
    use evogs::model::Motion;
    use evogs_cli::app::bench::FieldSize;
    use evogs_cli::app::inject::FieldSpec;
    use evogs_cli::app::render::CameraPath;
    use evogs_cli::app::study::StudyProtocol;
    use evogs_math::Vec3;

    #[test]
    fn command_line_definition_is_consistent() {
        Cli::command().debug_assert();
    }

    /// Parses a command line given as one string (arguments split at spaces).
    fn parse(line: &str) -> Cmd {
        Cli::try_parse_from(std::iter::once("evogs").chain(line.split(' ')))
            .unwrap_or_else(|e| panic!("`{line}` does not parse: {e}"))
            .cmd
    }

    /// The usage error of a command line that must not parse.
    fn refused(line: &str) -> String {
        Cli::try_parse_from(std::iter::once("evogs").chain(line.split(' ')))
            .map(|_| ())
            .expect_err(line)
            .to_string()
    }

    #[test]
    fn render_and_inject_read_the_shared_frame_options() {
        let Cmd::Render(c) = parse("render --run r --out o --times -1:2:5 --camera test --gif")
        else {
            panic!("not render")
        };
        assert_eq!(c.frames.times, (-1.0, 2.0, 5));
        assert_eq!(c.frames.camera, CameraPath::Test);
        assert!(c.frames.gif && c.frames.data.is_none());
        let Cmd::Inject(c) =
            parse("inject --run r --out o --mask sphere:0,0,0,1 --field translate:1,0,0 --data d")
        else {
            panic!("not inject")
        };
        assert_eq!(c.frames.times, (0.0, 1.0, 40));
        assert_eq!(c.frames.camera, CameraPath::Orbit);
        assert!(!c.frames.gif);
        assert_eq!(c.frames.data.as_deref(), Some(std::path::Path::new("d")));
        assert_eq!(c.field, FieldSpec::Translate(Vec3::new(1.0, 0.0, 0.0)));
    }

    #[test]
    fn counts_must_be_whole_and_positive() {
        for bad in ["-5", "0", "1.5", "x"] {
            for flag in [
                "train --iters",
                "study --jobs",
                "study --seeds",
                "bench --threads",
            ] {
                let e = refused(&format!("{flag} {bad}"));
                assert!(
                    e.contains("whole number of at least 1") && e.contains(&flag[flag.len() - 5..]),
                    "{flag} {bad}: {e}"
                );
            }
        }
        let Cmd::Study(s) = parse("study --iters 30 --seeds 3 --jobs 2") else {
            panic!("not study")
        };
        assert_eq!((s.iters, s.seeds, s.jobs), (Some(30), 3, 2), "parsed");
    }

    #[test]
    fn specs_are_parsed_into_their_values_with_the_line() {
        let Cmd::Study(s) = parse("study") else {
            panic!("not study")
        };
        assert_eq!(s.protocols, StudyProtocol::defaults(), "default protocols");
        assert_eq!(
            s.motions,
            vec![Motion::Velocity, Motion::Deformation, Motion::Static]
        );
        let Cmd::Study(s) = parse("study --protocols sparse:2 --motions static,velocity") else {
            panic!("not study")
        };
        assert_eq!(s.protocols, vec![StudyProtocol::Sparse(2)]);
        assert_eq!(s.motions, vec![Motion::Static, Motion::Velocity]);
        let Cmd::Bench(b) = parse("bench --sizes fast --motions deformation --no-single-thread")
        else {
            panic!("not bench")
        };
        assert_eq!(b.sizes, vec![FieldSize::Fast]);
        assert_eq!(b.motions, vec![Motion::Deformation]);
        assert!(!b.single_thread, "--no-single-thread");
        let Cmd::Bench(b) = parse("bench") else {
            panic!("not bench")
        };
        assert!(b.single_thread && b.gaussians == 20_000 && b.warmup == 2 && b.iters == 5);
        assert_eq!(b.sizes, vec![FieldSize::Paper, FieldSize::Fast]);
        // Each bad specification is a usage error that names its flag.
        for (line, flag) in [
            ("render --run r --out o --times 0:1", "--times"),
            ("render --run r --out o --times --gif", "--times"),
            ("export --run r --out o --times 1:0:x", "--times"),
            ("eval --run r --time-range nan:1", "--time-range"),
            (
                "inject --run r --out o --mask cone:1 --field translate:1,0,0",
                "--mask",
            ),
            (
                "inject --run r --out o --mask sphere:0,0,0,1 --field spin:1",
                "--field",
            ),
            ("study --protocols full,full", "--protocols"),
            ("study --motions warp", "--motions"),
            ("bench --motions static", "--motions"),
            ("bench --sizes huge", "--sizes"),
            ("bench --warmup -1", "--warmup"),
        ] {
            let e = refused(line);
            assert!(
                e.contains(flag) && e.contains("invalid value"),
                "{line}: {e}"
            );
        }
    }

    #[test]
    fn negative_times_parse_without_an_equals_sign() {
        let Cmd::Export(c) = parse("export --run r --time -0.5 --out o.ply") else {
            panic!("not export")
        };
        assert_eq!(c.time, Some(-0.5), "parsed");
        let Cmd::Eval(c) = parse("eval --run r --time-range -1:0.5") else {
            panic!("not eval")
        };
        assert_eq!(c.time_range, Some((-1.0, 0.5)));
    }
}
