//! The colours of every plotted series (benches and evaluation targets alike), so that one
//! method or tracker does not change colour from one figure to the next.

use plotters::style::RGBColor;

/// Series colours in the order they are handed out: blue, red, green, purple, orange, cyan,
/// brown, black, pink, olive (the first eight are those of the Paper A figures).
pub const SERIES: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(0, 0, 0),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
];

/// The colour of series `k`, cycling through [`SERIES`].
pub fn series(k: usize) -> RGBColor {
    SERIES[k % SERIES.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colours_are_distinct_and_cycle() {
        for (i, a) in SERIES.iter().enumerate() {
            for b in &SERIES[i + 1..] {
                assert_ne!((a.0, a.1, a.2), (b.0, b.1, b.2));
            }
        }
        let (a, b) = (series(3), series(3 + SERIES.len()));
        assert_eq!((a.0, a.1, a.2), (b.0, b.1, b.2));
    }
}
