//! PNG output: the bitmap backend with text drawn at each glyph's side bearing.
//!
//! plotters 0.3.7 rasterizes ab_glyph text by placing every glyph's ink box at the pen position,
//! dropping the glyph's left side bearing: narrow glyphs (`1`, `.`) slide left and leave gaps, so
//! "12.1" reads "1 2.1". The layout (the advances, which the text boxes are measured with) is
//! right; only the drawing is wrong. This backend wraps `BitMapBackend` and draws text itself with
//! the same layout and the bearing kept; everything else passes through.

use ab_glyph::{Font as _, FontRef, ScaleFont as _};
use plotters::prelude::BitMapBackend;
use plotters_backend::{
    text_anchor::{HPos, VPos},
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
};

/// `BitMapBackend` with correct glyph placement (see the module docs).
pub(crate) struct PngBackend<'a> {
    inner: BitMapBackend<'a>,
    font: FontRef<'static>,
}

impl<'a> PngBackend<'a> {
    /// Wraps `inner`; `font` is the embedded font every text is drawn with.
    pub(crate) fn new(inner: BitMapBackend<'a>, font: &'static [u8]) -> Result<Self, String> {
        let font = FontRef::try_from_slice(font).map_err(|e| format!("the embedded font: {e}"))?;
        Ok(PngBackend { inner, font })
    }
}

type Res<E> = Result<(), DrawingErrorKind<E>>;

