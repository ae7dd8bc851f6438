//! The HexPlane (K-Planes) space-time encoder of EvoGS/4DGS (`docs/method.md` §3).
//!
//! Coordinates `(x, y, z, t)` are normalised to [−1, 1] (space by the scene's bounding box,
//! time by a [`TimeMapping`]). Six planes, one per pair of coordinates, in itertools order:
//!
//! ```text
//! plane: 0 (x,y)  1 (x,z)  2 (x,t)  3 (y,z)  4 (y,t)  5 (z,t)      time planes: 2, 4, 5
//! ```
//!
//! Plane `(i, j)` is a grid of `res_j` rows × `res_i` columns of C-vectors (the first
//! coordinate indexes columns); it is stored **channel-last**, row-major:
//! `plane[(row·res_i + col)·C + c]`, so one bilinear lookup reads four contiguous C-vectors.
//! Sampling is bilinear with `align_corners = True` and border clamping:
//! `u = (c + 1)/2·(n − 1)` clamped to [0, n − 1] (zero gradient where clamped).
//! Within a resolution level the six sampled C-vectors are multiplied element-wise (Hadamard
//! product); levels (spatial resolution × multiplier, time resolution unchanged) are
//! concatenated: `feature_dim = C × levels`.
//!
//! Initialisation: time planes 1, spatial planes U(0.1, 0.5). Parameters live in the caller's
//! flat vector (so one Adam optimiser and one checkpoint cover everything); this type only
//! knows the layout.

use super::gemm::Gemm;
use super::lanes::{self, LANES, coord_grad_sums};
use evogs_math::Real;
use evogs_math::rng::SplitMix64;

/// Coordinate pairs of the six planes (itertools order).
pub const PLANE_AXES: [(usize, usize); 6] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];
/// Planes that contain time.
pub const TIME_PLANES: [usize; 3] = [2, 4, 5];
/// Planes that are purely spatial.
pub const SPACE_PLANES: [usize; 3] = [0, 1, 3];

/// How frame times map to the time coordinate (an enum so that the checkpoint format names
/// it).
///
/// Outside the mapped range the sampling clamps at the border cells, so a time-dependent
/// field reads there the law of the range's nearest end: that is the documented behaviour of
/// [`Normalized`](Self::Normalized) after the training window ("hold the last law"), and
/// [`Autonomous`](Self::Autonomous) is the choice of a field with no time input at all.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TimeMapping {
    /// `[t_min, t_max] → [−1, 1]` (the training time range; the default).
    Normalized {
        /// Time mapped to −1.
        t_min: f64,
        /// Time mapped to +1.
        t_max: f64,
    },
    /// No time input: every time maps to the coordinate 0, so the field is a function of
    /// position alone (an autonomous vector field). The time planes still multiply in, read
    /// at that one time coordinate: one learned factor per spatial axis.
    Autonomous,
}

impl TimeMapping {
    /// The time coordinate of `t`.
    #[must_use]
    pub fn coord<T: Real>(self, t: T) -> T {
        match self {
            Self::Normalized { t_min, t_max } => {
                (t - T::from_f64(t_min)) * T::from_f64(2.0 / (t_max - t_min)) - T::ONE
            }
            Self::Autonomous => T::ZERO,
        }
    }
}

/// The shape of a HexPlane: channels per plane, base resolution and level multipliers.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HexPlaneConfig {
    /// Channels per plane (C).
    pub channels: usize,
    /// Base resolution `[x, y, z, t]` (each ≥ 2).
    pub resolution: [usize; 4],
    /// Spatial resolution multipliers, one level each (time is not multiplied).
    pub multires: Vec<usize>,
}

