//! The reference LWPR library's XML model files (`lwpr_write_xml` / `lwpr_read_xml`), so models
//! move between the C library (and its Matlab and Python front ends) and this crate.
//!
//! The layout is the reference's: `<LWPR nIn nOut kernel>` with the model's `<integer>`,
//! `<scalar>`, `<vector>` and `<matrix>` elements (matrices written row by row), one
//! `<SubModel out_dim numRFS>` per output holding its `<ReceptiveField nReg>` elements with
//! every statistic of the field. Two attributes of `<LWPR>` are ours, `prune_rule` and
//! `arithmetic` (the reference ignores unknown attributes); a file without them is the
//! reference's and loads with [`PruneRule::ReferenceC`](crate::PruneRule) and
//! [`Arithmetic::Reference`](crate::Arithmetic), the rule and arithmetic it was trained with.
//!
//! Precision: we write every number in its shortest exact decimal form, so our files hold the
//! model exactly (write → read is the identical model, and the reference reads every bit of
//! it). The reference writes six decimals (`%12.6f` / `%12.6e`, chosen per vector by its first
//! element), so its files hold its model only to that precision, and `D` and `M` of a field no
//! longer satisfy `D = MᵀM` to [`METRIC_TOLERANCE`](crate::METRIC_TOLERANCE). Reading such a
//! file keeps `D` (what the reference's predictions use) and recomputes `M` as its Cholesky
//! factor, so predictions from the file agree with the reference's predictions from the same
//! file to rounding (`tests/integration/xml.rs` measures it); `init_M` is always recomputed from
//! `init_D`.
//!
//! Reading is stricter than the reference's reader: every field must be present exactly once
//! with the size its element declares and the model's dimensions require, every number finite,
//! unknown elements are errors, and the result passes every check of a loaded model
//! ([`LwprError::Format`](crate::LwprError), never a panic).

mod parse;
mod read;
mod write;

use std::path::Path;

use crate::error::{LwprError, Result};
use crate::model::Lwpr;

impl Lwpr {
    /// The model in the reference library's XML layout, every number exact (module `xml`).
    pub fn to_xml(&self) -> String {
        write::to_xml(self)
    }

    /// Reads a model from an XML model file's content: ours or one written by the reference
    /// library's `lwpr_write_xml` (module `xml`).
    pub fn from_xml(xml: &str) -> Result<Self> {
        let root = parse::parse(xml).map_err(LwprError::Format)?;
        read::model(&root)
    }

    /// Writes [`to_xml`](Self::to_xml) to `path` (through a temporary file in the same folder,
    /// so a failed write leaves no partial file).
    pub fn save_xml(&self, path: impl AsRef<Path>) -> Result<()> {
        crate::io::write_atomically(path.as_ref(), self.to_xml().as_bytes())
    }

    /// Reads an XML model file (see [`from_xml`](Self::from_xml)). A file that cannot be read
    /// is an [`LwprError::Io`] naming `path`.
    pub fn load_xml(path: impl AsRef<Path>) -> Result<Self> {
        let data = crate::io::read_file(path.as_ref())?;
        let s = std::str::from_utf8(&data)
            .map_err(|_| LwprError::Format("XML model file is not UTF-8".into()))?;
        Self::from_xml(s)
    }
}
