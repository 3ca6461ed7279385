//! Input points: anything that is an `(x, y)` pair of numbers.

/// A 2-D point of a contour. Implemented for tuples and arrays of `f64`, `f32`, `i32`, `i64`,
/// `u16`, `u32` and `usize`, so integer pixel contours (e.g. `Vec<(u32, u32)>` from an MSER
/// detector) and floating-point polygons can be passed without conversion.
pub trait ContourPoint: Copy {
    /// The point's coordinates as `f64`.
    fn xy(self) -> (f64, f64);
}

macro_rules! impl_point {
    ($($t:ty),*) => {$(
        impl ContourPoint for ($t, $t) {
            #[inline]
            fn xy(self) -> (f64, f64) {
                (self.0 as f64, self.1 as f64)
            }
        }
        impl ContourPoint for [$t; 2] {
            #[inline]
            fn xy(self) -> (f64, f64) {
                (self[0] as f64, self[1] as f64)
            }
        }
    )*};
}

impl_point!(f64, f32, i32, i64, u16, u32, usize);
