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

use crate::brdf::{BrdfSample, Bxdf, Outgoing};
use crate::camera::PrimarySample;
use crate::geometry::shading::adapt_shading_normal;
use crate::geometry::{Hit, Ray};
use crate::light::{DistantLight, LightSample, Located};
use crate::math::{Frame, Rgb, Vec2, Vec3};
use crate::sampling::{LANES, Sampler};
use crate::scene::Scene;
use crate::simd::{Float, Float3, Mask};

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
}

#[inline]
pub(super) fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

/// Offset along the geometric normal to keep secondary rays off their own surface, scaled with
/// the magnitude of the position (f32 rounding grows with it).
#[inline]
pub(crate) fn offset_origin(p: Vec3, ng: Vec3, dir: Vec3) -> Vec3 {
    let eps = 1e-4 * (1.0 + p.abs().max_element());
    if ng.dot(dir) >= 0.0 { p + eps * ng } else { p - eps * ng }
}

/// One path between the stages of a vertex: what the one-sample loop carried from vertex to vertex.
#[derive(Clone, Copy, Debug)]
struct PathState {
    /// Throughput: the product of the BRDF sample weights (and albedo textures) so far.
    beta: Rgb,
    /// Radiance gathered so far.
    radiance: Rgb,
    /// The current vertex: position, shading and geometric normals, ω_o (world) and its object.
    p: Vec3,
    n: Vec3,
    ng: Vec3,
    wo_world: Vec3,
    object: u32,
    /// Surface vertices so far (1 at the first hit).
    depth: u32,
    /// The path has a vertex to shade.
    alive: bool,
}

impl PathState {
    const DONE: PathState = PathState {
        beta: Rgb::ZERO,
        radiance: Rgb::ZERO,
        p: Vec3::ZERO,
        n: Vec3::ZERO,
        ng: Vec3::ZERO,
        wo_world: Vec3::ZERO,
        object: 0,
        depth: 0,
        alive: false,
    };

    #[inline(always)]
    fn at(p: Vec3, n: Vec3, ng: Vec3, wo_world: Vec3, object: u32) -> Self {
        PathState { beta: Rgb::ONE, radiance: Rgb::ZERO, p, n, ng, wo_world, object, depth: 1, alive: true }
    }
}

/// What the first stage of a vertex ([`PathTracer::plan_vertex`]) leaves for the others.
#[derive(Clone, Copy, Debug)]
struct VertexPlan {
    frame: Frame,
    u_light: Vec2,
    /// The BRDF's sample (`None`: no sample, or a zero weight).
    bs: Option<BrdfSample>,
    /// Its world direction, unit, and then (stage 1's second half) the light's data located for it.
    located: Located,
}

impl VertexPlan {
    const NONE: VertexPlan = VertexPlan {
        frame: Frame { s: Vec3::ZERO, t: Vec3::ZERO, n: Vec3::ZERO },
        u_light: Vec2::ZERO,
        bs: None,
        located: Located::NONE,
    };
}

/// Next-event estimation waiting for its shadow ray: the light sample and the BRDF's value for it.
#[derive(Clone, Copy, Debug)]
struct PendingNee {
    ls: LightSample,
    f: Rgb,
}

/// One stage's rays, a slot per lane (`want[k]`: lane k has a ray to trace).
struct LaneRays {
    rays: [Ray; LANES],
    want: [bool; LANES],
}

impl LaneRays {
    #[inline(always)]
    fn new() -> Self {
        LaneRays { rays: [Ray::new(Vec3::ZERO, Vec3::Z); LANES], want: [false; LANES] }
    }
}

impl<'a> PathTracer<'a> {
    pub fn new(scene: &'a Scene) -> Self {
        PathTracer { scene, max_depth: scene.settings.max_depth, single_convex: scene.geometry.is_single_sphere() }
    }

