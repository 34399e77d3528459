//! Where the renderer put its text: the pixel box of every legend and text label of a figure, so
//! that placement can be checked (and decided) from boxes rather than from pixels.

/// A rectangle in pixels of the whole image, y growing downwards; `right` and `bottom` are
/// exclusive edges.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PxRect {
    /// Left edge, px.
    pub left: i32,
    /// Top edge, px.
    pub top: i32,
    /// Right edge, px.
    pub right: i32,
    /// Bottom edge, px.
    pub bottom: i32,
}

impl PxRect {
    /// Whether the two rectangles share any area (touching edges do not count).
    pub fn overlaps(&self, o: &PxRect) -> bool {
        self.left < o.right && o.left < self.right && self.top < o.bottom && o.top < self.bottom
    }

    /// The rectangle moved by `(dx, dy)` px.
    pub fn shifted(&self, (dx, dy): (i32, i32)) -> PxRect {
        PxRect {
            left: self.left + dx,
            top: self.top + dy,
            right: self.right + dx,
            bottom: self.bottom + dy,
        }
    }

    /// The rectangle grown by `m` px on every side.
    pub fn grown(&self, m: i32) -> PxRect {
        PxRect {
            left: self.left - m,
            top: self.top - m,
            right: self.right + m,
            bottom: self.bottom + m,
        }
    }
}

/// What a placed box holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoxKind {
    /// A legend (its frame).
    Legend,
    /// A value label inside the plot area: margins, crossovers, step characteristics, overlay
    /// names (with its white backdrop).
    Label,
    /// A tick label on an axis.
    Tick,
    /// An axis description or a title.
    Caption,
}

/// One placed box: which panel (index in [`crate::Figure::panels`]; 0 for single-area figures such
/// as heat maps), what it is, its text (empty for a legend) and where it is.
#[derive(Debug, Clone, PartialEq)]
pub struct PlacedBox {
    /// Panel index.
    pub panel: usize,
    /// What the box holds.
    pub kind: BoxKind,
    /// The text drawn (a legend's entries joined by " | ").
    pub text: String,
    /// Where, px of the whole image.
    pub rect: PxRect,
}

/// Every legend and text box of one rendered figure, in drawing order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Layout {
    /// The boxes.
    pub boxes: Vec<PlacedBox>,
}

impl Layout {
    /// The boxes of one kind.
    pub fn of(&self, kind: BoxKind) -> impl Iterator<Item = &PlacedBox> {
        self.boxes.iter().filter(move |b| b.kind == kind)
    }

    /// Pairs of boxes (indices into `boxes`) that hide each other: a legend over any other box, or
    /// two value labels over each other. Tick labels and captions sit outside the plot area, where
    /// only a legend placed outside can reach them.
    pub fn collisions(&self) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for (i, a) in self.boxes.iter().enumerate() {
            for (j, b) in self.boxes.iter().enumerate().skip(i + 1) {
                let legend = (a.kind == BoxKind::Legend) != (b.kind == BoxKind::Legend);
                let labels = a.kind == BoxKind::Label && b.kind == BoxKind::Label;
                if (legend || labels) && a.rect.overlaps(&b.rect) {
                    out.push((i, j));
                }
            }
        }
        out
    }

    /// The collisions in words, one per line (for test failures).
    pub fn describe_collisions(&self) -> String {
        self.collisions()
            .iter()
            .map(|&(i, j)| {
                let (a, b) = (&self.boxes[i], &self.boxes[j]);
                format!(
                    "panel {} {:?} '{}' {:?} overlaps panel {} {:?} '{}' {:?}",
                    a.panel, a.kind, a.text, a.rect, b.panel, b.kind, b.text, b.rect
                )
            })
            .collect::<Vec<_>>()
            .join("\n")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(left: i32, top: i32, right: i32, bottom: i32) -> PxRect {
        PxRect {
            left,
            top,
            right,
            bottom,
        }
    }

    #[test]
    fn legends_against_everything_labels_against_labels() {
        let b = |kind, rect| PlacedBox {
            panel: 0,
            kind,
            text: String::new(),
            rect,
        };
        let l = Layout {
            boxes: vec![
                b(BoxKind::Legend, r(0, 0, 10, 10)),
                b(BoxKind::Label, r(5, 5, 15, 15)),   // under the legend
                b(BoxKind::Label, r(10, 14, 20, 20)), // over the first label
                b(BoxKind::Tick, r(18, 18, 30, 30)),  // touches a label: ticks only meet legends
                b(BoxKind::Label, r(10, 0, 20, 4)),   // touches the legend's edge only
            ],
        };
        assert_eq!(l.collisions(), vec![(0, 1), (1, 2)]);
        assert!(l.describe_collisions().contains("Legend"));
    }
}
