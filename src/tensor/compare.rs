//! Comparing stiffness tensors.

use super::Stiffness6;

/// Relative difference of `a` from the reference `b`: max_ab |a − b| / max_ab |b|
/// (entry-wise max norm of the Voigt matrices). When `b` is all zeros the result is 0 if
/// `a` is too and +∞ otherwise; any NaN entry makes the result NaN.
pub fn relative_difference(a: &Stiffness6, b: &Stiffness6) -> f64 {
    relative_difference_to(a, b, b)
}

/// max_ab |a − b| / max_ab |scale|: the difference of two tensors relative to a third (the
/// exact one, when two approximations are compared). Zero and NaN as
/// [`relative_difference`].
pub fn relative_difference_to(a: &Stiffness6, b: &Stiffness6, scale: &Stiffness6) -> f64 {
    let mut diff: f64 = 0.0;
    for (x, y) in a.iter().zip(b.iter()) {
        let d = (x - y).abs();
        if d.is_nan() {
            return f64::NAN;
        }
        diff = diff.max(d);
    }
    let scale = scale.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if scale > 0.0 {
        diff / scale
    } else if diff == 0.0 {
        0.0
    } else {
        f64::INFINITY
    }
}

/// A 6×6 tensor as row-major arrays.
pub fn rows(c: &Stiffness6) -> [[f64; 6]; 6] {
    std::array::from_fn(|i| std::array::from_fn(|j| c[(i, j)]))
}

/// A 6×6 tensor as row-major arrays, for JSON (`#[serde(serialize_with)]`).
pub fn matrix_rows<S: serde::Serializer>(
    c: &Stiffness6,
    s: S,
) -> std::result::Result<S::Ok, S::Error> {
    serde::Serialize::serialize(&rows(c), s)
}