impl HexPlaneConfig {
    /// Number of plane values this shape holds (what [`HexPlane::new`] lays out), or `None`
    /// if a level multiplier is 0 or the count does not fit a `usize`: computed without
    /// allocating, so that a configuration can be checked before anything is built.
    #[must_use]
    pub fn param_count(&self) -> Option<usize> {
        let mut total: usize = 0;
        for &m in &self.multires {
            if m == 0 {
                return None;
            }
            let res = [
                self.resolution[0].checked_mul(m)?,
                self.resolution[1].checked_mul(m)?,
                self.resolution[2].checked_mul(m)?,
                self.resolution[3],
            ];
            for &(i, j) in &PLANE_AXES {
                let plane = res[i].checked_mul(res[j])?.checked_mul(self.channels)?;
                total = total.checked_add(plane)?;
            }
        }
        Some(total)
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct PlaneLayout {
    offset: usize,
    /// Resolution of the first coordinate (columns).
    width: usize,
    /// Resolution of the second coordinate (rows).
    height: usize,
}

/// The layout of a HexPlane inside a flat parameter vector, and its bounding box.
#[derive(Clone, Debug, PartialEq)]
pub struct HexPlane {
    channels: usize,
    planes: Vec<[PlaneLayout; 6]>,
    n_params: usize,
    aabb_min: [f64; 3],
    aabb_max: [f64; 3],
    time: TimeMapping,
}

/// One bilinear lookup: the flat index of corner (col0, row0) channel 0, the strides to the
/// neighbouring column and row, the fractional offsets and `du/dc`, `dv/dc` (0 where clamped).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lookup<T> {
    /// Flat index of corner (col0, row0), channel 0.
    pub base: usize,
    /// Index step to the next column.
    pub col_step: usize,
    /// Index step to the next row.
    pub row_step: usize,
    /// Fraction along the columns.
    pub fx: T,
    /// Fraction along the rows.
    pub fy: T,
    /// `∂u/∂(first coordinate)`, 0 when clamped.
    pub du: T,
    /// `∂v/∂(second coordinate)`, 0 when clamped.
    pub dv: T,
}

impl<T> Lookup<T> {
    /// The four corner C-vectors `[p00, p10, p01, p11]` of the lookup's cell, `n` channels
    /// each, from the flat parameters.
    #[inline]
    #[must_use]
    pub fn corners<'a>(&self, params: &'a [T], n: usize) -> [&'a [T]; 4] {
        let (b, r) = (self.base, self.base + self.row_step);
        [
            &params[b..b + n],
            &params[b + self.col_step..b + self.col_step + n],
            &params[r..r + n],
            &params[r + self.col_step..r + self.col_step + n],
        ]
    }
}

/// What the plane-gradient scatter keeps of a [`Lookup`]: the offset of corner (col0, row0),
/// channel 0, within its plane, and the two fractions (12 bytes in f32 against the 40 of a
/// `Lookup`; the strides are the plane's, and the scatter reads no `du`, `dv`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CellRecord<T> {
    /// Offset of corner (col0, row0), channel 0, from the start of the plane.
    pub offset: u32,
    /// Fraction along the columns.
    pub fx: T,
    /// Fraction along the rows.
    pub fy: T,
}

/// `u = (c + 1)/2·(n − 1)` clamped, split into cell and fraction; returns (cell, frac, du/dc).
#[inline]
fn axis<T: Real>(c: T, n: usize) -> (usize, T, T) {
    let scale = T::from_usize(n - 1) * T::HALF;
    let u = (c + T::ONE) * scale;
    let top = T::from_usize(n - 1);
    let (u, d) = if u <= T::ZERO {
        (T::ZERO, T::ZERO)
    } else if u >= top {
        (top, T::ZERO)
    } else if u.is_nan() {
        (T::ZERO, T::ZERO)
    } else {
        (u, scale)
    };
    #[allow(clippy::cast_possible_truncation, reason = "u is in [0, n − 1]")]
    let cell = (u.floor().to_f64() as usize).min(n - 2);
    (cell, u - T::from_usize(cell), d)
}