    /// Traces samples `first .. first + n` (1 ≤ n ≤ [`LANES`]) of pixel (`row`, `col`), whose
    /// sampler id is `pixel`, from their camera sample on; returns their results in lanes `0..n`
    /// (the others are default). Sample k draws the numbers of `sampler.start(pixel, first + k)`,
    /// each dimension for all lanes at once ([`crate::sampling::SampleLanes`]: every live path of
    /// the batch is at the same vertex, hence at the same dimension), and
    /// computes the bits of the one-sample-at-a-time path tracer (`li_reference`, the tests'
    /// oracle: `render::tests` compares every scene in `scenes/`). With `jitter` false the camera
    /// sample is the pixel centre (the normal-probe camera's option).
    ///
    /// Each stage of a vertex runs over all live lanes before the next: the shading frame, the
    /// numbers and the BRDF's sample, with the loads of the light's data for that direction and of
    /// the light's sampling tables for u_light all issued before any is read; next-event
    /// estimation; the batch's shadow rays; the batch's bounce rays; then the escaped light or the
    /// next vertex. The lat-long light samples ([`DistantLight::sample_each`]), the lat-long
    /// lookups of the BRDF directions ([`DistantLight::locate_each`]), a single sphere's
    /// intersections ([`crate::geometry::Sphere::intersect_ts`]) and, where every planned
    /// lane has the same BRDF, its sample, eval and pdf ([`crate::brdf::Bxdf::sample_at`], every
    /// model) run in SIMD lanes, each written once over the lane type ([`crate::simd`]); where the
    /// lanes' BRDFs differ each lane calls the same code at one lane. A BVH's camera rays are walked
    /// as one packet ([`crate::geometry::SceneGeometry::intersect_packet`]); the rest loops over the
    /// live lanes with the one-sample code.
    ///
    /// Always inlined, so that each instruction-set copy of the render's tile loop has its own.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn li_lanes(
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
        let mut out = [SampleResult::default(); LANES];
        let mut st = [PathState::DONE; LANES];
        // The batch's numbers: lane k is sample first + k; `dim` is the next dimension of every
        // live lane (all at the same vertex), in the one-sample tracer's order: the camera's 2D,
        // then per vertex the light's 2D, the lobe's 1D (drawn or skipped), the BRDF's 2D, and
        // past `RR_START` vertices the roulette's 1D.
        let draws = sampler.lanes::<LANES>(pixel, first as u32);
        let mut dim = 2u32;
        let mut depth = 1u32;

        // Camera: each lane's first two dimensions, then its primary sample.
        // (No closures on this path: a closure is a function of its own, compiled for the build's
        // baseline even when called from the x86-64-v3 copy of the tile loop, where LLVM may leave
        // it out of line; the draws ahead run in AVX2 lanes only inside that copy.)
        let [cx, cy] = draws.draw_2d(0);
        let mut camera = LaneRays::new();
        for k in 0..n {
            let u = if jitter { Vec2::new(cx.0[k], cy.0[k]) } else { Vec2::splat(0.5) };
            match scene.camera.generate(row, col, u) {
                // The normal-probe camera hands over the first vertex itself.
                PrimarySample::Surface { p, n, wo } => st[k] = PathState::at(p, n, n, wo, 0),
                PrimarySample::Ray(ray) => {
                    camera.rays[k] = ray;
                    camera.want[k] = true;
                    out[k].rays += 1;
                }
            }
        }
        // A pixel's camera rays run nearly parallel: one packet walk of a BVH for all of them.
        let hits = if self.single_convex {
            self.trace(&camera)
        } else {
            scene.geometry.intersect_packet(&camera.rays, &camera.want)
        };
        // The light seen by the camera rays that miss (in SIMD lanes for a lat-long map).
        // Most batches have none (every lane inside an object's silhouette): then no lookup runs.
        let mut missed = [false; LANES];
        let mut miss_dirs = [Vec3::Z; LANES];
        let mut any_missed = false;
        for k in 0..n {
            missed[k] = camera.want[k] && hits[k].is_none();
            miss_dirs[k] = camera.rays[k].dir;
            any_missed |= missed[k];
        }
        let background = if any_missed {
            scene.light.eval_each(Float3::from_vecs(&miss_dirs), Mask(missed))
        } else {
            [Rgb::ZERO; LANES]
        };
        for k in 0..n {
            if camera.want[k] {
                match hits[k] {
                    Some(h) => st[k] = PathState::at(h.p, h.n, h.ng, -camera.rays[k].dir, h.object),
                    None => out[k].radiance = background[k],
                }
            }
            if st[k].alive {
                out[k].hit = true;
                out[k].normal = st[k].n;
            }
        }

