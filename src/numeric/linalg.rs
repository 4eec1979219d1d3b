//! Dense linear algebra on `nalgebra` matrices: solving and inverting square systems (LU with
//! partial pivoting) with one singularity rule, the symmetric eigen-decomposition, and the
//! normal equations of a least-squares Jacobian.
//!
//! The singularity rule: a system is singular when a pivot of its LU factorisation is not
//! finite or is at most 1e-13 times the largest |entry| of the matrix. A solve or inverse of a
//! singular system is `None`, so fits say "not determined" instead of returning noise.

use nalgebra::{DMatrix, DVector};

/// A pivot at most this many times the largest |entry| makes a matrix singular.
const RELATIVE_PIVOT_MIN: f64 = 1e-13;

/// A matrix from its rows (`rows[r][c]`); `None` when the rows differ in length.
pub fn from_rows(rows: &[Vec<f64>]) -> Option<DMatrix<f64>> {
    let cols = rows.first().map_or(0, Vec::len);
    rows.iter()
        .all(|r| r.len() == cols)
        .then(|| DMatrix::from_fn(rows.len(), cols, |r, c| rows[r][c]))
}

/// The LU factorisation of square `a` when it is not singular (see the module's rule).
fn lu_of(a: &DMatrix<f64>) -> Option<nalgebra::linalg::LU<f64, nalgebra::Dyn, nalgebra::Dyn>> {
    if !a.is_square() {
        return None;
    }
    let scale = a.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
    if !scale.is_finite() || scale <= 0.0 {
        return None;
    }
    let lu = a.clone().lu();
    let pivots_ok = lu
        .u()
        .diagonal()
        .iter()
        .all(|p| p.is_finite() && p.abs() > RELATIVE_PIVOT_MIN * scale);
    pivots_ok.then_some(lu)
}

/// Solves `a x = b` (LU with partial pivoting); `None` when `a` is singular or not square, or
/// `b` is of another length.
pub fn solve(a: &DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    if b.len() != a.nrows() {
        return None;
    }
    lu_of(a)?.solve(b)
}

/// [`solve`] of a system given as rows and a right-hand side slice.
pub fn solve_rows(a: &[Vec<f64>], b: &[f64]) -> Option<Vec<f64>> {
    let x = solve(&from_rows(a)?, &DVector::from_column_slice(b))?;
    Some(x.iter().copied().collect())
}

/// The inverse of square `a`; `None` when singular.
pub fn invert(a: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    lu_of(a)?.try_inverse()
}

/// [`invert`] of a matrix given as rows, returned as rows.
pub fn invert_rows(a: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let inv = invert(&from_rows(a)?)?;
    Some(
        (0..inv.nrows())
            .map(|r| inv.row(r).iter().copied().collect())
            .collect(),
    )
}

/// The inverse of a 3×3 matrix (rows `m[r][c]`); `None` when singular.
pub fn invert3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let inv = invert(&DMatrix::from_fn(3, 3, |r, c| m[r][c]))?;
    Some(std::array::from_fn(|r| {
        std::array::from_fn(|c| inv[(r, c)])
    }))
}

/// Eigen-decomposition of a symmetric matrix: (eigenvalues, eigenvectors as the columns of the
/// matrix, column k for eigenvalue k), in no particular order.
pub fn sym_eigen(a: &DMatrix<f64>) -> (DVector<f64>, DMatrix<f64>) {
    let e = a.clone().symmetric_eigen();
    (e.eigenvalues, e.eigenvectors)
}