impl HexPlane {
    /// A layout for `cfg` over the box `[aabb_min, aabb_max]` with a time mapping.
    ///
    /// # Panics
    /// If a resolution is below 2, there are no levels or channels, or the box is empty.
    #[must_use]
    pub fn new(
        cfg: &HexPlaneConfig,
        aabb_min: [f64; 3],
        aabb_max: [f64; 3],
        time: TimeMapping,
    ) -> Self {
        assert!(
            cfg.channels > 0 && !cfg.multires.is_empty(),
            "HexPlane needs channels and at least one level"
        );
        assert!(
            (0..3).all(|a| aabb_max[a] > aabb_min[a]),
            "HexPlane bounding box is empty"
        );
        let mut offset = 0;
        let mut planes = Vec::new();
        for &m in &cfg.multires {
            let res = [
                cfg.resolution[0] * m,
                cfg.resolution[1] * m,
                cfg.resolution[2] * m,
                cfg.resolution[3],
            ];
            assert!(
                res.iter().all(|&r| r >= 2),
                "HexPlane resolutions must be at least 2"
            );
            let mut level = [PlaneLayout {
                offset: 0,
                width: 0,
                height: 0,
            }; 6];
            for (p, &(i, j)) in PLANE_AXES.iter().enumerate() {
                level[p] = PlaneLayout {
                    offset,
                    width: res[i],
                    height: res[j],
                };
                let size = res[i] * res[j] * cfg.channels;
                // Scatter records hold offsets within a plane as u32 (`CellRecord`).
                assert!(
                    u32::try_from(size).is_ok(),
                    "a HexPlane plane must hold fewer than 2^32 values"
                );
                offset += size;
            }
            planes.push(level);
        }
        Self {
            channels: cfg.channels,
            planes,
            n_params: offset,
            aabb_min,
            aabb_max,
            time,
        }
    }

    /// Number of parameters (all plane values).
    #[must_use]
    pub const fn n_params(&self) -> usize {
        self.n_params
    }
    /// Channels per plane.
    #[must_use]
    pub const fn channels(&self) -> usize {
        self.channels
    }
    /// Number of resolution levels.
    #[must_use]
    pub fn levels(&self) -> usize {
        self.planes.len()
    }
    /// Output feature dimension `C × levels`.
    #[must_use]
    pub fn feature_dim(&self) -> usize {
        self.channels * self.planes.len()
    }
    /// Number of (level, plane) lookups per point: `6 × levels`.
    #[must_use]
    pub fn n_lookups(&self) -> usize {
        6 * self.planes.len()
    }
    /// The bounding box `(min, max)` the spatial coordinates are normalised over.
    #[must_use]
    pub const fn aabb(&self) -> ([f64; 3], [f64; 3]) {
        (self.aabb_min, self.aabb_max)
    }
    /// The time mapping.
    #[must_use]
    pub const fn time_mapping(&self) -> TimeMapping {
        self.time
    }
    /// The parameter range of plane `p` of level `l`.
    #[must_use]
    pub fn plane_range(&self, l: usize, p: usize) -> core::ops::Range<usize> {
        let pl = self.planes[l][p];
        pl.offset..pl.offset + pl.width * pl.height * self.channels
    }
    /// (rows, columns) of plane `p` of level `l`.
    #[must_use]
    pub fn plane_shape(&self, l: usize, p: usize) -> (usize, usize) {
        let pl = self.planes[l][p];
        (pl.height, pl.width)
    }

    /// Initial values: time planes 1, spatial planes U(0.1, 0.5).
    pub fn init_params<T: Real>(&self, rng: &mut SplitMix64, out: &mut [T]) {
        for l in 0..self.levels() {
            for p in 0..6 {
                let r = self.plane_range(l, p);
                for v in &mut out[r] {
                    *v = if TIME_PLANES.contains(&p) {
                        T::ONE
                    } else {
                        T::from_f64(rng.uniform(0.1, 0.5))
                    };
                }
            }
        }
    }

    /// Normalised coordinates `[cx, cy, cz, ct]` of a position and time, and `∂c/∂p` per axis.
    #[must_use]
    pub fn coords<T: Real>(&self, p: [T; 3], t: T) -> ([T; 4], [T; 3]) {
        let mut c = [T::ZERO; 4];
        let mut d = [T::ZERO; 3];
        for a in 0..3 {
            let s = T::from_f64(2.0 / (self.aabb_max[a] - self.aabb_min[a]));
            c[a] = (p[a] - T::from_f64(self.aabb_min[a])) * s - T::ONE;
            d[a] = s;
        }
        c[3] = self.time.coord(t);
        (c, d)
    }

