//! Tiny dense linear algebra for the estimators (systems of at most ~10 unknowns): Gaussian
//! elimination, inversion, and a symmetric Jacobi eigen-solver. Kept local so the estimators do not
//! need a linear-algebra crate.

// Index loops mirror the textbook row/column formulas; iterator rewrites obscure them.
#![allow(clippy::needless_range_loop)]

/// Solves `a x = b` by Gaussian elimination with partial pivoting; `None` when `a` is singular
/// (pivot below `1e-13` times the largest entry).
pub fn solve(a: &[Vec<f64>], b: &[f64]) -> Option<Vec<f64>> {
    let mut m: Vec<Vec<f64>> = a.to_vec();
    let mut x: Vec<f64> = b.to_vec();
    solve_in_place(&mut m, &mut x)?;
    Some(x)
}

/// [`solve`] on rows of any storage, overwriting `m` and leaving the solution in `x`: the same
/// operations in the same order for heap rows and fixed-size ones, so both give the same bits.
fn solve_in_place<R: AsRef<[f64]> + AsMut<[f64]>>(m: &mut [R], x: &mut [f64]) -> Option<()> {
    let n = x.len();
    let scale = m
        .iter()
        .flat_map(|r| r.as_ref().iter())
        .fold(0.0_f64, |s, v| s.max(v.abs()));
    if !scale.is_finite() || scale <= 0.0 {
        return None;
    }
    let at = |m: &[R], r: usize, c: usize| m[r].as_ref()[c];
    for col in 0..n {
        let piv = (col..n).max_by(|&i, &j| at(m, i, col).abs().total_cmp(&at(m, j, col).abs()))?;
        if at(m, piv, col).abs() <= 1e-13 * scale {
            return None;
        }
        m.swap(col, piv);
        x.swap(col, piv);
        for row in col + 1..n {
            let f = at(m, row, col) / at(m, col, col);
            if f != 0.0 {
                let (above, below) = m.split_at_mut(row);
                let (pivot_row, target) = (above[col].as_ref(), below[0].as_mut());
                for k in col..n {
                    target[k] -= f * pivot_row[k];
                }
                x[row] -= f * x[col];
            }
        }
    }
    for col in (0..n).rev() {
        let s: f64 = (col + 1..n).map(|k| at(m, col, k) * x[k]).sum();
        x[col] = (x[col] - s) / at(m, col, col);
    }
    Some(())
}

/// Inverse of a square matrix, column by column; `None` when singular.
pub fn invert(a: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let n = a.len();
    let mut inv = vec![vec![0.0; n]; n];
    for c in 0..n {
        let mut e = vec![0.0; n];
        e[c] = 1.0;
        let col = solve(a, &e)?;
        for r in 0..n {
            inv[r][c] = col[r];
        }
    }
    Some(inv)
}

/// [`invert`] of a fixed-size matrix without a heap allocation, the same bits (a Kalman
/// smoother inverts a 3×3 covariance at every sample of every track it smooths). Not
/// [`invert3`]: cofactors round differently from the elimination, and a speed-up must leave
/// every output bit as it was.
pub fn invert_fixed<const N: usize>(a: &[[f64; N]; N]) -> Option<[[f64; N]; N]> {
    let mut inv = [[0.0; N]; N];
    for c in 0..N {
        let mut m = *a;
        let mut col = [0.0; N];
        col[c] = 1.0;
        solve_in_place(&mut m, &mut col)?;
        for r in 0..N {
            inv[r][c] = col[r];
        }
    }
    Some(inv)
}

/// Inverse of a 3×3 matrix by cofactors; `None` when the determinant is not finite or below
/// 1e-12 × (largest entry)³.
pub fn invert3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let c =
        |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let cof = [
        [c(1, 2, 1, 2), -c(1, 2, 0, 2), c(1, 2, 0, 1)],
        [-c(0, 2, 1, 2), c(0, 2, 0, 2), -c(0, 2, 0, 1)],
        [c(0, 1, 1, 2), -c(0, 1, 0, 2), c(0, 1, 0, 1)],
    ];
    let det = m[0][0] * cof[0][0] + m[0][1] * cof[0][1] + m[0][2] * cof[0][2];
    let scale = m.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
    if !det.is_finite() || det.abs() <= 1e-12 * scale.powi(3) {
        return None;
    }
    // The inverse is the transposed cofactor matrix over the determinant.
    let mut inv = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            inv[i][j] = cof[j][i] / det;
        }
    }
    Some(inv)
}

