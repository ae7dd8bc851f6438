//! nalgebra interop: `From` conversions both ways, generic over the scalar.

use crate::{Mat3, Quat, Real, Se3, So3, Vec2, Vec3};

impl<T: Real + nalgebra::Scalar> From<nalgebra::Vector2<T>> for Vec2<T> {
    fn from(v: nalgebra::Vector2<T>) -> Self {
        Self::new(v[0], v[1])
    }
}
impl<T: Real + nalgebra::Scalar> From<Vec2<T>> for nalgebra::Vector2<T> {
    fn from(v: Vec2<T>) -> Self {
        Self::new(v.x, v.y)
    }
}
impl<T: Real + nalgebra::Scalar> From<nalgebra::Vector3<T>> for Vec3<T> {
    fn from(v: nalgebra::Vector3<T>) -> Self {
        Self::new(v[0], v[1], v[2])
    }
}
impl<T: Real + nalgebra::Scalar> From<Vec3<T>> for nalgebra::Vector3<T> {
    fn from(v: Vec3<T>) -> Self {
        Self::new(v.x, v.y, v.z)
    }
}
/// nalgebra's `Quaternion::new(w, i, j, k)` puts w first, like evogs (its storage is
/// `[i, j, k, w]`, which the conversion handles through the named accessors).
impl<T: Real + nalgebra::Scalar> From<nalgebra::Quaternion<T>> for Quat<T> {
    fn from(q: nalgebra::Quaternion<T>) -> Self {
        Self::new(q.coords[3], q.coords[0], q.coords[1], q.coords[2])
    }
}
impl<T: Real + nalgebra::Scalar> From<Quat<T>> for nalgebra::Quaternion<T> {
    fn from(q: Quat<T>) -> Self {
        Self::new(q.w, q.x, q.y, q.z)
    }
}
/// `Matrix3::new` takes its arguments in row-major order; entries are copied by (row, col).
impl<T: Real + nalgebra::Scalar> From<nalgebra::Matrix3<T>> for Mat3<T> {
    fn from(m: nalgebra::Matrix3<T>) -> Self {
        let mut r = Self::zero();
        for i in 0..3 {
            for j in 0..3 {
                r.m[i][j] = m[(i, j)];
            }
        }
        r
    }
}
impl<T: Real + nalgebra::Scalar> From<Mat3<T>> for nalgebra::Matrix3<T> {
    fn from(m: Mat3<T>) -> Self {
        Self::from_fn(|i, j| m.m[i][j])
    }
}

/// An `Isometry3` (unit quaternion and translation) is an SE(3) transform: the same
/// `p ↦ R p + t`. The quaternion is copied as it is (nalgebra keeps it unit).
impl<T: Real + nalgebra::Scalar> From<nalgebra::Isometry3<T>> for Se3<T> {
    fn from(m: nalgebra::Isometry3<T>) -> Self {
        let q = Quat::from(m.rotation.into_inner());
        Self::from_parts(So3::from_unit_quat(q), Vec3::from(m.translation.vector))
    }
}
impl<T: Real + nalgebra::Scalar> From<Se3<T>> for nalgebra::Isometry3<T> {
    fn from(x: Se3<T>) -> Self {
        Self {
            rotation: nalgebra::Unit::new_unchecked(nalgebra::Quaternion::from(x.quat())),
            translation: nalgebra::Translation3::from(nalgebra::Vector3::from(x.translation())),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::so3::{exp_matrix, exp_quat};
    use crate::{Mat3, Quat, Se3, Vec3, Vec6};

    #[test]
    fn round_trips() {
        let v2 = crate::Vec2::new(0.25_f64, -1.5);
        let n2 = nalgebra::Vector2::from(v2);
        assert_eq!(
            (n2[0], n2[1]),
            (0.25, -1.5),
            "vec2 to nalgebra, component by component"
        );
        assert_eq!(crate::Vec2::from(n2), v2, "vec2 round trip");
        let v = Vec3::new(0.25_f64, -1.5, 3.0);
        assert_eq!(Vec3::from(nalgebra::Vector3::from(v)), v, "vec3 round trip");
        let q = Quat::new(0.8_f32, 0.1, -0.5, 0.3);
        assert_eq!(
            Quat::from(nalgebra::Quaternion::from(q)),
            q,
            "quat round trip"
        );
        let m = Mat3::from_rows([[1.0_f64, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]]);
        let nm = nalgebra::Matrix3::from(m);
        assert!((nm[(1, 0)] - 4.0).abs() < 1e-16, "row 1, col 0");
        assert_eq!(Mat3::from(nm), m, "mat3 round trip");
    }

    #[test]
    fn isometry_round_trip_and_same_action() {
        let x = Se3::exp(Vec6::from_array([0.4_f64, -1.1, 0.7, 0.9, -0.3, 1.6]));
        let iso = nalgebra::Isometry3::from(x);
        assert_eq!(Se3::from(iso), x, "isometry round trip");
        let p = Vec3::new(0.3, -2.0, 1.25);
        let theirs: Vec3<f64> = (iso * nalgebra::Point3::from(nalgebra::Vector3::from(p)))
            .coords
            .into();
        assert!((theirs - x.act(p)).norm() < 1e-15, "same action on points");
        let composed = Se3::from(iso * iso.inverse() * iso);
        assert!((composed.log() - x.log()).norm() < 1e-14, "composition");
        let xf = x.cast::<f32>();
        assert_eq!(
            Se3::from(nalgebra::Isometry3::from(xf)),
            xf,
            "f32 round trip"
        );
    }

    #[test]
    fn nalgebra_is_an_oracle_for_exp() {
        let mut rng = crate::rng::SplitMix64::new(21);
        for _ in 0..200 {
            let scale = 10f64.powf(rng.uniform(-9.0, 0.5));
            let phi = Vec3::new(rng.normal(), rng.normal(), rng.normal()) * scale;
            let uq = nalgebra::UnitQuaternion::from_scaled_axis(nalgebra::Vector3::from(phi));
            let theirs = Quat::from(*uq.quaternion());
            let ours = exp_quat(phi);
            let d = if theirs.dot(ours) < 0.0 {
                theirs + ours
            } else {
                theirs - ours
            };
            assert!(d.norm() < 1e-15, "exp_quat vs nalgebra at {phi:?}");
            let rm: Mat3<f64> = uq.to_rotation_matrix().into_inner().into();
            assert!(
                (rm - exp_matrix(phi)).max_abs() < 1e-15,
                "exp_matrix vs nalgebra"
            );
        }
    }
}