    /// The bilinear lookup of plane `p`, level `l` at normalised coordinates `c`.
    #[inline]
    #[must_use]
    pub fn lookup<T: Real>(&self, l: usize, p: usize, c: &[T; 4]) -> Lookup<T> {
        let pl = self.planes[l][p];
        let (i, j) = PLANE_AXES[p];
        self.lookup_from_cells(l, p, axis(c[i], pl.width), axis(c[j], pl.height))
    }

    /// The six lookups of level `l` at normalised coordinates `c`, each coordinate's cell and
    /// fraction computed once for the three planes that share it (bitwise the six
    /// [`lookup`](Self::lookup)s).
    #[inline(always)]
    #[must_use]
    pub fn level_lookups<T: Real>(&self, l: usize, c: &[T; 4]) -> [Lookup<T>; 6] {
        let pl = &self.planes[l];
        // Plane 0 is (x, y), 1 is (x, z), 2 is (x, t): their widths and heights are the
        // resolutions of x, y, z and t at this level.
        let res = [pl[0].width, pl[0].height, pl[1].height, pl[2].height];
        let cells: [(usize, T, T); 4] = core::array::from_fn(|a| axis(c[a], res[a]));
        core::array::from_fn(|p| {
            let (i, j) = PLANE_AXES[p];
            self.lookup_from_cells(l, p, cells[i], cells[j])
        })
    }

    /// The lookup of plane `p`, level `l` from the cells of its two coordinates
    /// (`(cell, fraction, d(cell units)/dc)` each, from `axis`).
    #[inline(always)]
    fn lookup_from_cells<T: Real>(
        &self,
        l: usize,
        p: usize,
        (col, fx, du): (usize, T, T),
        (row, fy, dv): (usize, T, T),
    ) -> Lookup<T> {
        let pl = self.planes[l][p];
        let ch = self.channels;
        Lookup {
            base: pl.offset + (row * pl.width + col) * ch,
            col_step: ch,
            row_step: pl.width * ch,
            fx,
            fy,
            du,
            dv,
        }
    }

    /// The scatter's record of lookup `lk` of plane `p`, level `l`.
    #[inline]
    #[must_use]
    pub fn cell_record<T: Real>(&self, l: usize, p: usize, lk: &Lookup<T>) -> CellRecord<T> {
        #[allow(
            clippy::cast_possible_truncation,
            reason = "a plane holds fewer than 2^32 values (checked in new)"
        )]
        let offset = (lk.base - self.planes[l][p].offset) as u32;
        CellRecord {
            offset,
            fx: lk.fx,
            fy: lk.fy,
        }
    }

    /// The lookup of a scatter record of plane `p`, level `l`, with its base relative to
    /// the start of the plane (and `du`, `dv` zero: the scatter does not read them).
    #[inline]
    #[must_use]
    pub fn plane_lookup<T: Real>(&self, l: usize, p: usize, cell: &CellRecord<T>) -> Lookup<T> {
        Lookup {
            base: cell.offset as usize,
            col_step: self.channels,
            row_step: self.planes[l][p].width * self.channels,
            fx: cell.fx,
            fy: cell.fy,
            du: T::ZERO,
            dv: T::ZERO,
        }
    }

    /// Writes the sampled C-vector of a lookup into `out`.
    #[inline(always)]
    pub fn sample<T: Real>(params: &[T], lk: &Lookup<T>, out: &mut [T]) {
        let (w00, w10, w01, w11) = corner_weights(lk.fx, lk.fy);
        let [p00, p10, p01, p11] = lk.corners(params, out.len());
        for c in 0..out.len() {
            out[c] = w00 * p00[c] + w10 * p10[c] + w01 * p01[c] + w11 * p11[c];
        }
    }

    /// Multiplies `out` element-wise by the sampled C-vector of a lookup (`out_c ← out_c·s_c`,
    /// with `s_c` rounded exactly as [`sample`](Self::sample) rounds it): one factor of a
    /// level's Hadamard product.
    #[inline(always)]
    pub fn sample_mul<T: Real>(params: &[T], lk: &Lookup<T>, out: &mut [T]) {
        let (w00, w10, w01, w11) = corner_weights(lk.fx, lk.fy);
        let [p00, p10, p01, p11] = lk.corners(params, out.len());
        for c in 0..out.len() {
            out[c] *= w00 * p00[c] + w10 * p10[c] + w01 * p01[c] + w11 * p11[c];
        }
    }

    /// The gradient of `Σ_c g_c·s_c` (s the sampled vector) with respect to the lookup's two
    /// normalised coordinates: `(∂/∂c_i, ∂/∂c_j)`.
    #[inline(always)]
    #[must_use]
    pub fn sample_coord_grad<T: Gemm>(params: &[T], lk: &Lookup<T>, g: &[T]) -> (T, T) {
        if lk.du == T::ZERO && lk.dv == T::ZERO {
            return (T::ZERO, T::ZERO);
        }
        let n = g.len();
        let [p00, p10, p01, p11] = lk.corners(params, n);
        // Channel c goes to lane c mod LANES (fixed order, vectorised): the whole blocks in
        // the scalar type's lane kernel, then the tail channel by channel.
        let mut acc = ([T::ZERO; LANES], [T::ZERO; LANES]);
        let full = n - n % LANES;
        T::coord_grad_lanes(
            &g[..full],
            [&p00[..full], &p10[..full], &p01[..full], &p11[..full]],
            lk.fx,
            lk.fy,
            &mut acc,
        );
        coord_grad_sums(
            &g[full..],
            [&p00[full..], &p10[full..], &p01[full..], &p11[full..]],
            lk.fx,
            lk.fy,
            &mut acc,
        );
        let (gu, gv) = (lanes::total(acc.0), lanes::total(acc.1));
        (gu * lk.du, gv * lk.dv)
    }

    /// Adds `g ⊗ (bilinear weights)` into the four corners of a lookup (the parameter VJP).
    #[inline(always)]
    pub fn scatter<T: Real>(d_params: &mut [T], lk: &Lookup<T>, g: &[T]) {
        let (w00, w10, w01, w11) = corner_weights(lk.fx, lk.fy);
        let n = g.len();
        for (off, w) in [
            (0, w00),
            (lk.col_step, w10),
            (lk.row_step, w01),
            (lk.row_step + lk.col_step, w11),
        ] {
            let dst = &mut d_params[lk.base + off..lk.base + off + n];
            for c in 0..n {
                dst[c] += w * g[c];
            }
        }
    }
}

