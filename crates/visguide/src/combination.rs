//! The eight descriptor/sampling combinations of Paper A's Figures 4–6 and the four with
//! preselection of Figures 7–9.

use fd_match::{Method, Sampling};

/// One curve of the paper's figures: a matching method with a contour sampling.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Combination {
    /// Descriptor and error.
    pub method: Method,
    /// Contour sampling.
    pub sampling: Sampling,
}

impl Combination {
    /// The eight combinations, in the order of the paper's legends.
    pub const ALL: [Combination; 8] = [
        Combination::new(Method::FdCorr, Sampling::Canonical),
        Combination::new(Method::FdCorr, Sampling::AffineArcLength),
        Combination::new(Method::AbsFdSsd, Sampling::Canonical),
        Combination::new(Method::AbsFdSsd, Sampling::AffineArcLength),
        Combination::new(Method::Afd0Ssd, Sampling::Canonical),
        Combination::new(Method::Afd0Ssd, Sampling::AffineArcLength),
        Combination::new(Method::Afd1Ssd, Sampling::AffineArcLength),
        Combination::new(Method::Afd1Ssd, Sampling::Canonical),
    ];

    /// The combinations of Figures 7–9 (precision with preselection), in the paper's order:
    /// AFD0 SSD/Affine, AFD1 SSD/Affine, FD Corr/Canonical, FD Corr/Affine.
    pub const PRESELECTED: [Combination; 4] = [
        Combination::new(Method::Afd0Ssd, Sampling::AffineArcLength),
        Combination::new(Method::Afd1Ssd, Sampling::AffineArcLength),
        Combination::new(Method::FdCorr, Sampling::Canonical),
        Combination::new(Method::FdCorr, Sampling::AffineArcLength),
    ];

    /// The combination whose matches the pictures show: FD Corr/Affine, the paper's method.
    pub const SHOWN: Combination = Combination::new(Method::FdCorr, Sampling::AffineArcLength);

    /// A combination.
    pub const fn new(method: Method, sampling: Sampling) -> Self {
        Combination { method, sampling }
    }

    /// The legend label of the paper, e.g. `FD Corr/Affine`.
    pub fn label(&self) -> String {
        self.method.label(self.sampling)
    }

    /// Paper A's preselection threshold `T_err` (§5.2), for the four combinations that have one.
    pub fn preselection_threshold(&self) -> Option<f64> {
        self.method.paper_preselection_threshold(self.sampling)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eight_distinct_labels_and_four_thresholds() {
        let labels: Vec<String> = Combination::ALL.iter().map(|c| c.label()).collect();
        assert_eq!(labels[0], "FD Corr/Canonical");
        assert_eq!(labels[3], "abs(FD) SSD/Affine");
        let mut dedup = labels.clone();
        dedup.sort();
        dedup.dedup();
        assert_eq!(dedup.len(), 8);
        let t: Vec<f64> = Combination::PRESELECTED
            .iter()
            .map(|c| c.preselection_threshold().unwrap())
            .collect();
        assert_eq!(t, vec![1e-4, 5e-4, 1e-3, 1e-3]);
    }
}
