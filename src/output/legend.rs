//! The colour bar under a PNG preview of a `[color] by` render: the colormap across the width
//! (sRGB-encoded like the picture), and under it the values at its ends and what is mapped,
//! in font8x8's public-domain 8×8 glyphs.

use font8x8::legacy::BASIC_LEGACY;

use super::png::to_srgb8;
use crate::frame::Legend;

/// Rows the bar adds under the picture: a gap, the bar, a gap, one line of text, a gap.
pub const ROWS: u32 = 4 + 12 + 4 + 8 + 4;
const MARGIN: u32 = 4;

/// The legend's RGBA8 rows for a picture `width` wide (opaque white background).
pub fn rows(legend: &Legend, width: u32) -> Vec<u8> {
    let mut out = vec![255u8; (width * ROWS * 4) as usize];
    let mut put = |x: u32, y: u32, c: [u8; 4]| {
        if x < width && y < ROWS {
            let i = ((y * width + x) * 4) as usize;
            out[i..i + 4].copy_from_slice(&c);
        }
    };
    let bar = width.saturating_sub(2 * MARGIN).max(1);
    for x in 0..bar {
        let i = ((x as f64 / (bar - 1).max(1) as f64) * 255.0 + 0.5) as usize;
        let [r, g, b] = legend.lut[i.min(255)];
        for y in 4..16 {
            put(MARGIN + x, y, to_srgb8([r, g, b, 1.0]));
        }
    }
    let lo = short(legend.lo);
    let hi = short(legend.hi);
    let label = format!("{} ({})", legend.by, legend.colormap);
    let text_y = 20;
    let mut text = |s: &str, x0: u32| {
        for (n, ch) in s.chars().enumerate() {
            let glyph = BASIC_LEGACY.get(ch as usize).copied().unwrap_or([0; 8]);
            for (dy, row) in glyph.iter().enumerate() {
                for dx in 0..8 {
                    if row >> dx & 1 == 1 {
                        put(x0 + n as u32 * 8 + dx, text_y + dy as u32, [0, 0, 0, 255]);
                    }
                }
            }
        }
    };
    let w = |s: &str| s.chars().count() as u32 * 8;
    text(&lo, MARGIN);
    text(&hi, (MARGIN + bar).saturating_sub(w(&hi)));
    let middle = (width.saturating_sub(w(&label))) / 2;
    if middle > MARGIN + w(&lo) && middle + w(&label) + w(&hi) < MARGIN + bar {
        text(&label, middle);
    }
    out
}

/// A value in at most 4 significant digits.
fn short(v: f64) -> String {
    let s = format!("{v:.4}");
    let g = format!("{:.3e}", v);
    let t = s.trim_end_matches('0').trim_end_matches('.').to_string();
    if (v != 0.0 && (v.abs() >= 1e5 || v.abs() < 1e-3)) || t.len() > 9 {
        g
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bar_runs_through_the_colormap_and_the_ends_are_labelled() {
        let lut: Vec<[f32; 3]> = (0..256).map(|i| [i as f32 / 255.0, 0.0, 0.0]).collect();
        let legend = Legend { by: "z", colormap: "reds", lo: -1.5, hi: 2.0, lut };
        let rows = rows(&legend, 200);
        assert_eq!(rows.len(), 200 * ROWS as usize * 4);
        let red = |x: u32| rows[((8 * 200 + x) * 4) as usize];
        assert_eq!(red(MARGIN), 0);
        assert_eq!(red(MARGIN + 191), 255);
        assert!(red(100) > red(50));
        // Some black text pixels at both ends of the text line.
        let dark = |x0: u32, x1: u32| {
            (20..28).any(|y| (x0..x1).any(|x| rows[((y * 200 + x) * 4) as usize] == 0))
        };
        assert!(dark(MARGIN, 40) && dark(160, 196));
        assert_eq!(
            (short(-1.5), short(2.0), short(123456.0)),
            ("-1.5".into(), "2".into(), "1.235e5".into())
        );
    }
}
