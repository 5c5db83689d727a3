//! Mirror transfer coefficients, eq. 33: after reparameterization by the reflection vector,
//! ρ̂_l = Y_l0(0) = Λ_l⁻¹, so Λ_l ρ̂_l = 1 for every l (B_lm = L_lm).

/// Λ_l ρ̂_l = 1, l = 0 … lmax.
pub fn mirror(lmax: usize) -> Vec<f64> {
    vec![1.0; lmax + 1]
}
