//! Placeholder.
use super::EvalContext;
use crate::Result;
pub fn run(_ctx: &EvalContext) -> Result<()> {
    Ok(())
}
