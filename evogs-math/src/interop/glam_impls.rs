//! glam interop (f32 and f64): `From` conversions both ways.

use crate::{Mat3, Quat, Vec2, Vec3};

macro_rules! glam_conversions {
    ($t:ty, $gv2:ty, $gv3:ty, $gq:ty, $gm3:ty) => {
        impl From<$gv2> for Vec2<$t> {
            fn from(v: $gv2) -> Self {
                Self::new(v.x, v.y)
            }
        }
        impl From<Vec2<$t>> for $gv2 {
            fn from(v: Vec2<$t>) -> Self {
                <$gv2>::new(v.x, v.y)
            }
        }
        impl From<$gv3> for Vec3<$t> {
            fn from(v: $gv3) -> Self {
                Self::new(v.x, v.y, v.z)
            }
        }
        impl From<Vec3<$t>> for $gv3 {
            fn from(v: Vec3<$t>) -> Self {
                <$gv3>::new(v.x, v.y, v.z)
            }
        }
        /// glam stores (x, y, z, w); evogs stores (w, x, y, z).
        impl From<$gq> for Quat<$t> {
            fn from(q: $gq) -> Self {
                Self::new(q.w, q.x, q.y, q.z)
            }
        }
        impl From<Quat<$t>> for $gq {
            fn from(q: Quat<$t>) -> Self {
                <$gq>::from_xyzw(q.x, q.y, q.z, q.w)
            }
        }
        /// glam is column-major: `x_axis` is column 0.
        impl From<$gm3> for Mat3<$t> {
            fn from(m: $gm3) -> Self {
                Self::from_cols(m.x_axis.into(), m.y_axis.into(), m.z_axis.into())
            }
        }
        impl From<Mat3<$t>> for $gm3 {
            fn from(m: Mat3<$t>) -> Self {
                <$gm3>::from_cols(m.col(0).into(), m.col(1).into(), m.col(2).into())
            }
        }
    };
}

glam_conversions!(f32, glam::Vec2, glam::Vec3, glam::Quat, glam::Mat3);
glam_conversions!(f64, glam::DVec2, glam::DVec3, glam::DQuat, glam::DMat3);

#[cfg(test)]
mod tests {
    use crate::{Mat3, Quat, So3, Vec3};

    #[test]
    fn round_trips_and_agree_on_rotation() {
        let v = Vec3::new(0.25_f64, -1.5, 3.0);
        let gv: glam::DVec3 = v.into();
        assert_eq!(Vec3::from(gv), v, "vec3 f64 round trip");
        let vf = Vec3::new(0.25_f32, -1.5, 3.0);
        assert_eq!(Vec3::from(glam::Vec3::from(vf)), vf, "vec3 f32 round trip");
        let q = Quat::new(0.8_f64, 0.1, -0.5, 0.3).normalize();
        let gq: glam::DQuat = q.into();
        assert_eq!(Quat::from(gq), q, "quat round trip");
        assert!((gq.w - q.w).abs() < 1e-16, "w is w, not first");
        let m = Mat3::from_rows([[1.0_f64, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]]);
        let gm: glam::DMat3 = m.into();
        assert_eq!(Mat3::from(gm), m, "mat3 round trip");
        assert!(
            (gm.col(0).y - 4.0).abs() < 1e-16,
            "row-major (1,0) is glam column 0, y"
        );
        // Same rotation of a vector on both sides.
        let a = So3::from_unit_quat(q).act(v);
        let b: Vec3<f64> = (gq * gv).into();
        assert!((a - b).norm() < 1e-14, "glam and evogs rotate alike");
        let c: Vec3<f64> = (gm * gv).into();
        assert!(
            (c - m.mul_vec(v)).norm() < 1e-13,
            "matrix-vector products agree"
        );
    }
}
