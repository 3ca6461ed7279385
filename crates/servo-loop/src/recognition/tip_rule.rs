//! Which point of the gripper's far end is the tip ([`TipRule`]) and one camera's
//! measurements of that end ([`EndEstimate`]); the rules themselves are described in the
//! `silhouette` module.

use serde::{Deserialize, Serialize};

pub(super) fn far_end() -> TipRule {
    TipRule::FarEnd
}

/// Which point of the gripper's far end the recogniser reports as the tip.
///
/// The single-image rules trade accuracy against smoothness (measured on `arm-sim` with three
/// seeds the evaluation does not use; `docs/performance.md` at f7d00c4): `EndFace` finds
/// the middle of the finger ends to a median 0.26–0.50 px per camera (`FarEnd`: 2.1–5.1 px),
/// but where an end face has little contrast against the table the outline it reads moves with
/// the table's texture, so its tip changes less smoothly with the pose (camera 1: 90th
/// percentile of the step-to-step inconsistency 1.3–1.8 px against 0.75–0.81 px). `Learned`,
/// the default (the servo percept), combines them: on the same seeds 0.52–0.87 px on the worse
/// camera (`FarEnd` 2.8–4.0 px), and servoing on it ends, on the mean over the seeds, within
/// the run-to-run spread of `FarEnd` (lwpr after 5 corrections: 0.56 / 0.58 / 0.47 px against
/// 0.56 / 0.48 / 0.50 px).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TipRule {
    /// The far end of the silhouette from covered areas, centred across by the coverage:
    /// smooth in the pose, but ahead of the end face by up to its projected depth and
    /// off-centre when the cap is oblique.
    FarEnd,
    /// The middle of the end face (between the finger ends): the mean of the far cap's two
    /// outer corners on the outline (`end_face`); the far end when the outline shows no two
    /// sides.
    EndFace,
    /// The far end corrected by an offset learned from the end-face rule at random poses, then
    /// moved towards the end-face tip by at most half a pixel (opt-in: by up to `k σ` where the
    /// correction's local spread `σ` says it is unsure ([`SilhouetteConfig::face_gate`](crate::SilhouetteConfig::face_gate);
    /// `tip_correction`)): as smooth as the far end, nearly as accurate as the end face. Locates all cameras together
    /// ([`TipModel::locate_all`](super::TipModel::locate_all); the far ends of all cameras describe the pose) and needs
    /// [`TipModel::learn_correction`](super::TipModel::learn_correction).
    #[default]
    Learned,
}

/// One camera's measurements of the gripper's far end ([`TipModel::estimate_end`](super::TipModel::estimate_end)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EndEstimate {
    /// The far end of the silhouette (the `FarEnd` tip; pixels).
    pub far_end: [f64; 2],
    /// The middle of the end face (the `EndFace` tip), when the rule uses it and the outline
    /// shows two sides.
    pub end_face: Option<[f64; 2]>,
    /// Certainty in `[0, 1]`: the end window's covered area against the learned one.
    pub certainty: f64,
}

impl EndEstimate {
    /// The tip of a single-image rule: the far end, or the end face where the outline shows
    /// one (`Learned` combines the cameras in [`TipModel::tips`]; alone it is the far end).
    pub(super) fn single_image_tip(&self, rule: TipRule) -> [f64; 2] {
        match rule {
            TipRule::EndFace => self.end_face.unwrap_or(self.far_end),
            TipRule::FarEnd | TipRule::Learned => self.far_end,
        }
    }
}