#[inline]
fn corner_weights<T: Real>(fx: T, fy: T) -> (T, T, T, T) {
    (
        (T::ONE - fx) * (T::ONE - fy),
        fx * (T::ONE - fy),
        (T::ONE - fx) * fy,
        fx * fy,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shared-axis lookups of a level are bitwise the six single lookups, inside the box,
    /// clamped at both borders, at a cell edge and at NaN, on two levels of unequal
    /// resolutions (time not multiplied).
    #[test]
    fn level_lookups_are_the_six_single_lookups() {
        let cfg = HexPlaneConfig {
            channels: 3,
            resolution: [5, 7, 4, 6],
            multires: vec![1, 3],
        };
        let hex = HexPlane::new(
            &cfg,
            [-1.0, -2.0, 0.0],
            [1.0, 2.0, 3.0],
            TimeMapping::Normalized {
                t_min: 0.0,
                t_max: 1.0,
            },
        );
        let coords: [[f64; 4]; 5] = [
            [0.1, -0.35, 0.72, -0.9],
            [-1.5, 1.2, -1.0, 1.0],
            [1.0, -1.0, 0.5, 0.0],
            [0.25, 0.0, -0.999, 2.0],
            [f64::NAN, 0.3, f64::NAN, -0.2],
        ];
        for c in &coords {
            for l in 0..hex.levels() {
                let shared = hex.level_lookups(l, c);
                for (p, got) in shared.iter().enumerate() {
                    let want = hex.lookup(l, p, c);
                    assert_eq!(
                        (got.base, got.col_step, got.row_step),
                        (want.base, want.col_step, want.row_step),
                        "level {l} plane {p} at {c:?}: offsets"
                    );
                    for (g, w) in [
                        (got.fx, want.fx),
                        (got.fy, want.fy),
                        (got.du, want.du),
                        (got.dv, want.dv),
                    ] {
                        assert_eq!(g.to_bits(), w.to_bits(), "level {l} plane {p} at {c:?}");
                    }
                }
            }
        }
    }
}
