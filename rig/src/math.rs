//! The numeric vocabulary every scanrig crate shares: `Real = f64` and nalgebra aliases.
//!
//! All lengths are millimetres unless a type says otherwise; angles in public APIs are degrees.

/// The scalar of every geometric quantity.
pub type Real = f64;
/// A point in 3-D (mm).
pub type Point3 = nalgebra::Point3<Real>;
/// A point in 2-D, e.g. a pixel position (px).
pub type Point2 = nalgebra::Point2<Real>;
/// A free vector in 3-D.
pub type Vector3 = nalgebra::Vector3<Real>;
/// A free vector in 2-D.
pub type Vector2 = nalgebra::Vector2<Real>;
/// A unit-length vector in 3-D (directions, normals).
pub type UnitVector3 = nalgebra::Unit<Vector3>;
/// A 3 × 3 matrix.
pub type Matrix3 = nalgebra::Matrix3<Real>;
/// A rotation in 3-D.
pub type Rotation3 = nalgebra::Rotation3<Real>;
/// A rigid transform (rotation then translation): `y = R·x + t`.
pub type Isometry3 = nalgebra::Isometry3<Real>;
/// A translation in 3-D.
pub type Translation3 = nalgebra::Translation3<Real>;
/// A rotation as a unit quaternion.
pub type UnitQuaternion = nalgebra::UnitQuaternion<Real>;

/// A rigid motion as the row-major 4 × 4 matrix that pose files and reports hold (the last row
/// 0 0 0 1).
pub fn rows_of(m: &Isometry3) -> [[Real; 4]; 4] {
    let h = m.to_homogeneous();
    std::array::from_fn(|r| std::array::from_fn(|c| h[(r, c)]))
}

/// The rigid motion a row-major 4 × 4 matrix holds; `None` where it is not one (a scale, a shear).
pub fn isometry_of(rows: &[[Real; 4]; 4]) -> Option<Isometry3> {
    nalgebra::try_convert(nalgebra::Matrix4::from_fn(|r, c| rows[r][c]))
}
