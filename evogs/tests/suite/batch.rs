//! A batch of K views spread over K processes gives the same bits as one process with the
//! same batch: here the processes are threads that exchange their shares through
//! [`Collective::all_gather`] (the `evogs` binary does the same over MPI, tested in
//! evogs-cli's `mpi` test). The run covers the static warm-up, the switch to velocity
//! dynamics, densification and pruning (from the reduced statistics), and anchor refreshes.

use evogs::config::TrainConfig;
use evogs::field::HexPlaneConfig;
use evogs::model::Motion;
use evogs::train::collective::{Collective, agree, parameter_hash};
use evogs::train::step::ViewData;
use evogs::train::trainer::Trainer;
use evogs_math::{Par, Quat, Vec3};
use evogs_splat::{Image, PinholeCamera, RenderOptions, Splats, render};
use std::sync::{Arc, Barrier, Mutex};

const SIZE: usize = 32;

/// Ranks as threads: each puts its bytes in its slot, all wait, all read every slot in
/// rank order, all wait again before the slots can be reused.
struct Threads {
    rank: usize,
    size: usize,
    slots: Arc<Mutex<Vec<Vec<u8>>>>,
    barrier: Arc<Barrier>,
}

impl Threads {
    fn group(size: usize) -> Vec<Self> {
        let slots = Arc::new(Mutex::new(vec![Vec::new(); size]));
        let barrier = Arc::new(Barrier::new(size));
        (0..size)
            .map(|rank| Self {
                rank,
                size,
                slots: Arc::clone(&slots),
                barrier: Arc::clone(&barrier),
            })
            .collect()
    }
}

impl Collective for Threads {
    fn rank(&self) -> usize {
        self.rank
    }
    fn size(&self) -> usize {
        self.size
    }
    fn all_gather(&self, mine: &[u8]) -> Result<Vec<u8>, String> {
        self.slots.lock().map_err(|e| e.to_string())?[self.rank] = mine.to_vec();
        self.barrier.wait();
        let all = self.slots.lock().map_err(|e| e.to_string())?.concat();
        self.barrier.wait();
        Ok(all)
    }
}

/// A red square sliding over a grey backdrop, seen by four cameras at six times.
fn views() -> Vec<ViewData<f32>> {
    let opts = RenderOptions {
        sh_degree: 0,
        background: [1.0; 3],
        par: Par::Seq,
        ..RenderOptions::default()
    };
    let mut out = Vec::new();
    for k in 0..4_u8 {
        let az = f64::from(k) * std::f64::consts::FRAC_PI_2 + 0.3;
        let eye = Vec3::new(az.cos() * 1.6, az.sin() * 1.6, 1.4);
        let cam =
            PinholeCamera::look_at(eye, Vec3::zero(), Vec3::new(0.0, 0.0, 1.0), 0.9, SIZE, SIZE)
                .expect("camera");
        for i in 0..6_u8 {
            let t = f64::from(i) / 5.0;
            let mut s = Splats::new(0);
            for (x, c, scale) in [(-0.3 + 0.6 * t, 0.9, 0.08), (0.0, 0.2, 0.4)] {
                #[allow(clippy::cast_possible_truncation, reason = "test scene in f32")]
                let (x, c, scale) = (x as f32, c as f32, scale as f32);
                s.push(
                    Vec3::new(x, 0.0, if scale < 0.1 { 0.1 } else { -0.1 }),
                    Vec3::splat(scale.ln()),
                    Quat::identity(),
                    3.0,
                    &[[(c - 0.5) / 0.282, -1.0, -1.0]],
                );
            }
            let image: Image<f32> = render(&s, &cam, &opts).raster.rgb;
            out.push(ViewData {
                camera: cam,
                time: t,
                image: Arc::new(image),
            });
        }
    }
    out
}

fn config(batch: u64) -> TrainConfig {
    let mut c = TrainConfig::fast();
    c.dynamics.motion = Motion::Velocity;
    c.field.hexplane = HexPlaneConfig {
        channels: 4,
        resolution: [6, 6, 6, 4],
        multires: vec![1],
    };
    c.field.width = 16;
    c.init.sh_degree = 0;
    c.init.random_points = 300;
    c.schedule.views_per_step = batch;
    c.schedule.warmup_iters = 10;
    c.schedule.iterations = 60;
    c.schedule.curriculum_iters = 20;
    c.densify.from_iter = 15;
    c.densify.until_iter = 50;
    c.densify.interval = 15;
    c.optim.lr_max_steps = 60;
    c
}

fn trained_alone(batch: u64) -> Trainer {
    let mut t = Trainer::new(config(batch), views(), None).expect("trainer");
    while !t.finished() {
        t.step().expect("step");
    }
    t
}

#[test]
fn two_ranks_give_the_bits_of_one_process_with_the_same_batch() {
    let alone = trained_alone(2);
    let ranks = Threads::group(2);
    let hashes: Vec<(u64, usize, Vec<f64>)> = std::thread::scope(|scope| {
        let handles: Vec<_> = ranks
            .iter()
            .map(|c| {
                scope.spawn(move || {
                    let mut t = Trainer::new(config(2), views(), None).expect("trainer");
                    let mut losses = Vec::new();
                    while !t.finished() {
                        losses.push(t.step_with(c).expect("step").losses.total);
                    }
                    agree(c, "parameters", parameter_hash(t.model())).expect("ranks agree");
                    (parameter_hash(t.model()), t.model().len(), losses)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("rank"))
            .collect()
    });
    let densified = alone.log().iter().any(|r| r.gaussians != 300);
    assert!(densified, "the run densifies or prunes");
    for (rank, (h, n, _)) in hashes.iter().enumerate() {
        assert_eq!(*n, alone.model().len(), "rank {rank}: Gaussian count");
        assert_eq!(*h, parameter_hash(alone.model()), "rank {rank}: parameters");
    }
    assert_eq!(hashes[0].2, hashes[1].2, "the ranks report the same losses");
    let logged: Vec<f64> = alone.log().iter().map(|r| r.loss).collect();
    for r in alone.log() {
        let i = usize::try_from(r.iteration).expect("small") - 1;
        assert_eq!(
            r.loss.to_bits(),
            hashes[0].2[i].to_bits(),
            "loss at {}",
            r.iteration
        );
    }
    assert!(!logged.is_empty());
    // The batch matters: one view per step is another run.
    assert_ne!(
        parameter_hash(trained_alone(1).model()),
        parameter_hash(alone.model())
    );
}

#[test]
fn a_batch_that_does_not_split_over_the_ranks_is_refused_and_differing_ranks_are_named() {
    let ranks = Threads::group(2);
    let t = Trainer::new(config(3), views(), None).expect("trainer");
    let e = t
        .check_collective(&ranks[0])
        .expect_err("3 views over 2 ranks");
    assert!(e.to_string().contains("views_per_step = 3"), "{e}");
    let errors: Vec<String> = std::thread::scope(|scope| {
        let handles: Vec<_> = ranks
            .iter()
            .map(|c| scope.spawn(move || agree(c, "parameters", 7 + c.rank() as u64)))
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("rank").expect_err("they differ"))
            .collect()
    });
    for e in errors {
        assert!(e.contains("rank 1") && e.contains("rank 0 holds"), "{e}");
    }
}
