//! The one-sample-at-a-time path tracer the renderer used before the batched one: the tests'
//! oracle for [`PathTracer::li_lanes`], which must give its bits for every sample.

use super::path::{PathTracer, RR_START, SampleResult, offset_origin};
use crate::brdf::Bxdf;
use crate::camera::PrimarySample;
use crate::geometry::Ray;
use crate::geometry::shading::adapt_shading_normal;
use crate::light::DistantLight;
use crate::math::{Frame, Rgb, Vec3};
use crate::sampling::Sampler;

/// The power heuristic (β = 2), written out apart from the integrator's lanes.
fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

impl PathTracer<'_> {
    #[inline]
    fn visible(&self, p: Vec3, ng: Vec3, n: Vec3, dir: Vec3, ignores_horizon: bool, rays: &mut u32) -> bool {
        if n.dot(dir) <= 0.0 && ignores_horizon {
            return true;
        }
        if self.single_convex && ng.dot(dir) > 0.0 {
            return true;
        }
        *rays += 1;
        !self.scene.geometry.occluded(&Ray::new(offset_origin(p, ng, dir), dir))
    }

    /// Estimates the radiance of one primary sample. The sampler must already be positioned at
    /// the pixel sample (dimension 2 onward: the camera used dimensions 0–1). Always inlined, so
    /// that each instruction-set version of the render's tile loop has its own copy (`render_tile`).
    #[inline(always)]
    pub(crate) fn li_reference(&self, primary: PrimarySample, sampler: &mut Sampler) -> SampleResult {
        let scene = self.scene;
        let light = &scene.light;
        let mut out = SampleResult::default();
        let mut beta = Rgb::ONE;
        let mut radiance = Rgb::ZERO;

        // The first vertex: from the camera ray, or given directly by the normal-probe camera.
        let (mut p, mut n, mut ng, mut wo_world, mut object) = match primary {
            PrimarySample::Surface { p, n, wo } => (p, n, n, wo, 0u32),
            PrimarySample::Ray(ray) => {
                out.rays += 1;
                match scene.geometry.intersect(&ray) {
                    Some(h) => (h.p, h.n, h.ng, -ray.dir, h.object),
                    None => {
                        out.radiance = light.eval(ray.dir);
                        return out;
                    }
                }
            }
        };
        out.hit = true;
        out.normal = n;

        let mut depth = 1u32;
        loop {
            let brdf = &scene.brdfs[object as usize];
            // An albedo texture scales the BRDF at this vertex (f → T(n) f): every contribution
            // from here on carries it, and no sampling density changes.
            if let Some(t) = &scene.textures[object as usize] {
                beta *= t.eval(n);
            }
            // Smooth meshes: keep ω_o above the shading hemisphere (Keller et al. 2017).
            n = adapt_shading_normal(n, ng, wo_world);
            let frame = Frame::from_normal(n);
            let wo = frame.to_local(wo_world);
            if wo.z <= 0.0 {
                // Seen from below the shading hemisphere (e.g. an interpolated normal facing
                // away): no reflection defined.
                break;
            }
            let ignores = brdf.ignores_horizon();

            let u_light = sampler.next_2d();
            // Only a mix reads u_lobe; for the others its dimension is skipped, not drawn (the
            // same numbers everywhere else, one Owen-scrambled draw less per vertex).
            let u_lobe = if brdf.uses_lobe_choice() {
                sampler.next_1d()
            } else {
                sampler.skip_1d();
                0.0
            };
            let u_brdf = sampler.next_2d();
            // The light's sampling tables for u_light start loading now, while the BRDF samples.
            light.prefetch_sample(u_light);

            // The BRDF direction is drawn first so that the light's data for it (an environment
            // texel, megabytes away from anything recently used) can be fetched from memory while
            // next-event estimation runs; it is used only after NEE, as before.
            // `locate` finds its texel once (an environment map's lookup costs two arctangents)
            // and starts the load; `eval_pdf_located` uses it below.
            let bs = brdf.sample(wo, u_lobe, u_brdf).filter(|bs| bs.weight != Rgb::ZERO);
            let located = bs.map(|bs| light.locate(frame.to_world(bs.wi).normalize()));

            // Next-event estimation: one direction from the light.
            if let Some(ls) = light.sample(u_light).filter(|_| !brdf.is_delta()) {
                let wi = frame.to_local(ls.wi);
                let f = brdf.eval(wo, wi);
                if f != Rgb::ZERO && self.visible(p, ng, n, ls.wi, ignores, &mut out.rays) {
                    let w = if ls.delta { 1.0 } else { power_heuristic(ls.pdf, brdf.pdf(wo, wi)) };
                    radiance += beta * f * ls.value * w;
                }
            }

            // BRDF sampling: continues the path and, where it escapes, collects the light with
            // the complementary MIS weight.
            let (Some(bs), Some(located)) = (bs, located) else { break };
            let wi_world = located.wi;
            beta *= bs.weight;

            // Below the horizon with horizon = "ignore" the lobe sees the distant light directly;
            // above a single sphere's horizon nothing can be in the way.
            let unoccluded = (n.dot(wi_world) <= 0.0 && ignores) || (self.single_convex && ng.dot(wi_world) > 0.0);
            let escaped = if unoccluded {
                None
            } else {
                out.rays += 1;
                scene.geometry.intersect(&Ray::new(offset_origin(p, ng, wi_world), wi_world))
            };
            match escaped {
                None => {
                    let (le, light_pdf) = light.eval_pdf_located(located);
                    if le != Rgb::ZERO {
                        let w = if bs.delta || light.is_delta() { 1.0 } else { power_heuristic(bs.pdf, light_pdf) };
                        radiance += beta * le * w;
                    }
                    break;
                }
                Some(h) => {
                    if depth >= self.max_depth {
                        break;
                    }
                    depth += 1;
                    if depth > RR_START {
                        let q = beta.abs().max_element().min(0.95);
                        if sampler.next_1d() >= q {
                            break;
                        }
                        beta /= q;
                    }
                    p = h.p;
                    n = h.n;
                    ng = h.ng;
                    wo_world = -wi_world;
                    object = h.object;
                }
            }
        }
        out.radiance = radiance;
        out
    }
}
