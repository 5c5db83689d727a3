//! Warps from the unit square to directions (cosine hemisphere, cones, spheres, …).