/// JᵀJ and Jᵀr of a Jacobian `jac` (one row per residual, one column per parameter) and the
/// residuals `r`.
pub fn normal_equations(jac: &DMatrix<f64>, r: &DVector<f64>) -> (DMatrix<f64>, DVector<f64>) {
    (jac.tr_mul(jac), jac.tr_mul(r))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;
    use proptest::prelude::*;

    #[test]
    fn solve_and_invert_a_known_system() {
        let a = from_rows(&[
            vec![4.0, 1.0, 2.0],
            vec![1.0, 3.0, 0.0],
            vec![2.0, 0.0, 5.0],
        ])
        .unwrap();
        let x = solve(&a, &DVector::from_column_slice(&[7.0, 4.0, 7.0])).unwrap();
        for (got, want) in x.iter().zip([1.0, 1.0, 1.0]) {
            assert!((got - want).abs() < 1e-12, "{x}");
        }
        let inv = invert(&a).unwrap();
        let eye = &a * &inv;
        for r in 0..3 {
            for c in 0..3 {
                let want = if r == c { 1.0 } else { 0.0 };
                assert!((eye[(r, c)] - want).abs() < 1e-12);
            }
        }
        assert_eq!(
            solve_rows(&[vec![2.0, 0.0], vec![0.0, 4.0]], &[2.0, 2.0]),
            Some(vec![1.0, 0.5])
        );
    }

    #[test]
    fn singular_and_malformed_systems_are_refused() {
        let singular = from_rows(&[vec![1.0, 2.0], vec![2.0, 4.0]]).unwrap();
        assert!(invert(&singular).is_none());
        assert!(solve(&singular, &DVector::from_column_slice(&[1.0, 2.0])).is_none());
        // Nearly singular at the relative rule: a pivot of 1e-14 beside entries of 1.
        let near = from_rows(&[vec![1.0, 1.0], vec![1.0, 1.0 + 1e-14]]).unwrap();
        assert!(invert(&near).is_none());
        assert!(invert(&DMatrix::zeros(2, 2)).is_none());
        assert!(invert(&DMatrix::from_element(2, 2, f64::NAN)).is_none());
        assert!(from_rows(&[vec![1.0], vec![1.0, 2.0]]).is_none());
        assert!(solve_rows(&[vec![1.0, 0.0], vec![0.0, 1.0]], &[1.0]).is_none());
        assert!(invert3(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]).is_none());
    }

    #[test]
    fn symmetric_eigenvectors_diagonalise_the_matrix() {
        let a = from_rows(&[
            vec![2.0, 1.0, 0.0],
            vec![1.0, 2.0, 1.0],
            vec![0.0, 1.0, 2.0],
        ])
        .unwrap();
        let (w, v) = sym_eigen(&a);
        let mut sorted: Vec<f64> = w.iter().copied().collect();
        sorted.sort_by(f64::total_cmp);
        let s2 = 2f64.sqrt();
        for (got, want) in sorted.iter().zip([2.0 - s2, 2.0, 2.0 + s2]) {
            assert!((got - want).abs() < 1e-12);
        }
        for k in 0..3 {
            let col = v.column(k);
            assert!(((&a * col) - col * w[k]).norm() < 1e-12);
        }
    }

    proptest! {
        #[test]
        fn an_inverse_times_its_matrix_is_the_identity(
            entries in proptest::collection::vec(-10.0f64..10.0, 9),
        ) {
            let m = [
                [entries[0], entries[1], entries[2]],
                [entries[3], entries[4], entries[5]],
                [entries[6], entries[7], entries[8]],
            ];
            let a = Matrix3::from_fn(|r, c| m[r][c]);
            if let Some(inv) = invert3(&m) {
                let inv = Matrix3::from_fn(|r, c| inv[r][c]);
                let cond = a.norm() * inv.norm();
                let err = (a * inv - Matrix3::identity()).norm();
                prop_assert!(err <= 1e-12 * cond.max(1.0), "{err} at condition {cond}");
            } else {
                prop_assert!(a.determinant().abs() <= 1e-9 * a.norm().powi(3));
            }
        }

        #[test]
        fn the_normal_equations_are_the_products_of_the_jacobian(
            p in 1usize..6,
            n in 1usize..12,
            seed in any::<u64>(),
        ) {
            use rand::Rng;
            let mut rng = crate::rng::stream(seed, crate::rng::Stream::MonteCarlo, 0);
            let jac = DMatrix::from_fn(n, p, |_, _| rng.gen_range(-1.0..1.0));
            let r = DVector::from_fn(n, |_, _| rng.gen_range(-1.0..1.0));
            let (jtj, jtr) = normal_equations(&jac, &r);
            for i in 0..p {
                let want: f64 = (0..n).map(|k| jac[(k, i)] * r[k]).sum();
                prop_assert!((jtr[i] - want).abs() < 1e-12);
                for j in 0..p {
                    let want: f64 = (0..n).map(|k| jac[(k, i)] * jac[(k, j)]).sum();
                    prop_assert!((jtj[(i, j)] - want).abs() < 1e-12);
                }
            }
        }
    }
}
