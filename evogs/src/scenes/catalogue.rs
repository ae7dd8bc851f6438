//! The procedural scenes: each a few bodies with closed-form motion over a static
//! checkerboard floor (so that a static model is a meaningful baseline).

use super::body::Shape;
use super::law::Law;

/// One body of a scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodySpec {
    /// Name, as in `motion.json`.
    pub name: &'static str,
    /// Shape.
    pub shape: Shape,
    /// Centre of the shape in the body frame.
    pub centre: [f64; 3],
    /// Motion law.
    pub law: Law,
    /// Index of the first palette colour (bodies of one scene differ in colour).
    pub palette: usize,
}

/// A scene: a name, a one-line description and its moving bodies (the floor is added by the
/// generator).
#[derive(Clone, Debug, PartialEq)]
pub struct SceneSpec {
    /// Name (the output folder).
    pub name: &'static str,
    /// What moves, and how.
    pub description: &'static str,
    /// The moving bodies.
    pub bodies: Vec<BodySpec>,
}

/// The floor every scene stands on: a 4 × 4 checkerboard at `z = 0`, never moving.
#[must_use]
pub fn floor() -> BodySpec {
    BodySpec {
        name: "floor",
        shape: Shape::Sheet {
            half: [2.0, 2.0],
            square: 0.4,
        },
        centre: [0.0, 0.0, 0.0],
        law: Law::Still {
            origin: [0.0, 0.0, 0.0],
            tilt: [0.0, 0.0, 0.0],
        },
        palette: 0,
    }
}

fn cube(half: f64) -> Shape {
    Shape::Box {
        half: [half, half, half],
    }
}

/// Every scene, in a fixed order.
#[must_use]
pub fn catalogue() -> Vec<SceneSpec> {
    const O: [f64; 3] = [0.0, 0.0, 0.0];
    vec![
        SceneSpec {
            name: "translate",
            description: "a box sliding at constant velocity",
            bodies: vec![BodySpec {
                name: "box",
                shape: cube(0.22),
                centre: O,
                law: Law::Translate {
                    origin: [-0.75, -0.3, 0.3],
                    velocity: [1.2, 0.45, 0.0],
                },
                palette: 2,
            }],
        },
        SceneSpec {
            name: "throw",
            description: "a ball thrown under constant gravity (no bounce)",
            bodies: vec![BodySpec {
                name: "ball",
                shape: Shape::Sphere { radius: 0.2 },
                centre: O,
                law: Law::Throw {
                    origin: [-0.8, -0.1, 0.835],
                    velocity: [1.2, 0.2, 1.5],
                    acceleration: [0.0, 0.0, -3.0],
                },
                palette: 2,
            }],
        },
        SceneSpec {
            name: "spin",
            description: "a box spinning about a tilted axis through its centre",
            bodies: vec![BodySpec {
                name: "box",
                shape: Shape::Box {
                    half: [0.35, 0.25, 0.18],
                },
                centre: O,
                law: Law::Spin {
                    centre: [0.0, 0.0, 0.55],
                    axis: unit([0.25, 0.15, 1.0]),
                    rate: 4.0,
                    phase: 0.0,
                },
                palette: 2,
            }],
        },
        SceneSpec {
            name: "orbit",
            description: "a ball on a circular orbit at constant orientation",
            bodies: vec![BodySpec {
                name: "ball",
                shape: Shape::Sphere { radius: 0.2 },
                centre: O,
                law: Law::Orbit {
                    centre: [0.0, 0.0, 0.5],
                    axis: [0.0, 0.0, 1.0],
                    radius: [0.85, 0.0, 0.0],
                    rate: 2.5,
                },
                palette: 3,
            }],
        },
        SceneSpec {
            name: "pendulum",
            description: "a box bob on a pendulum (small-angle closed form)",
            bodies: vec![BodySpec {
                name: "bob",
                shape: cube(0.16),
                centre: [0.0, 0.0, -1.0],
                law: Law::Pendulum {
                    pivot: [0.0, 0.0, 1.45],
                    axis: [1.0, 0.0, 0.0],
                    amplitude: 0.35,
                    frequency: 7.0,
                    phase: 0.0,
                },
                palette: 2,
            }],
        },
        SceneSpec {
            name: "wave",
            description: "a standing sheet carrying a travelling wave (non-rigid)",
            bodies: vec![BodySpec {
                name: "sheet",
                shape: Shape::Sheet {
                    half: [0.8, 0.35],
                    square: 0.2,
                },
                centre: O,
                law: Law::Wave {
                    origin: [0.0, 0.0, 0.55],
                    tilt: [std::f64::consts::FRAC_PI_2, 0.0, 0.0],
                    amplitude: 0.1,
                    wavenumber: 7.5,
                    frequency: 8.0,
                },
                palette: 4,
            }],
        },
        SceneSpec {
            name: "pair",
            description: "two bodies: a box sliding and a ball orbiting",
            bodies: vec![
                BodySpec {
                    name: "box",
                    shape: cube(0.18),
                    centre: O,
                    law: Law::Translate {
                        origin: [-0.7, 0.6, 0.2],
                        velocity: [1.1, -0.2, 0.0],
                    },
                    palette: 2,
                },
                BodySpec {
                    name: "ball",
                    shape: Shape::Sphere { radius: 0.17 },
                    centre: O,
                    law: Law::Orbit {
                        centre: [0.0, -0.3, 0.55],
                        axis: unit([0.0, 0.3, 1.0]),
                        radius: [0.6, 0.0, 0.0],
                        rate: -3.0,
                    },
                    palette: 3,
                },
            ],
        },
    ]
}

fn unit(a: [f64; 3]) -> [f64; 3] {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    a.map(|x| x / n)
}

/// The scenes named in `names` (in catalogue order), or all when `names` is empty.
///
/// # Errors
/// An unknown name (the message lists the known ones).
pub fn select(names: &[String]) -> Result<Vec<SceneSpec>, String> {
    let all = catalogue();
    for n in names {
        if !all.iter().any(|s| s.name == n) {
            let known: Vec<&str> = all.iter().map(|s| s.name).collect();
            return Err(format!("unknown scene `{n}` (known: {})", known.join(", ")));
        }
    }
    Ok(all
        .into_iter()
        .filter(|s| names.is_empty() || names.iter().any(|n| n == s.name))
        .collect())
}
