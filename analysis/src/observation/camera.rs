//! The camera of one image, in our world frame: from the image's header, a sidecar scene, the
//! header's `worldToNDC` matrices or explicit values, and how two of them are compared.

use super::error::Error;
use super::{Sourced, close, merge, num, v3};
use crate::projection::OrthoCamera;
use vocab::scene::{CameraSection, decimal, decimal3};

/// The camera of one image, in our world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Camera {
    /// docs/src/conventions.md §5 orthographic camera (world units).
    Ortho(OrthoCamera),
    /// docs/src/conventions.md §6 normal-probe camera at exitance (θ_o, φ_o), degrees.
    NormalProbe { theta_o_deg: f64, phi_o_deg: f64 },
}

impl std::fmt::Display for Camera {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Camera::Ortho(c) => {
                write!(f, "orthographic from {} to {} up {} extent {}", v3(c.from), v3(c.to), v3(c.up), num(c.extent))
            }
            Camera::NormalProbe { theta_o_deg, phi_o_deg } => {
                write!(f, "normal-probe theta_o_deg {} phi_o_deg {}", num(*theta_o_deg), num(*phi_o_deg))
            }
        }
    }
}

impl Camera {
    /// θ_o (degrees) of a normal-probe camera for the per-order analysis of `analyze` and
    /// `invert lighting | brdf`, which reads the q = 0 term at (θ_o, φ_o = 0) (eq. 10): another
    /// azimuth at oblique exitance is refused (`what` names the command's verb in the message).
    pub fn probe_theta_o_deg(theta_o_deg: f64, phi_o_deg: f64, what: &str) -> Result<f64, Error> {
        if theta_o_deg != 0.0 && phi_o_deg.rem_euclid(360.0) != 0.0 {
            return Err(Error::ProbeAzimuth { phi_o_deg, what: what.to_string() });
        }
        Ok(theta_o_deg)
    }

    /// A scene or header camera table as a [`Camera`]; `what` is the command's verb ("analysed",
    /// "inverted") for the refusal of a camera the analysis does not model (perspective). A
    /// normal-probe θ_o goes through the one exitance check of every command
    /// ([`crate::transfer::validate_exitance`]: 0 ≤ θ_o < 90°, as the renderer's camera).
    pub fn of_section(c: &CameraSection, what: &str) -> Result<Camera, Error> {
        match c {
            CameraSection::Orthographic { from, to, up, extent } => Ok(Camera::Ortho(OrthoCamera {
                from: decimal3(*from),
                to: decimal3(*to),
                up: decimal3(*up),
                extent: decimal(*extent),
            })),
            CameraSection::NormalProbe { theta_o_deg, phi_o_deg, .. } => {
                let (t, p) = (decimal(*theta_o_deg), decimal(*phi_o_deg));
                crate::transfer::validate_exitance(t.to_radians()).map_err(|e| Error::CameraExitance(e.message))?;
                Ok(Camera::NormalProbe { theta_o_deg: t, phi_o_deg: p })
            }
            CameraSection::Perspective { .. } => Err(Error::Perspective { what: what.to_string() }),
        }
    }

    /// Whether two cameras are the same view, to the f32 precision headers store.
    pub fn same(&self, other: &Camera) -> bool {
        match (self, other) {
            (Camera::Ortho(x), Camera::Ortho(y)) => x.same_view(y),
            (
                Camera::NormalProbe { theta_o_deg: t1, phi_o_deg: p1 },
                Camera::NormalProbe { theta_o_deg: t2, phi_o_deg: p2 },
            ) => close(*t1, *t2, 90.0) && close((p1 - p2 + 180.0).rem_euclid(360.0) - 180.0, 0.0, 360.0),
            _ => false,
        }
    }
}

/// The explicit camera values of one image (`None` where a value is not given): an orthographic
/// view (`from`, `to`, `up`, `extent`, world units) or a normal-probe one (`theta_o`, `phi_o`,
/// degrees). The CLI's `--from/--to/--up/--extent/--theta-o/--phi-o`, one set per image.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraValues {
    pub from: Option<[f64; 3]>,
    pub to: Option<[f64; 3]>,
    pub up: Option<[f64; 3]>,
    pub extent: Option<f64>,
    /// A normal-probe camera's exitance θ_o and azimuth φ_o (degrees).
    pub theta_o: Option<f64>,
    pub phi_o: Option<f64>,
}

impl CameraValues {
    /// Whether an orthographic value (`from/to/up/extent`) is given.
    pub fn ortho_given(&self) -> bool {
        self.from.is_some() || self.to.is_some() || self.up.is_some() || self.extent.is_some()
    }

    /// The normal-probe angles (θ_o°, φ_o°) (each defaulting to 0 when the other is given); `None`
    /// when neither is given.
    pub fn probe(&self) -> Option<(f64, f64)> {
        (self.theta_o.is_some() || self.phi_o.is_some())
            .then(|| (self.theta_o.unwrap_or(0.0), self.phi_o.unwrap_or(0.0)))
    }