/// Eigen-decomposition of a symmetric matrix by cyclic Jacobi rotations.
/// Returns (eigenvalues, eigenvectors as columns `v[r][k]` for eigenvalue `k`).
pub fn sym_eigen(a: &[Vec<f64>]) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = a.len();
    let mut m = a.to_vec();
    let mut v = vec![vec![0.0; n]; n];
    for (i, row) in v.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for _sweep in 0..100 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| m[i][j] * m[i][j])
            .sum();
        if off < 1e-30 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                if m[p][q].abs() < 1e-300 {
                    continue;
                }
                let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let mkp = m[k][p];
                    let mkq = m[k][q];
                    m[k][p] = c * mkp - s * mkq;
                    m[k][q] = s * mkp + c * mkq;
                }
                for k in 0..n {
                    let mpk = m[p][k];
                    let mqk = m[q][k];
                    m[p][k] = c * mpk - s * mqk;
                    m[q][k] = s * mpk + c * mqk;
                }
                for row in v.iter_mut() {
                    let vkp = row[p];
                    let vkq = row[q];
                    row[p] = c * vkp - s * vkq;
                    row[q] = s * vkp + c * vkq;
                }
            }
        }
    }
    ((0..n).map(|i| m[i][i]).collect(), v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn a_fixed_size_inverse_is_the_heap_inverse_bit_for_bit(seed in any::<u64>()) {
            use rand::Rng;
            let mut rng = crate::rng::stream(seed, crate::rng::Stream::MonteCarlo, 1);
            // Entries over many decades, exact zeros, repeated values (ties between pivots)
            // and now and then a repeated row (singular): every branch of the elimination.
            let palette = [0.0, -0.0, 1.0, -1.0, 2.5];
            let mut a = [[0.0f64; 3]; 3];
            for row in a.iter_mut() {
                for v in row.iter_mut() {
                    *v = match rng.gen_range(0..6) {
                        0 | 1 => palette[rng.gen_range(0..palette.len())],
                        _ => rng.gen_range(-1.0..1.0) * 10f64.powi(rng.gen_range(-6..7)),
                    };
                }
            }
            if rng.gen_range(0..5) == 0 {
                a[2] = a[0];
            }
            let heap: Vec<Vec<f64>> = a.iter().map(|r| r.to_vec()).collect();
            let bits = |m: Option<Vec<Vec<f64>>>| {
                m.map(|m| m.into_iter().flatten().map(f64::to_bits).collect::<Vec<u64>>())
            };
            let fixed = invert_fixed(&a).map(|m| m.iter().map(|r| r.to_vec()).collect());
            prop_assert_eq!(bits(fixed), bits(invert(&heap)));
        }
    }

    #[test]
    fn solve_and_invert_known_system() {
        let a = vec![
            vec![2.0, 1.0, 0.0],
            vec![1.0, 3.0, 1.0],
            vec![0.0, 1.0, 4.0],
        ];
        let x_true = [1.0, -2.0, 0.5];
        let b: Vec<f64> = a
            .iter()
            .map(|r| r.iter().zip(&x_true).map(|(p, q)| p * q).sum())
            .collect();
        let x = solve(&a, &b).unwrap();
        for (p, q) in x.iter().zip(&x_true) {
            assert!((p - q).abs() < 1e-12);
        }
        let inv = invert(&a).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let s: f64 = (0..3).map(|k| a[i][k] * inv[k][j]).sum();
                assert!((s - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12);
            }
        }
        assert!(solve(&[vec![1.0, 2.0], vec![2.0, 4.0]], &[1.0, 2.0]).is_none());
    }

    #[test]
    fn jacobi_reconstructs_matrix() {
        let a = vec![
            vec![4.0, 1.0, 2.0],
            vec![1.0, 3.0, 0.5],
            vec![2.0, 0.5, 1.0],
        ];
        let (w, v) = sym_eigen(&a);
        for i in 0..3 {
            for j in 0..3 {
                let s: f64 = (0..3).map(|k| v[i][k] * w[k] * v[j][k]).sum();
                assert!((s - a[i][j]).abs() < 1e-10);
            }
        }
    }
}
