//! The Okabe–Ito colour-blind-safe palette and the line styles built from it.

use plotters::style::RGBColor;

/// Black `#000000`.
pub const BLACK: RGBColor = RGBColor(0x00, 0x00, 0x00);
/// Orange `#E69F00`.
pub const ORANGE: RGBColor = RGBColor(0xE6, 0x9F, 0x00);
/// Sky blue `#56B4E9`.
pub const SKY_BLUE: RGBColor = RGBColor(0x56, 0xB4, 0xE9);
/// Bluish green `#009E73`.
pub const BLUISH_GREEN: RGBColor = RGBColor(0x00, 0x9E, 0x73);
/// Yellow `#F0E442` (too light for thin lines on white; used for fills only).
pub const YELLOW: RGBColor = RGBColor(0xF0, 0xE4, 0x42);
/// Blue `#0072B2`.
pub const BLUE: RGBColor = RGBColor(0x00, 0x72, 0xB2);
/// Vermillion `#D55E00`.
pub const VERMILLION: RGBColor = RGBColor(0xD5, 0x5E, 0x00);
/// Reddish purple `#CC79A7`.
pub const REDDISH_PURPLE: RGBColor = RGBColor(0xCC, 0x79, 0xA7);
/// Light grey for shaded regions and grids (not a data colour).
pub const LIGHT_GREY: RGBColor = RGBColor(0xE4, 0xE4, 0xE4);
/// Mid grey for reference lines (not a data colour).
pub const GREY: RGBColor = RGBColor(0x80, 0x80, 0x80);

/// The eight Okabe–Ito colours in their published order.
pub const OKABE_ITO: [RGBColor; 8] = [
    BLACK,
    ORANGE,
    SKY_BLUE,
    BLUISH_GREEN,
    YELLOW,
    BLUE,
    VERMILLION,
    REDDISH_PURPLE,
];

/// The seven Okabe–Ito colours that read well as lines on white, in drawing order
/// (yellow left out).
pub const LINE_COLOURS: [RGBColor; 7] = [
    BLUE,
    VERMILLION,
    BLUISH_GREEN,
    ORANGE,
    REDDISH_PURPLE,
    SKY_BLUE,
    BLACK,
];

/// How one series is drawn: a colour and whether its line is dashed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SeriesStyle {
    /// Line / marker colour.
    pub colour: RGBColor,
    /// Dashed line (used once the seven line colours are exhausted).
    pub dashed: bool,
}

/// The style of the `i`-th series: the seven line colours solid, then the same dashed,
/// then repeating. Distinct for the first 14 series.
pub fn series_style(i: usize) -> SeriesStyle {
    let n = LINE_COLOURS.len();
    SeriesStyle {
        colour: LINE_COLOURS[i % n],
        dashed: (i / n) % 2 == 1,
    }
}

/// `#rrggbb` text of a colour.
pub fn hex(c: RGBColor) -> String {
    format!("#{:02x}{:02x}{:02x}", c.0, c.1, c.2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn styles_distinct_for_fourteen_series() {
        let s: Vec<_> = (0..14).map(series_style).collect();
        for i in 0..s.len() {
            for j in 0..i {
                assert_ne!(s[i], s[j], "series {i} and {j} look the same");
            }
        }
        assert_eq!(series_style(14), series_style(0));
    }

    #[test]
    fn hex_text() {
        assert_eq!(hex(VERMILLION), "#d55e00");
        assert_eq!(hex(OKABE_ITO[4]), "#f0e442");
    }
}