impl DrawingBackend for PngBackend<'_> {
    type ErrorType = <BitMapBackend<'static> as DrawingBackend>::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }
    fn ensure_prepared(&mut self) -> Res<Self::ErrorType> {
        self.inner.ensure_prepared()
    }
    fn present(&mut self) -> Res<Self::ErrorType> {
        self.inner.present()
    }
    fn draw_pixel(&mut self, p: BackendCoord, c: BackendColor) -> Res<Self::ErrorType> {
        self.inner.draw_pixel(p, c)
    }
    fn draw_line<S: BackendStyle>(&mut self, a: BackendCoord, b: BackendCoord, s: &S) -> Res<Self::ErrorType> {
        self.inner.draw_line(a, b, s)
    }
    fn draw_rect<S: BackendStyle>(
        &mut self,
        a: BackendCoord,
        b: BackendCoord,
        s: &S,
        fill: bool,
    ) -> Res<Self::ErrorType> {
        self.inner.draw_rect(a, b, s, fill)
    }
    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        s: &S,
    ) -> Res<Self::ErrorType> {
        self.inner.draw_path(path, s)
    }
    fn draw_circle<S: BackendStyle>(&mut self, c: BackendCoord, r: u32, s: &S, fill: bool) -> Res<Self::ErrorType> {
        self.inner.draw_circle(c, r, s, fill)
    }
    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        s: &S,
    ) -> Res<Self::ErrorType> {
        self.inner.fill_polygon(vert, s)
    }
    fn blit_bitmap(&mut self, pos: BackendCoord, size: (u32, u32), src: &[u8]) -> Res<Self::ErrorType> {
        self.inner.blit_bitmap(pos, size, src)
    }

    fn draw_text<T: BackendTextStyle>(&mut self, text: &str, style: &T, pos: BackendCoord) -> Res<Self::ErrorType> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        // The same box plotters measures (so anchoring matches the layout code), then the glyphs.
        let ((min_x, min_y), (max_x, max_y)) = style
            .layout_box(text)
            .map_err(|e| DrawingErrorKind::FontError(Box::new(e)))?;
        let (width, height) = (max_x - min_x, max_y - min_y);
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let trans = style.transform();
        let size = style.size() as f32;
        let font = self.font.as_scaled(size);
        let (w, h) = self.get_size();
        let mut pen = 0f32;
        let mut prev = None;
        for ch in text.chars() {
            let id = font.glyph_id(ch);
            if let Some(p) = prev {
                pen += font.kern(p, id);
            }
            prev = Some(id);
            if let Some(q) = font.outline_glyph(id.with_scale(size)) {
                let rect = q.px_bounds();
                let x0 = (pen + rect.min.x).round() as i32;
                // Floored, not truncated: `as` rounds toward zero, which at odd sizes moved the
                // ink of glyphs whose top lies below `size / 2` (the point, the comma) up and every
                // taller glyph down by half a pixel, so at 13 px the point sat a row above the
                // digits' baseline and read as a middle dot. `px_bounds` is in whole pixels, so
                // flooring shifts every glyph alike.
                let y0 = (size / 2.0 + rect.min.y).floor() as i32;
                let mut px = Vec::new();
                q.draw(|x, y, cov| px.push((x as i32 + x0, y as i32 + y0, cov)));
                for (x, y, cov) in px {
                    let (x, y) = trans.transform(x + dx - min_x, y + dy - min_y);
                    let (x, y) = (pos.0 + x, pos.1 + y);
                    if x >= 0 && x < w as i32 && y >= 0 && y < h as i32 {
                        let c = BackendColor {
                            alpha: color.alpha * f64::from(cov.clamp(0.0, 1.0)),
                            rgb: color.rgb,
                        };
                        self.inner.draw_pixel((x, y), c)?;
                    }
                }
            }
            pen += font.h_advance(id);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// Darkness (0–255) of every pixel of `text` drawn black on white at `size` px through
    /// [`PngBackend`], row-major in a `w`×`h` image.
    fn rasterize(text: &str, size: f64, (w, h): (u32, u32)) -> Vec<u8> {
        crate::render::register_font().unwrap();
        let mut buf = vec![255u8; (w * h * 3) as usize];
        {
            let mut b = PngBackend::new(BitMapBackend::with_buffer(&mut buf, (w, h)), crate::render::FONT).unwrap();
            let style = crate::render::text_style(size);
            b.draw_text(text, &style, (4, 4)).unwrap();
            b.present().unwrap();
        }
        buf.chunks(3).map(|p| 255 - p[0].min(p[1]).min(p[2])).collect()
    }

    /// The inked column runs of the image (one per glyph when glyphs do not touch), each with its
    /// lowest inked row.
    fn glyph_bottoms(ink: &[u8], (w, h): (u32, u32)) -> Vec<(u32, u32, u32)> {
        let inked = |x: u32, y: u32| ink[(y * w + x) as usize] > 100;
        let mut out: Vec<(u32, u32, u32)> = Vec::new();
        let mut start = None;
        for x in 0..=w {
            let any = x < w && (0..h).any(|y| inked(x, y));
            match (any, start) {
                (true, None) => start = Some(x),
                (false, Some(s)) => {
                    let bottom = (0..h).rev().find(|&y| (s..x).any(|c| inked(c, y))).unwrap();
                    out.push((s, x, bottom));
                    start = None;
                }
                _ => {}
            }
        }
        out
    }

    #[test]
    fn the_decimal_point_sits_on_the_baseline() {
        let dim = (80, 40);
        // Every text size the figures use (ticks and legends 13, notes 12, labels 14, titles 15).
        for size in [12.0, 13.0, 14.0, 15.0, 17.0, 20.0] {
            let g = glyph_bottoms(&rasterize("1.5", size, dim), dim);
            assert_eq!(g.len(), 3, "size {size}: glyphs {g:?}");
            let (one, dot, five) = (g[0].2, g[1].2, g[2].2);
            // A round glyph may overshoot the baseline by a row.
            assert!(
                one.abs_diff(five) <= 1,
                "size {size}: digits end at rows {one} and {five}"
            );
            // The point and the `1` both stand flat on the baseline: they end on the same row.
            // (The defect was one row, at 13 and 15 px: a ±1 row test would not see it.)
            assert_eq!(dot, one, "size {size}: the point ends at row {dot}, the `1` at {one}");
        }
    }
}
