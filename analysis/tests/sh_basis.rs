//! The SH basis: orthonormality by exact quadrature (l ≤ 30), the addition theorem (to l = 100),
//! and rotation (round trips, agreement with the projection of the rotated function, deltas).

mod common;
use analysis::projection::project_function;
use analysis::quadrature::{gauss_legendre, legendre_all};
use analysis::sh::{Reconstructor, Rotation, ShBasis, index, lambda, num_coefficients, rotate_coefficients};
use common::Rng;
use std::f64::consts::PI;

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

/// Y_lm pinned against values computed outside this code base, for l = 3…6 (every m) and a few
/// (l, m) up to l = 100: exact rational arithmetic in Python (`fractions`): P_l^m by Rodrigues'
/// formula (no Condon–Shortley phase), cos mφ / sin mφ by exact complex powers, K_lm² exact, and one
/// 80-digit square root at the end. The direction has rational coordinates: cos θ = 3/5, sin θ = 4/5,
/// cos φ = 5/13, sin φ = 12/13. (l ≤ 2 is pinned by the docs/src/conventions.md §3 check values in analysis/src/sh/basis.rs.) A sign,
/// phase, normalization or index error at any order fails here even if it cancels everywhere else.
#[test]
fn basis_pinned_to_independent_values_up_to_l100() {
    let (st, z) = (0.8, 0.6);
    let dir = [st * 5.0 / 13.0, st * 12.0 / 13.0, z];
    let y = ShBasis::new(100).eval(dir);
    let pinned: [(usize, i64, f64); 51] = [
        (3, -3, -0.11385558458768391),
        (3, -2, 0.3940809919434223),
        (3, -1, 0.2700085953759305),
        (3, 0, -0.2686869594648831),
        (3, 1, 0.11250358140663771),
        (3, 2, -0.3907969836772271),
        (3, 3, -0.2798262254057207),
        (4, -4, -0.2563333419829103),
        (4, -3, -0.20494005225783105),
        (4, -2, 0.32678298604720274),
        (4, -1, -0.14229076027901486),
        (4, 0, -0.34528402513122686),
        (4, 1, -0.05928781678292286),
        (4, 2, -0.3240597944968094),
        (4, 3, -0.5036872057302972),
        (4, 4, -0.00214508644026315),
        (5, -5, -0.08438281928782537),
        (5, -4, -0.5100969099691014),
        (5, -3, -0.21146510244379443),
        (5, -2, 0.05228075149149604),
        (5, -1, -0.4409832848761158),
        (5, 0, -0.14281037775432462),
        (5, 1, -0.18374303536504824),
        (5, 2, -0.05184507856240024),
        (5, 3, -0.5197240138564272),
        (5, 4, -0.004268668119139189),
        (5, 5, 0.19783921216241426),
        (6, -6, 0.12503808327948204),
        (6, -5, -0.18254794902627963),
        (6, -4, -0.6117211398744983),
        (6, -3, -0.10238801729134543),
        (6, -2, -0.25184814237122405),
        (6, -1, -0.39320811000599554),
        (6, 0, 0.17504008693519651),
        (6, 1, -0.16383671250249815),
        (6, 2, 0.24974940785146388),
        (6, 3, -0.2516420473283671),
        (6, 4, -0.005119094973039393),
        (6, 5, 0.4279916542493901),
        (6, 6, 0.128217167901694),
        (10, 0, -0.3149878839390698),
        (10, 7, -0.24321479361683507),
        (10, -3, 0.03042822123719489),
        (20, 5, -0.0780782479413278),
        (31, -31, -0.0009431838940565495),
        (50, 0, -0.16687139894779965),
        (50, 25, -0.17759789161567602),
        (100, 0, -0.09497346567630512),
        (100, 1, -0.1867502699818028),
        (100, -50, 0.19036340280930011),
        (100, 100, -5.679955351528153e-11),
    ];
    for (l, m, v) in pinned {
        // Recurrences lose a few ulp per order: 1e-12 relative to the order's typical size √((2l+1)/4π).
        let tol = 1e-12 * ((2 * l + 1) as f64 / (4.0 * PI)).sqrt();
        let got = y[index(l, m)];
        assert!((got - v).abs() <= tol, "Y_{l},{m}: {got:.17e} vs {v:.17e}");
    }
}
