//! glam interop (f32 and f64): `From` conversions both ways.

use crate::{Mat3, Quat, Se3, Vec2, Vec3};

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

/// SE(3) transforms to and from glam's affine transforms and 4×4 matrices. Towards glam the
/// conversion is exact (`from_rotation_translation`). From glam the linear part must be a
/// rotation: it is read through [`Se3::from_matrix`] (Shepperd's method, then normalised), so
/// rounding noise of `f32` matrices is absorbed, but scale or shear is not detected; the
/// bottom row of a `Mat4` is not read.
macro_rules! glam_se3_conversions {
    ($t:ty, $gv3:ty, $gq:ty, $ga:ty, $gm4:ty) => {
        impl From<Se3<$t>> for $ga {
            fn from(x: Se3<$t>) -> Self {
                <$ga>::from_rotation_translation(
                    <$gq>::from(x.quat()),
                    <$gv3>::from(x.translation()),
                )
            }
        }
        impl From<$ga> for Se3<$t> {
            fn from(a: $ga) -> Self {
                Self::from(<$gm4>::from(a))
            }
        }
        impl From<Se3<$t>> for $gm4 {
            fn from(x: Se3<$t>) -> Self {
                <$gm4>::from_rotation_translation(
                    <$gq>::from(x.quat()),
                    <$gv3>::from(x.translation()),
                )
            }
        }
        /// glam is column-major: row `i` of the matrix is `m.row(i)`.
        impl From<$gm4> for Se3<$t> {
            fn from(m: $gm4) -> Self {
                Self::from_matrix(&core::array::from_fn(|i| m.row(i).to_array()))
            }
        }
    };
}

glam_se3_conversions!(f32, glam::Vec3, glam::Quat, glam::Affine3A, glam::Mat4);
glam_se3_conversions!(f64, glam::DVec3, glam::DQuat, glam::DAffine3, glam::DMat4);

#[cfg(test)]
mod tests {
    use crate::{Mat3, Quat, Se3, So3, Vec3, Vec6};

    #[test]
    fn se3_round_trips_and_same_action() {
        let x = Se3::exp(Vec6::from_array([0.4_f64, -1.1, 0.7, 0.9, -0.3, 1.6]));
        let p = Vec3::new(0.3, -2.0, 1.25);
        let gp = glam::DVec3::from(p);
        let a = glam::DAffine3::from(x);
        let m = glam::DMat4::from(x);
        assert!(
            (Vec3::from(a.transform_point3(gp)) - x.act(p)).norm() < 1e-14,
            "DAffine3 acts alike"
        );
        assert!(
            (Vec3::from(m.transform_point3(gp)) - x.act(p)).norm() < 1e-14,
            "DMat4 acts alike"
        );
        assert!(
            (m.to_cols_array_2d()[3][0] - x.translation().x).abs() < 1e-16,
            "translation in column 3"
        );
        for back in [Se3::from(a), Se3::from(m)] {
            assert!((back.log() - x.log()).norm() < 1e-14, "f64 round trip");
        }
        assert!(
            (Se3::from(glam::DMat4::from(x) * glam::DMat4::from(x.inverse()))
                .log()
                .norm())
                < 1e-14,
            "composition with the inverse"
        );
        let xf = x.cast::<f32>();
        let pf = Vec3::new(0.3_f32, -2.0, 1.25);
        for back in [
            Se3::from(glam::Affine3A::from(xf)),
            Se3::from(glam::Mat4::from(xf)),
        ] {
            let d = back.act(pf) - xf.act(pf);
            assert!(d.norm() < 1e-5, "f32 round trip");
            assert!((back.quat().norm() - 1.0).abs() < 1e-6, "unit quaternion");
        }
        let af = glam::Affine3A::from(xf);
        let d = Vec3::from(af.transform_point3(glam::Vec3::from(pf))) - xf.act(pf);
        assert!(d.norm() < 1e-5, "Affine3A acts alike");
    }

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
