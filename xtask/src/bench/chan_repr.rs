//! Placeholder.
use super::BenchArgs;
use crate::Result;
use crate::report::BenchRow;
pub fn run(_args: &BenchArgs) -> Result<Vec<BenchRow>> {
    Ok(Vec::new())
}
