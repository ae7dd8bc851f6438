//! A model gradient as one flat sequence of values, in a fixed order: the canonical
//! Gaussians (means, log-scales, quaternions w,x,y,z, opacity logits, SH triples), then each
//! anchor (means, log-scales, quaternions), the field and the waypoint field. This is the
//! order in which a batch's per-view gradients are summed and in which a gradient crosses a
//! process boundary ([`crate::train::batch`]).

use super::{AnchorState, ModelGrad};
use crate::field::Gemm;
use evogs_math::{Quat, Vec3};

fn vec3s<T: Copy>(v: &[Vec3<T>], f: &mut impl FnMut(T)) {
    for p in v {
        f(p.x);
        f(p.y);
        f(p.z);
    }
}

fn vec3s_mut<T>(v: &mut [Vec3<T>], f: &mut impl FnMut(&mut T)) {
    for p in v {
        f(&mut p.x);
        f(&mut p.y);
        f(&mut p.z);
    }
}

fn vec3s_zip<T: Copy>(a: &mut [Vec3<T>], b: &[Vec3<T>], f: &mut impl FnMut(&mut T, T)) {
    for (p, q) in a.iter_mut().zip(b) {
        f(&mut p.x, q.x);
        f(&mut p.y, q.y);
        f(&mut p.z, q.z);
    }
}

fn quats<T: Copy>(v: &[Quat<T>], f: &mut impl FnMut(T)) {
    for q in v {
        f(q.w);
        f(q.x);
        f(q.y);
        f(q.z);
    }
}

fn quats_mut<T>(v: &mut [Quat<T>], f: &mut impl FnMut(&mut T)) {
    for q in v {
        f(&mut q.w);
        f(&mut q.x);
        f(&mut q.y);
        f(&mut q.z);
    }
}

fn quats_zip<T: Copy>(a: &mut [Quat<T>], b: &[Quat<T>], f: &mut impl FnMut(&mut T, T)) {
    for (p, q) in a.iter_mut().zip(b) {
        f(&mut p.w, q.w);
        f(&mut p.x, q.x);
        f(&mut p.y, q.y);
        f(&mut p.z, q.z);
    }
}

fn scalars_zip<T: Copy>(a: &mut [T], b: &[T], f: &mut impl FnMut(&mut T, T)) {
    for (p, &q) in a.iter_mut().zip(b) {
        f(p, q);
    }
}

fn anchor<T: Copy>(a: &AnchorState<T>, f: &mut impl FnMut(T)) {
    vec3s(&a.means, f);
    vec3s(&a.log_scales, f);
    quats(&a.quats, f);
}

impl<T: Gemm> ModelGrad<T> {
    /// Number of values ([`ModelGrad::for_each`] visits this many).
    #[must_use]
    pub fn value_count(&self) -> usize {
        let c = &self.canonical;
        let gaussian = 3 + 3 + 4 + 1;
        let anchors: usize = self.anchors.iter().map(|a| 10 * a.means.len()).sum();
        gaussian * c.means.len()
            + 3 * c.sh.len()
            + anchors
            + self.field.len()
            + self.waypoint_field.len()
    }

    /// `true` if `other` has the same layout (Gaussians, SH coefficients, anchors, fields).
    #[must_use]
    pub fn same_shape(&self, other: &Self) -> bool {
        let (a, b) = (&self.canonical, &other.canonical);
        a.means.len() == b.means.len()
            && a.sh.len() == b.sh.len()
            && self.anchors.len() == other.anchors.len()
            && self.field.len() == other.field.len()
            && self.waypoint_field.len() == other.waypoint_field.len()
    }

    /// Visits every value in the order of the module docs.
    pub fn for_each(&self, mut f: impl FnMut(T)) {
        let c = &self.canonical;
        vec3s(&c.means, &mut f);
        vec3s(&c.log_scales, &mut f);
        quats(&c.quats, &mut f);
        c.opacity_logits.iter().for_each(|&v| f(v));
        c.sh.iter().flatten().for_each(|&v| f(v));
        for a in &self.anchors {
            anchor(a, &mut f);
        }
        self.field.iter().for_each(|&v| f(v));
        self.waypoint_field.iter().for_each(|&v| f(v));
    }

    /// Visits every value mutably in the order of the module docs.
    pub fn for_each_mut(&mut self, mut f: impl FnMut(&mut T)) {
        let c = &mut self.canonical;
        vec3s_mut(&mut c.means, &mut f);
        vec3s_mut(&mut c.log_scales, &mut f);
        quats_mut(&mut c.quats, &mut f);
        c.opacity_logits.iter_mut().for_each(&mut f);
        c.sh.iter_mut().flatten().for_each(&mut f);
        for a in &mut self.anchors {
            vec3s_mut(&mut a.means, &mut f);
            vec3s_mut(&mut a.log_scales, &mut f);
            quats_mut(&mut a.quats, &mut f);
        }
        self.field.iter_mut().for_each(&mut f);
        self.waypoint_field.iter_mut().for_each(&mut f);
    }

    /// Calls `f(self_value, other_value)` for every pair of values at the same place.
    ///
    /// # Panics
    /// If the layouts differ ([`ModelGrad::same_shape`]).
    pub fn zip_with(&mut self, other: &Self, mut f: impl FnMut(&mut T, T)) {
        assert!(self.same_shape(other), "gradients of different layouts");
        let (c, o) = (&mut self.canonical, &other.canonical);
        vec3s_zip(&mut c.means, &o.means, &mut f);
        vec3s_zip(&mut c.log_scales, &o.log_scales, &mut f);
        quats_zip(&mut c.quats, &o.quats, &mut f);
        scalars_zip(&mut c.opacity_logits, &o.opacity_logits, &mut f);
        for (p, q) in c.sh.iter_mut().zip(&o.sh) {
            scalars_zip(p, q, &mut f);
        }
        for (a, b) in self.anchors.iter_mut().zip(&other.anchors) {
            vec3s_zip(&mut a.means, &b.means, &mut f);
            vec3s_zip(&mut a.log_scales, &b.log_scales, &mut f);
            quats_zip(&mut a.quats, &b.quats, &mut f);
        }
        scalars_zip(&mut self.field, &other.field, &mut f);
        scalars_zip(&mut self.waypoint_field, &other.waypoint_field, &mut f);
    }

    /// `self += other`, value by value.
    ///
    /// # Panics
    /// If the layouts differ.
    pub fn add_assign(&mut self, other: &Self) {
        self.zip_with(other, |a, b| *a += b);
    }

    /// `self = other`, value by value (no allocation).
    ///
    /// # Panics
    /// If the layouts differ.
    pub fn copy_from(&mut self, other: &Self) {
        self.zip_with(other, |a, b| *a = b);
    }
}