        let mut plan = [VertexPlan::NONE; LANES];
        let mut planned = [false; LANES];
        loop {
            let mut any = false;
            for s in &st {
                any |= s.alive;
            }
            if !any {
                break;
            }
            // Stage 1: the vertex's numbers for every lane, frame, the BRDF's sample; the light's
            // loads start. Only a mix reads u_lobe: where no live lane has one, its dimension is
            // skipped, not drawn (a one-sample path skips it the same way).
            let [ux, uy] = draws.draw_2d(dim);
            let mut lobe_used = false;
            for s in &st {
                lobe_used |= s.alive && scene.brdfs[s.object as usize].uses_lobe_choice();
            }
            let lobe = if lobe_used { draws.draw_1d(dim + 2) } else { Float::ZERO };
            let [bx, by] = draws.draw_2d(dim + 3);
            dim += 5;
            let mut wo = [Vec3::Z; LANES];
            let mut u_lobe = [0.0f32; LANES];
            let mut u_brdf = [Vec2::ZERO; LANES];
            for k in 0..LANES {
                planned[k] = false;
                if st[k].alive {
                    debug_assert_eq!(st[k].depth, depth, "the batch's live paths are at one vertex");
                    planned[k] = self.plan_vertex(&mut st[k], Vec2::new(ux.0[k], uy.0[k]), &mut plan[k], &mut wo[k]);
                    if scene.brdfs[st[k].object as usize].uses_lobe_choice() {
                        u_lobe[k] = lobe.0[k];
                    }
                    u_brdf[k] = Vec2::new(bx.0[k], by.0[k]);
                }
            }
            // The BRDF's terms of ω_o and its sample: all lanes at once where every planned lane
            // has the same BRDF, else each lane with its own BRDF (the same code at one lane).
            let shared = shared_object(&st, &planned);
            let mut outgoing = Outgoing::plain(Float3::from_vecs(&wo));
            let mut samples = [None; LANES];
            match shared {
                Some(object) => {
                    let brdf = &scene.brdfs[object as usize];
                    outgoing = brdf.outgoing(outgoing.wo);
                    let mut u = [Float::ZERO; 2];
                    for (k, uk) in u_brdf.iter().enumerate() {
                        (u[0].0[k], u[1].0[k]) = (uk.x, uk.y);
                    }
                    let s = brdf.sample_at(&outgoing, Float(u_lobe), u);
                    for k in 0..LANES {
                        if planned[k] {
                            samples[k] = s.lane(k);
                        }
                    }
                }
                None => {
                    for k in 0..LANES {
                        if planned[k] {
                            let brdf = &scene.brdfs[st[k].object as usize];
                            let o = brdf.outgoing::<1>(Float3::splat(wo[k]));
                            outgoing.set_lane(k, &o);
                            let u = [Float::splat(u_brdf[k].x), Float::splat(u_brdf[k].y)];
                            samples[k] = brdf.sample_at(&o, Float::splat(u_lobe[k]), u).lane(0);
                        }
                    }
                }
            }
            for k in 0..LANES {
                if planned[k] {
                    // The direction is located in the light after this stage (`locate_each`: an
                    // environment map's texel found once, its load started); `eval_pdf_located`
                    // reads it in stage 4.
                    plan[k].bs = match samples[k] {
                        Some(bs) if bs.weight != Rgb::ZERO => {
                            plan[k].located.wi = plan[k].frame.to_world(bs.wi).normalize();
                            Some(bs)
                        }
                        _ => None,
                    };
                }
            }
            // The BRDF directions located in the light, all lanes at once (an environment map's
            // lookups run in SIMD lanes), which starts the loads of their texels.
            let mut dirs = [Vec3::Z; LANES];
            let mut sampled = [false; LANES];
            for k in 0..LANES {
                sampled[k] = planned[k] && plan[k].bs.is_some();
                dirs[k] = plan[k].located.wi;
            }
            let located = scene.light.locate_each(Float3::from_vecs(&dirs), Mask(sampled));
            for k in 0..LANES {
                if sampled[k] {
                    plan[k].located = located[k];
                }
            }
            // Stage 2: next-event estimation up to its shadow ray, then the batch's shadow rays.
            let mut u_light = [Vec2::ZERO; LANES];
            let mut nee_wanted = [false; LANES];
            for k in 0..LANES {
                // A Dirac BRDF takes no light sample.
                nee_wanted[k] = planned[k] && !scene.brdfs[st[k].object as usize].is_delta();
                u_light[k] = plan[k].u_light;
            }
            let mut u = [Float::ZERO; 2];
            for (k, uk) in u_light.iter().enumerate() {
                (u[0].0[k], u[1].0[k]) = (uk.x, uk.y);
            }
            let light_samples = scene.light.sample_each(u, Mask(nee_wanted));
            // The BRDF's value for each light sample (in SIMD lanes where the BRDF is shared).
            let mut wi_local = [Vec3::Z; LANES];
            let mut evaluate = [false; LANES];
            for k in 0..LANES {
                if let (true, Some(ls)) = (nee_wanted[k], light_samples[k]) {
                    wi_local[k] = plan[k].frame.to_local(ls.wi);
                    evaluate[k] = true;
                }
            }
            let f = match shared {
                Some(object) => {
                    let f = scene.brdfs[object as usize].eval_at(&outgoing, Float3::from_vecs(&wi_local));
                    let mut out = [Rgb::ZERO; LANES];
                    for k in 0..LANES {
                        if evaluate[k] {
                            out[k] = f.lane(k);
                        }
                    }
                    out
                }
                None => {
                    let mut f = [Rgb::ZERO; LANES];
                    for k in 0..LANES {
                        if evaluate[k] {
                            let brdf = &scene.brdfs[st[k].object as usize];
                            f[k] = brdf.eval_at(&outgoing.lane(k), Float3::splat(wi_local[k])).lane(0);
                        }
                    }
                    f
                }
            };
            let mut nee = [None::<PendingNee>; LANES];
            let mut shadow = LaneRays::new();
            for k in 0..LANES {
                let (true, Some(ls)) = (evaluate[k], light_samples[k]) else { continue };
                if f[k] == Rgb::ZERO {
                    continue;
                }
                if let Some(ray) = self.ray_toward(&st[k], ls.wi) {
                    shadow.rays[k] = ray;
                    shadow.want[k] = true;
                    out[k].rays += 1;
                }
                nee[k] = Some(PendingNee { ls, f: f[k] });
            }
            let occluded = self.occluded(&shadow);
            // Next-event estimation's MIS weights need the BRDF's density of each unoccluded,
            // non-Dirac light sample.
            let mut weigh = [false; LANES];
            for k in 0..LANES {
                weigh[k] = matches!((planned[k], &nee[k], occluded[k]), (true, Some(p), false) if !p.ls.delta);
            }
            let brdf_pdf = match shared {
                Some(object) => {
                    let p = scene.brdfs[object as usize].pdf_at(&outgoing, Float3::from_vecs(&wi_local));
                    let mut out = [0.0f32; LANES];
                    for k in 0..LANES {
                        if weigh[k] {
                            out[k] = p.lane(k);
                        }
                    }
                    out
                }
                None => {
                    let mut pdf = [0.0f32; LANES];
                    for k in 0..LANES {
                        if weigh[k] {
                            let brdf = &scene.brdfs[st[k].object as usize];
                            pdf[k] = brdf.pdf_at(&outgoing.lane(k), Float3::splat(wi_local[k])).lane(0);
                        }
                    }
                    pdf
                }
            };
            for k in 0..LANES {
                if let (true, Some(pending), false) = (planned[k], &nee[k], occluded[k]) {
                    add_light_sample(&mut st[k], pending, brdf_pdf[k]);
                }
            }
            // Stage 3: the BRDF's direction continues the path; the batch's bounce rays.
            let mut bounce = LaneRays::new();
            for k in 0..LANES {
                if !planned[k] {
                    continue;
                }
                let (Some(bs), located) = (plan[k].bs, plan[k].located) else {
                    st[k].alive = false;
                    planned[k] = false;
                    continue;
                };
                st[k].beta *= bs.weight;
                if let Some(ray) = self.ray_toward(&st[k], located.wi) {
                    bounce.rays[k] = ray;
                    bounce.want[k] = true;
                    out[k].rays += 1;
                }
            }
            let hits = self.trace(&bounce);
            // Stage 4: the light where the path escapes, or the next vertex (whose roulette number
            // every lane draws at once, where the vertex has a roulette).
            let mut any_hit = false;
            for k in 0..LANES {
                any_hit |= planned[k] && hits[k].is_some();
            }
            let roulette = depth < self.max_depth && depth + 1 > RR_START;
            let u_rr = if any_hit && roulette { draws.draw_1d(dim) } else { Float::ZERO };
            for k in 0..LANES {
                let (true, Some(bs), located) = (planned[k], plan[k].bs, plan[k].located) else { continue };
                match hits[k] {
                    None => self.add_escaped(&mut st[k], &bs, located),
                    Some(h) => self.next_vertex(&mut st[k], &h, located.wi, u_rr.0[k]),
                }
            }
            if roulette {
                dim += 1;
            }
            depth += 1;
        }
        for k in 0..n {
            if out[k].hit {
                out[k].radiance = st[k].radiance;
            }
        }
        out
    }

    /// Closest hits of the wanted rays (`None` elsewhere).
    #[inline(always)]
    fn trace(&self, r: &LaneRays) -> [Option<Hit>; LANES] {
        let mut hits = [None; LANES];
        let geometry = &self.scene.geometry;
        if let Some(sphere) = geometry.single_sphere() {
            // One sphere (object 0): its roots over the lanes, then the hit records.
            let (mut origin, mut dir, mut t_max) = (Float3::<LANES>::ZERO, Float3::<LANES>::ZERO, Float::<LANES>::ZERO);
            for k in 0..LANES {
                origin.set_lane(k, r.rays[k].origin);
                dir.set_lane(k, r.rays[k].dir);
                t_max.0[k] = r.rays[k].t_max;
            }
            let (t, hit) = sphere.intersect_ts(origin, dir, t_max);
            for (k, h) in hits.iter_mut().enumerate() {
                if r.want[k] && hit.lane(k) {
                    *h = Some(sphere.hit_at(&r.rays[k], t.lane(k), 0));
                }
            }
            return hits;
        }
        // A BVH: ray by ray. `intersect_batch` on a stage's ≤ 8 rays gives the same hits, but costed
        // 62 % more render instructions on bench-mesh-sky and no wall time (guide "Performance notes and their
        // history", eighth round): its interleaving pays off over many rays, not over one pixel's batch.
        for ((hit, ray), &want) in hits.iter_mut().zip(&r.rays).zip(&r.want) {
            if want {
                *hit = geometry.intersect(ray);
            }
        }
        hits
    }

    /// Whether each wanted ray is occluded (`false` elsewhere).
    #[inline(always)]
    fn occluded(&self, r: &LaneRays) -> [bool; LANES] {
        let mut occluded = [false; LANES];
        for ((o, ray), &want) in occluded.iter_mut().zip(&r.rays).zip(&r.want) {
            if want {
                *o = self.scene.geometry.occluded(ray);
            }
        }
        occluded
    }

    /// The vertex's shading frame and ω_o in it, with its light number `u_light` (drawn for the
    /// batch, as are its lobe and BRDF numbers); the light's sampling tables for u_light start
    /// loading (read in stage 2). Writes `plan`'s frame and u_light and `wo`; the BRDF's sample
    /// follows for the whole batch. False ends the path: seen from below the shading hemisphere
    /// (e.g. an interpolated normal facing away), no reflection is defined.
    #[inline(always)]
    fn plan_vertex(&self, st: &mut PathState, u_light: Vec2, plan: &mut VertexPlan, wo_out: &mut Vec3) -> bool {
        let scene = self.scene;
        // An albedo texture scales the BRDF at this vertex (f → T(n) f): every contribution
        // from here on carries it, and no sampling density changes.
        if let Some(t) = &scene.textures[st.object as usize] {
            st.beta *= t.eval(st.n);
        }
        // Smooth meshes: keep ω_o above the shading hemisphere (Keller et al. 2017).
        st.n = adapt_shading_normal(st.n, st.ng, st.wo_world);
        let frame = Frame::from_normal(st.n);
        let wo = frame.to_local(st.wo_world);
        if wo.z <= 0.0 {
            st.alive = false;
            return false;
        }
        scene.light.prefetch_sample(u_light);
        *wo_out = wo;
        plan.frame = frame;
        plan.u_light = u_light;
        true
    }

    /// The ray from the vertex toward `dir` (a shadow ray, or the bounce along the BRDF's
    /// direction), or `None` where nothing can be in the way: below the horizon of a BRDF with
    /// `horizon = "ignore"` the lobe sees the distant light by definition, and above a single
    /// sphere's horizon nothing can occlude.
    #[inline(always)]
    fn ray_toward(&self, st: &PathState, dir: Vec3) -> Option<Ray> {
        let ignores = self.scene.brdfs[st.object as usize].ignores_horizon();
        if st.n.dot(dir) <= 0.0 && ignores {
            return None;
        }
        if self.single_convex && st.ng.dot(dir) > 0.0 {
            return None;
        }
        Some(Ray::new(offset_origin(st.p, st.ng, dir), dir))
    }

    /// The path escaped along the BRDF's direction: the light there, with the complementary MIS
    /// weight. Ends the path.
    #[inline(always)]
    fn add_escaped(&self, st: &mut PathState, bs: &BrdfSample, located: Located) {
        let light = &self.scene.light;
        let (le, light_pdf) = light.eval_pdf_located(located);
        if le != Rgb::ZERO {
            let w = if bs.delta || light.is_delta() { 1.0 } else { power_heuristic(bs.pdf, light_pdf) };
            st.radiance += st.beta * le * w;
        }
        st.alive = false;
    }

    /// The path hit `h` along `wi_world`: the next vertex, unless the depth limit or Russian
    /// roulette (after [`RR_START`] vertices, survival probability min(max β, 0.95), against the
    /// number `u_rr`) ends it.
    #[inline(always)]
    fn next_vertex(&self, st: &mut PathState, h: &Hit, wi_world: Vec3, u_rr: f32) {
        if st.depth >= self.max_depth {
            st.alive = false;
            return;
        }
        st.depth += 1;
        if st.depth > RR_START {
            let q = st.beta.abs().max_element().min(0.95);
            if u_rr >= q {
                st.alive = false;
                return;
            }
            st.beta /= q;
        }
        st.p = h.p;
        st.n = h.n;
        st.ng = h.ng;
        st.wo_world = -wi_world;
        st.object = h.object;
    }
}

/// The object of every planned lane, where they all have the same (the BRDF's calls can then
/// run over the batch in SIMD lanes); `None` when they differ or none is planned.
#[inline(always)]
fn shared_object(st: &[PathState; LANES], planned: &[bool; LANES]) -> Option<u32> {
    let mut object = None;
    for k in 0..LANES {
        if planned[k] {
            match object {
                None => object = Some(st[k].object),
                Some(o) if o != st[k].object => return None,
                Some(_) => {}
            }
        }
    }
    object
}

/// Adds next-event estimation's contribution of an unoccluded light sample, MIS-weighted against
/// the BRDF's density `brdf_pdf` of its direction (power heuristic; a Dirac light takes weight 1).
#[inline(always)]
fn add_light_sample(st: &mut PathState, nee: &PendingNee, brdf_pdf: f32) {
    let w = if nee.ls.delta { 1.0 } else { power_heuristic(nee.ls.pdf, brdf_pdf) };
    st.radiance += st.beta * nee.f * nee.ls.value * w;
}
