//! Unidirectional path tracer, batched: the samples of a pixel are traced [`LANES`] at a time,
//! stage by stage over the batch (a wavefront within one pixel's batch; Laine, Karras and Aila
//! 2013, "Megakernels considered harmful", at the scale of 8 paths).
//!
//! At every vertex: next-event estimation (one light sample) and one BRDF sample, combined by
//! multiple importance sampling with the power heuristic (Veach 1997); Russian roulette after
//! `RR_START` vertices; at most `max_depth` surface vertices. Light is distant, so a light sample
//! is a direction and its shadow ray is infinite.
//!
//! Visibility: a scene made of a single sphere cannot shadow itself in any direction above the
//! local horizon, so shadow rays are skipped there (exact, and the common case of the paper).
//! Directions below the horizon only reach a BRDF with `horizon = "ignore"` (the paper's
//! simplification, docs/src/conventions.md §4): they gather the distant light unoccluded by definition.

// Lane loops read and write several lane arrays at index k.
#![allow(clippy::needless_range_loop)]

use crate::brdf::{BrdfSamples, Bxdf, Outgoing};
use crate::camera::PrimarySample;
use crate::geometry::bvh::PACKET;
use crate::geometry::shading::adapt_shading_normal;
use crate::geometry::{Hit, Ray};
use crate::light::{DistantLight, LightSamples};
use crate::math::{Rgb, Vec2, Vec3};
use crate::sampling::{LANES, Sampler};
use crate::scene::Scene;
use crate::simd::{Float, Float3, Frames, Isa, Mask, Sse2};

/// Russian roulette starts after this many vertices (the first bounces are never cut).
pub(super) const RR_START: u32 = 3;

/// What one primary sample returns.
#[derive(Clone, Copy, Debug, Default)]
pub struct SampleResult {
    pub radiance: Rgb,
    /// World-space shading normal of the first hit (zero on a miss).
    pub normal: Vec3,
    pub hit: bool,
    /// Rays traced (camera, bounce and shadow rays) for throughput statistics.
    pub rays: u32,
}

pub struct PathTracer<'a> {
    pub(super) scene: &'a Scene,
    pub(super) max_depth: u32,
    /// True when no geometry can occlude a direction above a hit's horizon.
    pub(super) single_convex: bool,
    /// True when some object has an albedo texture.
    textured: bool,
}

/// Offset along the geometric normal to keep secondary rays off their own surface, scaled with
/// the magnitude of the position (f32 rounding grows with it). The one-lane call of
/// [`offset_origins`].
#[inline]
#[cfg(test)]
pub(crate) fn offset_origin(p: Vec3, ng: Vec3, dir: Vec3) -> Vec3 {
    offset_origins::<1, Sse2>(Float3::splat(p), Float3::splat(ng), Float3::splat(dir)).lane(0)
}

/// [`offset_origin`] of each lane: `p ± ε n_g` toward the side of `dir`, ε = 10⁻⁴ (1 + max |p_i|).
#[inline(always)]
pub(crate) fn offset_origins<const N: usize, S: Isa>(
    p: Float3<N, S>,
    ng: Float3<N, S>,
    dir: Float3<N, S>,
) -> Float3<N, S> {
    let a = Float3::new(p.x.abs(), p.y.abs(), p.z.abs());
    let eps = (a.y.max(a.z).max(a.x) + 1.0) * 1e-4;
    let shift = ng * eps;
    Float3::select(ng.dot(dir).ge(Float::ZERO), p + shift, p - shift)
}

/// The power heuristic (β = 2, Veach 1997) of each lane: a² / (a² + b²), 0 where both densities
/// are 0.
#[inline(always)]
fn power_heuristics<const N: usize, S: Isa>(a: Float<N, S>, b: Float<N, S>) -> Float<N, S> {
    let (a2, b2) = (a * a, b * b);
    let sum = a2 + b2;
    sum.gt(Float::ZERO).select(a2 / sum, Float::ZERO)
}