    /// The orthographic camera these values describe: `from` and `extent` are needed, `to`
    /// defaults to the origin and `up` to +z. `None` when either is missing.
    pub fn camera(&self) -> Option<OrthoCamera> {
        Some(OrthoCamera {
            from: self.from?,
            to: self.to.unwrap_or([0.0; 3]),
            up: self.up.unwrap_or([0.0, 0.0, 1.0]),
            extent: self.extent?,
        })
    }

    /// These values laid over a base orthographic camera. A `from` given describes the values' own
    /// camera: `to` and `up` then take their defaults (0,0,0 and 0,0,1) when absent, as for an
    /// image with no camera at all, never the base's (a pbrt matrix camera's `to` is a point on its
    /// own view axis, so `from` with the base's `to` would look elsewhere). Without `from`, the
    /// values given replace the base's fields and the others are the base's.
    fn over(&self, base: &OrthoCamera) -> OrthoCamera {
        match self.from {
            Some(from) => OrthoCamera {
                from,
                to: self.to.unwrap_or([0.0; 3]),
                up: self.up.unwrap_or([0.0, 0.0, 1.0]),
                extent: self.extent.unwrap_or(base.extent),
            },
            None => OrthoCamera {
                from: base.from,
                to: self.to.unwrap_or(base.to),
                up: self.up.unwrap_or(base.up),
                extent: self.extent.unwrap_or(base.extent),
            },
        }
    }
}

/// The normal-probe camera of explicit angles (degrees), through the one exitance check of every
/// command ([`crate::transfer::validate_exitance`]: 0 ≤ θ_o < 90°).
fn probe_of_values(theta_o_deg: f64, phi_o_deg: f64) -> Result<Camera, Error> {
    if !phi_o_deg.is_finite() {
        return Err(Error::AzimuthValue(phi_o_deg));
    }
    crate::transfer::validate_exitance(theta_o_deg.to_radians()).map_err(|e| Error::ExitanceValue(e.message))?;
    Ok(Camera::NormalProbe { theta_o_deg, phi_o_deg })
}

/// The camera of one image from its header's (`from_header`: `reflect:camera` or `worldToNDC`),
/// the sidecar scene's (`scene`) and the explicit values `v` (module docs of [`super`]).
pub(super) fn resolve(
    from_header: Sourced<Camera>,
    scene: Sourced<Camera>,
    v: &CameraValues,
    probe_only: bool,
    spelling: super::brdf::Spelling,
) -> Result<Camera, Error> {
    // A sidecar's normal-probe camera describes a set of views of one scene, each at its own
    // exitance (a light field, a separation): the image's header or the explicit angles give this
    // image's angles, the scene's are the default.
    let template = matches!(scene, Some((Camera::NormalProbe { .. }, _)));
    let base = match (from_header, scene) {
        (Some(h @ (Camera::NormalProbe { .. }, _)), Some(_)) if template => Some(h),
        (h, s) => merge(h, s, Camera::same)?,
    };
    let base_is_template = template && base.as_ref().is_some_and(|(_, src)| src.starts_with("the [camera]"));
    if v.ortho_given() && v.probe().is_some() {
        return Err(Error::TwoCameraKinds);
    }
    Ok(match (base, v.probe()) {
        (None, Some((t, ph))) => probe_of_values(t, ph)?,
        (None, None) => v.camera().map(Camera::Ortho).ok_or(Error::NoCamera { probe_only, spelling })?,
        (Some((Camera::NormalProbe { .. }, _)), Some((t, ph))) if base_is_template => probe_of_values(t, ph)?,
        (Some((b @ Camera::NormalProbe { .. }, src)), Some((t, ph))) => {
            let c = probe_of_values(t, ph)?;
            if !c.same(&b) {
                return Err(Error::Contradiction {
                    one: format!("--theta-o/--phi-o give {c}"),
                    other: format!("{src} gives {b}"),
                });
            }
            b
        }
        (Some((Camera::Ortho(_), src)), Some(_)) => return Err(Error::ProbeValuesForOrtho { src }),
        (Some((Camera::Ortho(b), src)), None) if v.ortho_given() => {
            let c = v.over(&b);
            if !c.same_view(&b) {
                return Err(Error::Contradiction {
                    one: format!("the camera flags give {}", Camera::Ortho(c)),
                    other: format!("{src} gives {}", Camera::Ortho(b)),
                });
            }
            Camera::Ortho(b)
        }
        (Some((Camera::NormalProbe { .. }, src)), None) if v.ortho_given() => {
            return Err(Error::OrthoValuesForProbe { src });
        }
        (Some((c, _)), None) => c,
    })
}
