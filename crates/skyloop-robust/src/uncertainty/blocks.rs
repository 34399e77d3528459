//! Block structures of Δ = blkdiag(Δ₁, …, Δₙ), as used by μ and by uncertain systems.
//!
//! Conventions follow MATLAB's `mussv`: block j of Δ is `rows × cols`, and the matrix M analysed
//! against Δ (singularity of I − MΔ) has Σ cols rows and Σ rows columns.

use crate::error::Result;
use crate::error::RobustError;

/// What kind of uncertainty one block of Δ is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlockKind {
    /// δ·I_r with δ complex, |δ| ≤ 1 (r = 1 is a plain complex scalar).
    ComplexScalar {
        /// Repetition r (size of the identity).
        repeat: usize,
    },
    /// δ·I_r with δ real, −1 ≤ δ ≤ 1.
    RealScalar {
        /// Repetition r (size of the identity).
        repeat: usize,
    },
    /// A full complex `rows × cols` matrix with σ̄ ≤ 1.
    Full {
        /// Rows of the block (it maps `cols` signals of M's output to `rows` inputs of M).
        rows: usize,
        /// Columns of the block.
        cols: usize,
    },
}

impl BlockKind {
    /// Rows of this block of Δ (the number of M columns it feeds).
    pub fn rows(&self) -> usize {
        match *self {
            BlockKind::ComplexScalar { repeat } | BlockKind::RealScalar { repeat } => repeat,
            BlockKind::Full { rows, .. } => rows,
        }
    }
    /// Columns of this block of Δ (the number of M rows it reads).
    pub fn cols(&self) -> usize {
        match *self {
            BlockKind::ComplexScalar { repeat } | BlockKind::RealScalar { repeat } => repeat,
            BlockKind::Full { cols, .. } => cols,
        }
    }
    /// True for δ·I blocks (their D-scales are full r×r matrices).
    pub fn is_scalar(&self) -> bool {
        !matches!(self, BlockKind::Full { .. })
    }
    /// True for real scalar blocks.
    pub fn is_real(&self) -> bool {
        matches!(self, BlockKind::RealScalar { .. })
    }
}

/// A block-diagonal structure of Δ: the blocks in order, with their offsets precomputed.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockStructure {
    blocks: Vec<BlockKind>,
    /// Offset of each block among M's rows (Δ's columns).
    row_off: Vec<usize>,
    /// Offset of each block among M's columns (Δ's rows).
    col_off: Vec<usize>,
}

impl BlockStructure {
    /// Builds a structure; every block must have positive dimensions and there must be at least one.
    pub fn new(blocks: Vec<BlockKind>) -> Result<Self> {
        if blocks.is_empty() {
            return Err(RobustError::InvalidArgument(
                "a block structure needs at least one block".into(),
            ));
        }
        let (mut row_off, mut col_off) = (Vec::new(), Vec::new());
        let (mut r, mut c) = (0, 0);
        for b in &blocks {
            if b.rows() == 0 || b.cols() == 0 {
                return Err(RobustError::InvalidArgument(format!(
                    "block {b:?} has a zero dimension"
                )));
            }
            row_off.push(r);
            col_off.push(c);
            r += b.cols();
            c += b.rows();
        }
        Ok(BlockStructure {
            blocks,
            row_off,
            col_off,
        })
    }