/// The batch's paths in structure of arrays, lane k being sample `first + k`: what the
/// one-sample loop carries from vertex to vertex. Every live lane is at the same vertex.
struct Paths<S: Isa> {
    /// Throughput: the product of the BRDF sample weights (and albedo textures) so far.
    beta: Float3<LANES, S>,
    /// Radiance gathered so far.
    radiance: Float3<LANES, S>,
    /// The current vertex: position, shading and geometric normals, ω_o (world) and its object.
    p: Float3<LANES, S>,
    n: Float3<LANES, S>,
    ng: Float3<LANES, S>,
    wo_world: Float3<LANES, S>,
    object: [u32; LANES],
    /// The lane has a vertex to shade.
    alive: Mask<LANES, S>,
}

impl<S: Isa> Paths<S> {
    #[inline(always)]
    fn new() -> Self {
        let z = Float3::splat(Vec3::Z);
        Paths {
            beta: Float3::splat(Rgb::ONE),
            radiance: Float3::ZERO,
            p: Float3::ZERO,
            n: z,
            ng: z,
            wo_world: z,
            object: [0; LANES],
            alive: Mask::NONE,
        }
    }

    /// Lane `k` starts its first vertex.
    #[inline(always)]
    fn start(&mut self, k: usize, p: Vec3, n: Vec3, ng: Vec3, wo_world: Vec3, object: u32) {
        self.p.set_lane(k, p);
        self.n.set_lane(k, n);
        self.ng.set_lane(k, ng);
        self.wo_world.set_lane(k, wo_world);
        self.object[k] = object;
        self.alive.set(k, true);
    }
}

/// The closest hits of a stage's rays, in lanes (`hit[k]`: lane k's ray hit something).
struct LaneHits<S: Isa> {
    hit: Mask<LANES, S>,
    p: Float3<LANES, S>,
    n: Float3<LANES, S>,
    ng: Float3<LANES, S>,
    object: [u32; LANES],
}

impl<S: Isa> LaneHits<S> {
    const NONE: Self =
        LaneHits { hit: Mask::NONE, p: Float3::ZERO, n: Float3::ZERO, ng: Float3::ZERO, object: [0; LANES] };

    /// Lane `k` hit `h`.
    #[inline(always)]
    fn set_lane(&mut self, k: usize, h: &Hit) {
        self.hit.set(k, true);
        self.p.set_lane(k, h.p);
        self.n.set_lane(k, h.n);
        self.ng.set_lane(k, h.ng);
        self.object[k] = h.object;
    }
}

impl<'a> PathTracer<'a> {
    pub fn new(scene: &'a Scene) -> Self {
        PathTracer {
            scene,
            max_depth: scene.settings.max_depth,
            single_convex: scene.geometry.is_single_sphere(),
            textured: scene.textures.iter().any(Option::is_some),
        }
    }

