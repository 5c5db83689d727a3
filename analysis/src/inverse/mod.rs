//! Inverse rendering in frequency space (paper sec. 2.2 and sec. 3): what the reflection equation
//! B_lm = Λ_l ρ̂_l L_lm (eq. 15) lets one recover from images, and how well.
//!
//! - [`lighting`]: inverse lighting (eq. 17), L_lm = B_lm / (Λ_l ρ̂_l) per order with standard
//!   errors, noise amplification, a recovered / ill-conditioned / unobservable classification and a
//!   Tikhonov-regularised reconstruction whose λ is chosen by a stated rule.
//! - [`brdf`]: inverse BRDF (eq. 16), Λ_l ρ̂_l per order from B_lm and L_lm, and a weighted
//!   least-squares fit of the Phong exponent s (eq. 43) or the Torrance–Sparrow σ (eq. 50) with a
//!   confidence interval from the χ² profile (Δχ² = 1).
//! - [`factorization`]: factoring the 4D reflected light field into lighting and BRDF up to a
//!   global scale (eq. 18, 23): L_lm / P = M_lm / (Λ_l κ_l) from the exitance map (B̃_lm00) and the
//!   normal-averaged outgoing profile (B̃_00l0), ambiguous (0/0) orders where κ_l = 0.
//! - [`views`]: inverse lighting fitted in pixel space from views that see part of the sphere, with
//!   the conditioning of the actual design, the truncation bias and χ²/ν (issue 16).
//! - [`separation`]: diffuse + specular separation (sec. 3.5, reference \[17\]): subtract the 9-term
//!   diffuse part, recover the high-frequency lighting from the specular part, and test the
//!   consistency of the low orders of both sides (which also fixes the k_d : k_s split).

pub mod brdf;
pub mod factorization;
pub mod lighting;
pub mod separation;
pub mod views;