    /// Parses a spec such as `c1x1,c1x1,f2x2,r1,c3r`: `fMxN` or `cMxN` is a full complex M×N block
    /// (`c1x1` is a complex scalar), `cNr` a complex scalar repeated N times, `rN` a real scalar
    /// repeated N times (`r1` plain).
    pub fn parse(spec: &str) -> Result<Self> {
        let mut blocks = Vec::new();
        for (k, raw) in spec.split(',').enumerate() {
            let t = raw.trim().to_ascii_lowercase();
            let bad = || {
                RobustError::InvalidArgument(format!(
                    "block {} '{}' is not one of fMxN, cMxN, cNr, rN (N, M positive integers)",
                    k + 1,
                    raw.trim()
                ))
            };
            let num = |s: &str| -> Result<usize> {
                match s.parse::<usize>() {
                    Ok(n) if n > 0 && n <= 100_000 => Ok(n),
                    _ => Err(bad()),
                }
            };
            let (head, rest) = t.split_at(t.chars().next().map_or(0, |c| c.len_utf8()));
            let kind = match head {
                "r" => BlockKind::RealScalar {
                    repeat: num(rest.strip_suffix('r').unwrap_or(rest))?,
                },
                "c" if rest.ends_with('r') => BlockKind::ComplexScalar {
                    repeat: num(&rest[..rest.len() - 1])?,
                },
                "c" | "f" => {
                    let (m, n) = rest.split_once('x').ok_or_else(bad)?;
                    let (rows, cols) = (num(m)?, num(n)?);
                    if head == "c" && rows == 1 && cols == 1 {
                        BlockKind::ComplexScalar { repeat: 1 }
                    } else {
                        BlockKind::Full { rows, cols }
                    }
                }
                _ => return Err(bad()),
            };
            blocks.push(kind);
        }
        BlockStructure::new(blocks)
    }

    /// The blocks in order.
    pub fn blocks(&self) -> &[BlockKind] {
        &self.blocks
    }
    /// Number of blocks.
    pub fn len(&self) -> usize {
        self.blocks.len()
    }
    /// Always false: a structure has at least one block.
    pub fn is_empty(&self) -> bool {
        self.blocks.is_empty()
    }
    /// Rows M must have (Σ block columns).
    pub fn m_rows(&self) -> usize {
        self.blocks.iter().map(|b| b.cols()).sum()
    }
    /// Columns M must have (Σ block rows).
    pub fn m_cols(&self) -> usize {
        self.blocks.iter().map(|b| b.rows()).sum()
    }
    /// Range of M's rows read by block `j`.
    pub fn row_range(&self, j: usize) -> std::ops::Range<usize> {
        self.row_off[j]..self.row_off[j] + self.blocks[j].cols()
    }
    /// Range of M's columns fed by block `j`.
    pub fn col_range(&self, j: usize) -> std::ops::Range<usize> {
        self.col_off[j]..self.col_off[j] + self.blocks[j].rows()
    }
    /// True when any block is real.
    pub fn has_real(&self) -> bool {
        self.blocks.iter().any(|b| b.is_real())
    }
    /// The structure with one more full block appended (the performance block of the main loop theorem).
    pub fn with_full_block(&self, rows: usize, cols: usize) -> Result<Self> {
        let mut b = self.blocks.clone();
        b.push(BlockKind::Full { rows, cols });
        BlockStructure::new(b)
    }
    /// Checks that an `nr × nc` matrix M fits this structure.
    pub fn check_matrix(&self, nr: usize, nc: usize) -> Result<()> {
        if nr != self.m_rows() || nc != self.m_cols() {
            return Err(RobustError::Dimension(format!(
                "the block structure needs M of size {}x{}, got {nr}x{nc}",
                self.m_rows(),
                self.m_cols()
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_kind() {
        let s = BlockStructure::parse("c1x1, f2x3,r1,c3r,r2").expect("valid spec");
        assert_eq!(
            s.blocks(),
            &[
                BlockKind::ComplexScalar { repeat: 1 },
                BlockKind::Full { rows: 2, cols: 3 },
                BlockKind::RealScalar { repeat: 1 },
                BlockKind::ComplexScalar { repeat: 3 },
                BlockKind::RealScalar { repeat: 2 },
            ]
        );
        // M reads Δ's columns as rows: 1 + 3 + 1 + 3 + 2.
        assert_eq!(s.m_rows(), 10);
        assert_eq!(s.m_cols(), 9);
        assert_eq!(s.row_range(1), 1..4);
        assert_eq!(s.col_range(1), 1..3);
        assert_eq!(s.row_range(3), 5..8);
    }

    #[test]
    fn rejects_bad_specs() {
        for bad in [
            "",
            "x",
            "f2",
            "f0x1",
            "c0r",
            "r",
            "q1",
            "f2x",
            "c1x1,,c1x1",
            "r-1",
            "fxx2",
        ] {
            assert!(BlockStructure::parse(bad).is_err(), "{bad} should be rejected");
        }
    }
}
