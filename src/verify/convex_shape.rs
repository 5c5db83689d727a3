//! Check 10, any convex shape (sec. 2.1). UNFINISHED: placeholder that reports "not implemented".
use super::Ctx;
use super::check::Check;

pub const NAME: &str = "convex-shape";
pub const EQUATION: &str = "sec. 2.1";

pub fn run(_ctx: &Ctx) -> Result<Check, String> {
    Err("not implemented yet".into())
}
