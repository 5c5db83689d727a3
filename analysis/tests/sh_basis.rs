//! The SH basis: orthonormality by exact quadrature (l ≤ 30), the addition theorem (to l = 100),
//! and rotation (round trips, agreement with the projection of the rotated function, deltas).

use analysis::projection::project_function;
use analysis::quadrature::{gauss_legendre, legendre_all};
use analysis::sh::{Reconstructor, Rotation, ShBasis, index, lambda, num_coefficients, rotate_coefficients};
use std::f64::consts::PI;

/// SplitMix64, for deterministic test inputs (no dependency on the renderer).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e3779b97f4a7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn dir(&mut self) -> [f64; 3] {
        let z = 2.0 * self.next() - 1.0;
        let phi = 2.0 * PI * self.next();
        let s = (1.0 - z * z).sqrt();
        [s * phi.cos(), s * phi.sin(), z]
    }
}

#[test]
fn orthonormal_up_to_l30_by_exact_quadrature() {
    let lmax = 30;
    let n = num_coefficients(lmax);
    // Products Y·Y' have degree ≤ 60: 31 Gauss nodes in cos θ, 61+ uniform φ are exact.
    let (zs, ws) = gauss_legendre(lmax + 1);
    let nphi = 2 * lmax + 2;
    let basis = ShBasis::new(lmax);
    let mut gram = vec![0.0; n * n];
    let mut y = vec![0.0; n];
    for (z, wz) in zs.iter().zip(&ws) {
        let st = (1.0 - z * z).sqrt();
        for j in 0..nphi {
            let phi = 2.0 * PI * j as f64 / nphi as f64;
            basis.eval_into([st * phi.cos(), st * phi.sin(), *z], &mut y);
            let w = wz * 2.0 * PI / nphi as f64;
            for a in 0..n {
                let wa = w * y[a];
                for b in a..n {
                    gram[a * n + b] += wa * y[b];
                }
            }
        }
    }
    let mut worst = 0.0f64;
    for a in 0..n {
        for b in a..n {
            let e = if a == b { 1.0 } else { 0.0 };
            worst = worst.max((gram[a * n + b] - e).abs());
        }
    }
    assert!(worst < 1e-12, "max |<Y_a, Y_b> − δ_ab| = {worst}");
}

#[test]
fn addition_theorem_to_l100() {
    // Σ_m Y_lm(a) Y_lm(b) = (2l+1)/(4π) P_l(a·b), for every l ≤ 100.
    let lmax = 100;
    let basis = ShBasis::new(lmax);
    let mut rng = Rng(7);
    let mut p = vec![0.0; lmax + 1];
    for _ in 0..20 {
        let (a, b) = (rng.dir(), rng.dir());
        let (ya, yb) = (basis.eval(a), basis.eval(b));
        legendre_all(a[0] * b[0] + a[1] * b[1] + a[2] * b[2], &mut p);
        for l in 0..=lmax {
            let s: f64 = (-(l as i64)..=(l as i64)).map(|m| ya[index(l, m)] * yb[index(l, m)]).sum();
            let e = (2 * l + 1) as f64 / (4.0 * PI) * p[l];
            // Scale of the terms is (2l+1)/(4π); rounding grows slowly with l.
            assert!((s - e).abs() < 1e-11 * (2 * l + 1) as f64, "l={l}: {s} vs {e}");
        }
    }
}

#[test]
fn y_l0_at_the_pole_is_inverse_lambda_to_l100() {
    let basis = ShBasis::new(100);
    let y = basis.eval([0.0, 0.0, 1.0]);
    for l in 0..=100 {
        assert!((y[index(l, 0)] * lambda(l) - 1.0).abs() < 1e-13, "l={l}");
        for m in 1..=(l as i64) {
            assert_eq!(y[index(l, m)], 0.0);
            assert_eq!(y[index(l, -m)], 0.0);
        }
    }
}

fn random_coeffs(lmax: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = Rng(seed);
    (0..num_coefficients(lmax)).map(|_| [rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5]).collect()
}

