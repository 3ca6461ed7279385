//! Grey conversion: `luminance` is OpenCV's 14-bit fixed-point BT.601 and `to_gray` keeps grey
//! images, scales 16-bit ones to 8 bits and ignores alpha.

use image::{DynamicImage, GrayAlphaImage, GrayImage, ImageBuffer, Luma, Rgb, RgbImage, RgbaImage};
use mser::{luminance, to_gray};

/// OpenCV's `cvtColor(RGB2GRAY)` on 8 bits: `(R·4899 + G·9617 + B·1868 + 2^13) >> 14`.
#[test]
fn luminance_is_opencvs_fixed_point() {
    // Primaries and extremes, values as OpenCV prints them.
    assert_eq!(luminance(0, 0, 0), 0);
    assert_eq!(luminance(255, 255, 255), 255);
    assert_eq!(luminance(255, 0, 0), 76);
    assert_eq!(luminance(0, 255, 0), 150);
    assert_eq!(luminance(0, 0, 255), 29);
    // Grey stays grey: the weights sum to 2^14.
    for g in 0..=255u8 {
        assert_eq!(luminance(g, g, g), g);
    }
    // Rounded to nearest, not truncated: 0.299 + 0.587 = 0.886 ↦ 1 (and green above, 149.7 ↦ 150).
    assert_eq!(luminance(1, 1, 0), 1);
    // Against the fixed-point formula on a grid of colours.
    for r in (0..=255u32).step_by(17) {
        for g in (0..=255u32).step_by(15) {
            for b in (0..=255u32).step_by(51) {
                let want = ((r * 4899 + g * 9617 + b * 1868 + 8192) >> 14) as u8;
                assert_eq!(luminance(r as u8, g as u8, b as u8), want, "{r} {g} {b}");
            }
        }
    }
}

#[test]
fn to_gray_keeps_grey_scales_16_bits_and_ignores_alpha() {
    // 8-bit grey: the same bytes.
    let g8 = GrayImage::from_raw(3, 1, vec![0, 77, 255]).unwrap();
    assert_eq!(to_gray(&DynamicImage::ImageLuma8(g8.clone())), g8);
    // 16-bit grey: scaled to 8 bits (257·k ↦ k).
    let g16: ImageBuffer<Luma<u16>, Vec<u16>> =
        ImageBuffer::from_raw(3, 1, vec![0, 257 * 77, 65535]).unwrap();
    assert_eq!(to_gray(&DynamicImage::ImageLuma16(g16)), g8);
    // Grey with alpha: the alpha channel is ignored.
    let ga = GrayAlphaImage::from_raw(3, 1, vec![0, 0, 77, 10, 255, 200]).unwrap();
    assert_eq!(to_gray(&DynamicImage::ImageLumaA8(ga)), g8);
    // Colour: through `luminance`, alpha ignored.
    let colours = [(255u8, 0u8, 0u8), (0, 255, 0), (12, 200, 99)];
    let want = GrayImage::from_raw(
        3,
        1,
        colours
            .iter()
            .map(|&(r, g, b)| luminance(r, g, b))
            .collect(),
    )
    .unwrap();
    let mut rgb = RgbImage::new(3, 1);
    let mut rgba = RgbaImage::new(3, 1);
    for (i, &(r, g, b)) in colours.iter().enumerate() {
        rgb.put_pixel(i as u32, 0, Rgb([r, g, b]));
        rgba.put_pixel(i as u32, 0, image::Rgba([r, g, b, (i * 100) as u8]));
    }
    assert_eq!(to_gray(&DynamicImage::ImageRgb8(rgb)), want);
    assert_eq!(to_gray(&DynamicImage::ImageRgba8(rgba)), want);
    assert_eq!(want.as_raw(), &[76, 150, luminance(12, 200, 99)]);
}

/// `GrayView::inverted` of a window of a strided buffer: a packed image of the window's size
/// whose every pixel is `255 − g` of the view's pixel there (the bytes outside the window, in the
/// stride's padding and beside it, play no part), down to a 1 × 1 window.
#[test]
fn inverted_is_255_minus_each_pixel_of_the_view() {
    let (bw, bh) = (11usize, 7usize);
    let buf: Vec<u8> = (0..bw * bh).map(|i| (i * 37 % 256) as u8).collect();
    let big = mser::GrayView::new(&buf, 9, bh, bw).unwrap();
    for (x0, y0, w, h) in [
        (0, 0, 9, 7),
        (2, 1, 5, 4),
        (8, 6, 1, 1),
        (3, 0, 1, 7),
        (0, 5, 9, 1),
    ] {
        let view = big.window(x0, y0, w, h).unwrap();
        let inv = view.inverted();
        assert_eq!((inv.width() as usize, inv.height() as usize), (w, h));
        for y in 0..h {
            for x in 0..w {
                let g = buf[(y0 + y) * bw + x0 + x];
                assert_eq!(
                    inv.get_pixel(x as u32, y as u32)[0],
                    255 - g,
                    "({x}, {y}) of {w}x{h}"
                );
            }
        }
    }
}
