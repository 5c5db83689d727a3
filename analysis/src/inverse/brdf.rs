//! Inverse BRDF (eq. 16): placeholder, filled in below.