#[test]
fn rotation_round_trip() {
    let c = random_coeffs(12, 3);
    let r = Rotation::from_xyz_deg([30.0, -50.0, 110.0]);
    let back = rotate_coefficients(&rotate_coefficients(&c, &r), &r.transpose());
    for k in 0..c.len() {
        for ch in 0..3 {
            assert!((back[k][ch] - c[k][ch]).abs() < 1e-12, "k={k}");
        }
    }
    // Composition: rotating by A then B equals rotating by BA.
    let a = Rotation::axis_angle([1.0, 2.0, 3.0], 0.7);
    let b = Rotation::axis_angle([-1.0, 0.5, 0.0], 2.1);
    let ab = rotate_coefficients(&rotate_coefficients(&c, &a), &b);
    let ba = rotate_coefficients(&c, &b.mul(&a));
    for k in 0..c.len() {
        for ch in 0..3 {
            assert!((ab[k][ch] - ba[k][ch]).abs() < 1e-12, "k={k}");
        }
    }
}

#[test]
fn rotated_coefficients_equal_projection_of_rotated_function() {
    let lmax = 8;
    let c = random_coeffs(lmax, 11);
    let r = Rotation::from_xyz_deg([10.0, 75.0, -20.0]);
    let rot = rotate_coefficients(&c, &r);
    let rt = r.transpose();
    let proj = project_function(lmax, 24, |d| {
        let mut rec = Reconstructor::new(lmax);
        rec.eval(&c, rt.apply(d))
    });
    for k in 0..c.len() {
        for ch in 0..3 {
            assert!((rot[k][ch] - proj[k][ch]).abs() < 1e-12, "k={k}: {} vs {}", rot[k][ch], proj[k][ch]);
        }
    }
    // Per order, rotation preserves energy (the D^l are orthogonal, eq. 3).
    for l in 0..=lmax {
        let e = |v: &[[f64; 3]]| (-(l as i64)..=(l as i64)).map(|m| v[index(l, m)][0].powi(2)).sum::<f64>();
        assert!((e(&c) - e(&rot)).abs() < 1e-12);
    }
}

#[test]
fn rotation_matrices_are_orthogonal_and_match_coefficient_rotation() {
    let lmax = 10;
    let r = Rotation::from_xyz_deg([25.0, -70.0, 140.0]);
    let d = analysis::sh::rotation_matrices(lmax, &r);
    let c = random_coeffs(lmax, 17);
    let rot = rotate_coefficients(&c, &r);
    for (l, dl) in d.iter().enumerate() {
        let s = 2 * l + 1;
        // D Dᵀ = I (rotations are orthogonal within each order; eq. 3 mixes only m).
        for a in 0..s {
            for b in 0..s {
                let v: f64 = (0..s).map(|k| dl[a * s + k] * dl[b * s + k]).sum();
                assert!((v - if a == b { 1.0 } else { 0.0 }).abs() < 1e-12, "l={l}");
            }
        }
        for a in 0..s {
            let v: f64 = (0..s).map(|b| dl[a * s + b] * c[l * l + b][0]).sum();
            assert!((v - rot[l * l + a][0]).abs() < 1e-12, "l={l}");
        }
    }
    // Eq. 4: D^l_m0 for the rotation taking +z to direction u equals Λ_l Y_lm(u).
    let u = [0.6, 0.0, 0.8];
    let ry = Rotation::axis_angle([0.0, 1.0, 0.0], 0.6f64.atan2(0.8));
    let dy = analysis::sh::rotation_matrices(lmax, &ry);
    let yu = ShBasis::new(lmax).eval(u);
    for (l, dl) in dy.iter().enumerate() {
        let s = 2 * l + 1;
        for a in 0..s {
            assert!((dl[a * s + l] - lambda(l) * yu[l * l + a]).abs() < 1e-12, "l={l} a={a}");
        }
    }
}

#[test]
fn rotating_a_delta_moves_it() {
    // A delta at d has coefficients Y(d); rotated by R it is a delta at R d.
    let lmax = 20;
    let basis = ShBasis::new(lmax);
    let d = [0.36, -0.48, 0.8];
    let c: Vec<[f64; 3]> = basis.eval(d).into_iter().map(|y| [y, 2.0 * y, 0.0]).collect();
    let r = Rotation::from_xyz_deg([0.0, 90.0, 45.0]);
    let rot = rotate_coefficients(&c, &r);
    let expect = basis.eval(r.apply(d));
    for k in 0..c.len() {
        assert!((rot[k][0] - expect[k]).abs() < 1e-11, "k={k}");
        assert!((rot[k][1] - 2.0 * expect[k]).abs() < 1e-11, "k={k}");
    }
}
