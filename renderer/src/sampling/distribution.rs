//! Discrete and piecewise-constant 1D/2D distributions (for environment-map importance sampling).