    /// Traces samples `first .. first + n` (1 ≤ n ≤ [`LANES`]) of pixel (`row`, `col`), whose
    /// sampler id is `pixel`, from their camera sample on; returns their results in lanes `0..n`
    /// (the others are default). Sample k draws the numbers of `sampler.start(pixel, first + k)`,
    /// each dimension for all lanes at once ([`crate::sampling::SampleLanes`]: every live path of
    /// the batch is at the same vertex, hence at the same dimension), and computes the bits of the
    /// one-sample-at-a-time path tracer (`li_reference`, the tests' oracle: `render::tests`
    /// compares every scene in `scenes/`). With `jitter` false the camera sample is the pixel
    /// centre (the normal-probe camera's option).
    ///
    /// The paths are held in structure of arrays (`Paths`) and each stage of a vertex runs over
    /// the lanes at once: the shading frames and ω_o, the BRDF's sample (every model, written once
    /// over the lane type, [`crate::simd`]; where the lanes' BRDFs differ each lane calls the same
    /// code at one lane), the light's lookups of the BRDF directions ([`DistantLight::locate_each`],
    /// which starts their loads), the light samples ([`DistantLight::sample_each`]), the BRDF's
    /// value and density for them, MIS, the shadow rays, the bounce rays (a single sphere's roots
    /// over the lanes; a BVH's closest hits ray by ray, its any hits as packets, `bvh/packet.rs`),
    /// the escaped light and Russian roulette.
    ///
    /// Always inlined, so that each instruction-set copy of the render's tile loop has its own.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn li_lanes<S: Isa>(
        &self,
        sampler: &Sampler,
        pixel: u64,
        row: u32,
        col: u32,
        first: u64,
        n: usize,
        jitter: bool,
    ) -> [SampleResult; LANES] {
        debug_assert!((1..=LANES).contains(&n));
        let scene = self.scene;
        let light = &scene.light;
        let mut out = [SampleResult::default(); LANES];
        let mut ps = Paths::new();
        // The batch's numbers: lane k is sample first + k; `dim` is the next dimension of every
        // live lane (all at the same vertex), in the one-sample tracer's order: the camera's 2D,
        // then per vertex the light's 2D, the lobe's 1D (drawn or skipped), the BRDF's 2D, and
        // past `RR_START` vertices the roulette's 1D.
        let draws = sampler.lanes::<LANES, S>(pixel, first as u32);
        let mut dim = 2u32;
        let mut depth = 1u32;

        // Camera: each lane's first two dimensions, then its primary sample.
        // (No closures on this path: a closure is a function of its own, compiled for the build's
        // baseline even when called from the x86-64-v3 copy of the tile loop, where LLVM may leave
        // it out of line.)
        let [cx, cy] = draws.draw_2d(0);
        let u = if jitter { [cx, cy] } else { [Float::splat(0.5); 2] };
        let mut want = [false; LANES];
        let (mut origins, mut dirs) = (Float3::ZERO, Float3::splat(Vec3::Z));
        if let Some((o, d)) = scene.camera.generate_rays(row, col, u) {
            // A ray camera: every lane's ray at once (lanes past `n` are not wanted: every stage
            // below masks them out).
            (origins, dirs) = (o, d);
            for k in 0..n {
                want[k] = true;
                out[k].rays += 1;
            }
        } else {
            for k in 0..n {
                // The normal-probe camera hands over the first vertex itself.
                if let PrimarySample::Surface { p, n, wo } =
                    scene.camera.generate(row, col, Vec2::new(u[0].0[k], u[1].0[k]))
                {
                    ps.start(k, p, n, n, wo, 0);
                }
            }
        }
        let hits = self.trace_lanes(origins, dirs, Mask::from_bools(want));
        // The light seen by the camera rays that miss (in SIMD lanes for a lat-long map).
        // Most batches have none (every lane inside an object's silhouette): then no lookup runs.
        let missed = Mask::from_bools(want) & !hits.hit;
        let background = if missed.any() { light.eval_each(dirs, missed) } else { [Rgb::ZERO; LANES] };
        for k in 0..n {
            if hits.hit.lane(k) {
                ps.start(k, hits.p.lane(k), hits.n.lane(k), hits.ng.lane(k), -dirs.lane(k), hits.object[k]);
            } else if missed.lane(k) {
                out[k].radiance = background[k];
            }
            if ps.alive.lane(k) {
                out[k].hit = true;
                out[k].normal = ps.n.lane(k);
            }
        }

        while ps.alive.any() {
            // The vertex's numbers. Only a mix reads u_lobe: where no live lane has one, its
            // dimension is skipped, not drawn (a one-sample path skips it the same way).
            let [ux, uy] = draws.draw_2d(dim);
            let mut lobe_used = false;
            for k in 0..LANES {
                lobe_used |= ps.alive.lane(k) && scene.brdfs[ps.object[k] as usize].uses_lobe_choice();
            }
            let lobe = if lobe_used { draws.draw_1d(dim + 2) } else { Float::ZERO };
            let [bx, by] = draws.draw_2d(dim + 3);
            dim += 5;

            // An albedo texture scales the BRDF at this vertex (f → T(n) f): every contribution
            // from here on carries it, and no sampling density changes.
            if self.textured {
                for k in 0..LANES {
                    if let (true, Some(t)) = (ps.alive.lane(k), &scene.textures[ps.object[k] as usize]) {
                        ps.beta.set_lane(k, ps.beta.lane(k) * t.eval(ps.n.lane(k)));
                    }
                }
            }
            // Smooth meshes: keep ω_o above the shading hemisphere (Keller et al. 2017); a flat
            // or analytic surface (n = n_g) keeps its normal.
            let flat = ps.n.x.eq(ps.ng.x) & ps.n.y.eq(ps.ng.y) & ps.n.z.eq(ps.ng.z);
            let smooth = ps.alive & !flat;
            if smooth.any() {
                for k in 0..LANES {
                    if smooth.lane(k) {
                        let adapted = adapt_shading_normal(ps.n.lane(k), ps.ng.lane(k), ps.wo_world.lane(k));
                        ps.n.set_lane(k, adapted);
                    }
                }
            }
            let frame = Frames::from_normal(ps.n);
            let wo = frame.to_local(ps.wo_world);
            // Seen from below the shading hemisphere (e.g. an interpolated normal facing away), no
            // reflection is defined: the path ends.
            let planned = ps.alive & !wo.z.le(Float::ZERO);
            ps.alive = planned;
            if !planned.any() {
                break;
            }
            // The light's sampling tables for u_light start loading (read by the light sample).
            for k in 0..LANES {
                if planned.lane(k) {
                    light.prefetch_sample(Vec2::new(ux.0[k], uy.0[k]));
                }
            }

            // The BRDF's terms of ω_o and its sample: all lanes at once where every planned lane
            // has the same BRDF, else each lane with its own BRDF (the same code at one lane).
            let shared = shared_object(&ps.object, planned);
            let mut outgoing = Outgoing::plain(wo);
            let mut bs = BrdfSamples::<LANES, S>::NONE;
            // Per-lane properties of the BRDFs: a Dirac BRDF takes no light sample, and one with
            // `horizon = "ignore"` sees the distant light below its horizon unoccluded.
            let (mut delta_brdf, mut ignores) = (Mask::<LANES, S>::NONE, Mask::<LANES, S>::NONE);
            match shared {
                Some(object) => {
                    let brdf = &scene.brdfs[object as usize];
                    outgoing = brdf.outgoing(wo);
                    let u_lobe = if brdf.uses_lobe_choice() { lobe } else { Float::ZERO };
                    bs = brdf.sample_at(&outgoing, u_lobe, [bx, by]);
                    (delta_brdf, ignores) = (Mask::splat(brdf.is_delta()), Mask::splat(brdf.ignores_horizon()));
                }
                None => {
                    for k in 0..LANES {
                        if planned.lane(k) {
                            let brdf = &scene.brdfs[ps.object[k] as usize];
                            let o = brdf.outgoing::<1, Sse2>(Float3::splat(wo.lane(k)));
                            outgoing.set_lane(k, &o);
                            let u_lobe = if brdf.uses_lobe_choice() { lobe.0[k] } else { 0.0 };
                            let u = [Float::splat(bx.0[k]), Float::splat(by.0[k])];
                            bs.set_lane(k, &brdf.sample_at(&o, Float::splat(u_lobe), u));
                            delta_brdf.set(k, brdf.is_delta());
                            ignores.set(k, brdf.ignores_horizon());
                        }
                    }
                }
            }
            // A sample with zero weight continues nothing.
            let sampled = planned & bs.valid & !bs.weight.is_zero();
            let wi_world = frame.to_world(bs.wi).normalize();
            // The BRDF directions located in the light, all lanes at once (an environment map's
            // lookups run in SIMD lanes), which starts the loads of their texels; read when a
            // path escapes.
            let located = light.locate_each(wi_world, sampled);

            // Next-event estimation: one light sample per lane, the BRDF's value for it.
            // Lanes without a sample hold +z, 0, 0 and no delta (`LightSamples`).
            let LightSamples { wi: ls_wi, value: ls_value, pdf: ls_pdf, valid: drawn, delta: ls_delta } =
                light.sample_each([ux, uy], planned & !delta_brdf);
            let wi_local = frame.to_local(ls_wi);
            let f = match shared {
                Some(object) => scene.brdfs[object as usize].eval_at(&outgoing, wi_local),
                None => {
                    let mut f = Float3::ZERO;
                    for k in 0..LANES {
                        if drawn.lane(k) {
                            let brdf = &scene.brdfs[ps.object[k] as usize];
                            f.set_lane(k, brdf.eval_at(&outgoing.lane(k), Float3::splat(wi_local.lane(k))).lane(0));
                        }
                    }
                    f
                }
            };
            let nee = drawn & !f.is_zero();
            // The batch's shadow rays.
            let free = self.unoccluded(&ps, ignores, ls_wi);
            let shadow = nee & !free;
            let shadow_origins = offset_origins(ps.p, ps.ng, ls_wi);
            // The BRDF's direction continues the path: the batch's bounce rays.
            let traced = sampled & !self.unoccluded(&ps, ignores, wi_world);
            let bounce_origins = offset_origins(ps.p, ps.ng, wi_world);
            for k in 0..LANES {
                out[k].rays += shadow.lane(k) as u32 + traced.lane(k) as u32;
            }
            // At the last vertex a bounce ray only asks whether it escapes (no surface emits), so
            // it is an any-hit ray like the shadow rays, and both leave from the same points: they
            // are walked as one packet.
            let last = depth >= self.max_depth;
            let (occluded, last_blocked) = if last {
                self.occluded_pairs([shadow_origins, bounce_origins], [ls_wi, wi_world], [shadow, traced])
            } else {
                (self.occluded_lanes(shadow_origins, ls_wi, shadow), Mask::NONE)
            };
            let lit = nee & !occluded;
            // MIS against the BRDF's density of each unoccluded, non-Dirac light sample (power
            // heuristic; a Dirac light takes weight 1).
            let brdf_pdf = match shared {
                Some(object) => scene.brdfs[object as usize].pdf_at(&outgoing, wi_local),
                None => {
                    let mut pdf = Float::ZERO;
                    for k in 0..LANES {
                        if lit.lane(k) && !ls_delta.lane(k) {
                            let brdf = &scene.brdfs[ps.object[k] as usize];
                            pdf.0[k] = brdf.pdf_at(&outgoing.lane(k), Float3::splat(wi_local.lane(k))).lane(0);
                        }
                    }
                    pdf
                }
            };
            let w = ls_delta.select(Float::ONE, power_heuristics(ls_pdf, brdf_pdf));
            ps.radiance = Float3::select(lit, ps.radiance + ps.beta * f * ls_value * w, ps.radiance);

            ps.alive = sampled;
            ps.beta = Float3::select(sampled, ps.beta * bs.weight, ps.beta);
            let (blocked, hits) = if last {
                (last_blocked, LaneHits::NONE)
            } else {
                let hits = self.trace_lanes(bounce_origins, wi_world, traced);
                (hits.hit, hits)
            };

            // The light where the path escapes, with the complementary MIS weight.
            let escaped = sampled & !blocked;
            if escaped.any() {
                let (mut le, mut light_pdf) = (Float3::<LANES, S>::ZERO, Float::<LANES, S>::ZERO);
                for k in 0..LANES {
                    if escaped.lane(k) {
                        let (l, pdf) = light.eval_pdf_located(located[k]);
                        le.set_lane(k, l);
                        light_pdf.0[k] = pdf;
                    }
                }
                let mis = if light.is_delta() { Mask::ALL } else { bs.delta };
                let w = mis.select(Float::ONE, power_heuristics(bs.pdf, light_pdf));
                let gathered = escaped & !le.is_zero();
                ps.radiance = Float3::select(gathered, ps.radiance + ps.beta * le * w, ps.radiance);
                ps.alive = ps.alive & !escaped;
            }
            // The next vertex, unless the depth limit or Russian roulette (after `RR_START`
            // vertices, survival probability min(max β, 0.95)) ends the path.
            if last {
                break;
            }
            if !ps.alive.any() {
                break;
            }
            let roulette = depth + 1 > RR_START;
            if roulette {
                let u_rr = draws.draw_1d(dim);
                dim += 1;
                let b = Float3::new(ps.beta.x.abs(), ps.beta.y.abs(), ps.beta.z.abs());
                let q = b.y.max(b.z).max(b.x).min(Float::splat(0.95));
                let survives = ps.alive & !u_rr.ge(q);
                ps.beta = Float3::select(survives, ps.beta / q, ps.beta);
                ps.alive = survives;
            }
            ps.p = Float3::select(ps.alive, hits.p, ps.p);
            ps.n = Float3::select(ps.alive, hits.n, ps.n);
            ps.ng = Float3::select(ps.alive, hits.ng, ps.ng);
            ps.wo_world = Float3::select(ps.alive, -wi_world, ps.wo_world);
            for k in 0..LANES {
                if ps.alive.lane(k) {
                    ps.object[k] = hits.object[k];
                }
            }
            depth += 1;
        }
        for k in 0..n {
            if out[k].hit {
                out[k].radiance = ps.radiance.lane(k);
            }
        }
        out
    }

    /// Lanes whose direction `dir` nothing can block: below the horizon of a BRDF with
    /// `horizon = "ignore"` (`ignores`) the lobe sees the distant light by definition, and above
    /// a single sphere's horizon nothing can occlude.
    #[inline(always)]
    fn unoccluded<S: Isa>(&self, ps: &Paths<S>, ignores: Mask<LANES, S>, dir: Float3<LANES, S>) -> Mask<LANES, S> {
        let below = ps.n.dot(dir).le(Float::ZERO) & ignores;
        if self.single_convex { below | ps.ng.dot(dir).gt(Float::ZERO) } else { below }
    }

    /// The lanes of `want` whose ray (`origin`, `dir`, unbounded) hits something: the lanes where
    /// [`PathTracer::trace_lanes`] finds a hit, found by any-hit walks.
    #[inline(always)]
    fn occluded_lanes<S: Isa>(
        &self,
        origin: Float3<LANES, S>,
        dir: Float3<LANES, S>,
        want: Mask<LANES, S>,
    ) -> Mask<LANES, S> {
        let geometry = &self.scene.geometry;
        if !want.any() {
            return Mask::NONE;
        }
        if let Some(sphere) = geometry.single_sphere() {
            // The roots of `trace_lanes`, without the hit records.
            let (_, hit) = sphere.intersect_ts(origin, dir, Float::splat(f32::INFINITY));
            return want & hit;
        }
        // A BVH: the lanes' rays as one packet (`bvh/packet.rs`).
        let (rays, bits) = packet(origin, dir, want);
        let blocked = geometry.occluded_packet(&rays, bits);
        let mut out = Mask::NONE;
        for k in 0..LANES {
            out.set(k, blocked & (1 << k) != 0);
        }
        out
    }

    /// [`PathTracer::occluded_lanes`] of two sets of rays (the lanes' shadow and bounce rays),
    /// walked as one packet of sixteen when the scene has a BVH.
    #[inline(always)]
    fn occluded_pairs<S: Isa>(
        &self,
        origin: [Float3<LANES, S>; 2],
        dir: [Float3<LANES, S>; 2],
        want: [Mask<LANES, S>; 2],
    ) -> (Mask<LANES, S>, Mask<LANES, S>) {
        let geometry = &self.scene.geometry;
        if geometry.single_sphere().is_some() || !(want[0].any() && want[1].any()) {
            return (self.occluded_lanes(origin[0], dir[0], want[0]), self.occluded_lanes(origin[1], dir[1], want[1]));
        }
        let (first, bits0) = packet(origin[0], dir[0], want[0]);
        let (second, bits1) = packet(origin[1], dir[1], want[1]);
        let rays: [Ray; 2 * PACKET] = std::array::from_fn(|r| if r < PACKET { first[r] } else { second[r - PACKET] });
        let blocked = geometry.occluded_packet(&rays, bits0 | bits1 << PACKET);
        let (mut a, mut b) = (Mask::NONE, Mask::NONE);
        for k in 0..LANES {
            a.set(k, blocked & (1 << k) != 0);
            b.set(k, blocked & (1 << (k + PACKET)) != 0);
        }
        (a, b)
    }

    /// Closest hits of the rays (`origin`, `dir`) of the lanes in `want` (unbounded rays).
    #[inline(always)]
    fn trace_lanes<S: Isa>(
        &self,
        origin: Float3<LANES, S>,
        dir: Float3<LANES, S>,
        want: Mask<LANES, S>,
    ) -> LaneHits<S> {
        let geometry = &self.scene.geometry;
        let mut hits = LaneHits::NONE;
        if !want.any() {
            return hits;
        }
        if let Some(sphere) = geometry.single_sphere() {
            // One sphere (object 0): its roots over the lanes, then the hit records.
            let (t, hit) = sphere.intersect_ts(origin, dir, Float::splat(f32::INFINITY));
            hits.hit = want & hit;
            if !sphere.is_large() {
                (hits.p, hits.n) = sphere.surface_at(origin, dir, t);
                hits.ng = hits.n;
                return hits;
            }
            for k in 0..LANES {
                if hits.hit.lane(k) {
                    hits.set_lane(k, &sphere.hit_at(&Ray::new(origin.lane(k), dir.lane(k)), t.lane(k), 0));
                }
            }
            return hits;
        }
        // A BVH: ray by ray. (A packet's closest hits could depend on which rays share it, where
        // several triangles are hit at nearly the same t, and a sample's value must not depend on
        // its batch: `bvh/packet.rs`.)
        for k in 0..LANES {
            if want.lane(k)
                && let Some(h) = geometry.intersect(&Ray::new(origin.lane(k), dir.lane(k)))
            {
                hits.set_lane(k, &h);
            }
        }
        hits
    }
}

// A packet holds one ray of each lane.
const _: () = assert!(LANES == PACKET);

/// The lanes' rays (`origin`, `dir`, unbounded) as a packet, and the bits of `want`.
#[inline(always)]
fn packet<S: Isa>(origin: Float3<LANES, S>, dir: Float3<LANES, S>, want: Mask<LANES, S>) -> ([Ray; PACKET], u32) {
    let mut bits = 0;
    for k in 0..LANES {
        bits |= (want.lane(k) as u32) << k;
    }
    (std::array::from_fn(|k| Ray::new(origin.lane(k), dir.lane(k))), bits)
}

/// The object of every lane in `lanes`, where they all have the same (the BRDF's calls can then
/// run over the batch in SIMD lanes); `None` when they differ or `lanes` is empty.
#[inline(always)]
fn shared_object<S: Isa>(objects: &[u32; LANES], lanes: Mask<LANES, S>) -> Option<u32> {
    let mut object = None;
    for k in 0..LANES {
        if lanes.lane(k) {
            match object {
                None => object = Some(objects[k]),
                Some(o) if o != objects[k] => return None,
                Some(_) => {}
            }
        }
    }
    object
}
