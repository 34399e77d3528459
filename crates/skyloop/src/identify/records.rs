//! The segments of a log as separate records of sample indices, and the blocks of the jackknife and
//! the held-out validation cut from them: every estimate averages spectra within records and never
//! across the gap between two.

use std::ops::Range;

/// The records (sample ranges, in time order) cut into `count` blocks of (nearly) equal total length;
/// a block is the pieces of the records it covers.
pub(crate) fn blocks(records: &[Range<usize>], count: usize) -> Vec<Vec<Range<usize>>> {
    let total: usize = records.iter().map(|r| r.len()).sum();
    let cuts: Vec<usize> = (0..=count).map(|b| b * total / count).collect();
    (0..count)
        .map(|b| {
            let (lo, hi) = (cuts[b], cuts[b + 1]);
            let mut out = Vec::new();
            let mut at = 0;
            for r in records {
                // The record's samples occupy [at, at + len) of the concatenation.
                let (a, z) = (lo.max(at), hi.min(at + r.len()));
                if a < z {
                    out.push(r.start + (a - at)..r.start + (z - at));
                }
                at += r.len();
            }
            out
        })
        .collect()
}

/// The pieces of the chosen blocks as records: pieces that touch in time (one record cut by a block
/// boundary) are one record again.
pub(crate) fn pieces(blocks: &[Vec<Range<usize>>], chosen: &[usize]) -> Vec<Range<usize>> {
    let mut all: Vec<Range<usize>> = chosen.iter().flat_map(|&b| blocks[b].iter().cloned()).collect();
    all.sort_by_key(|r| r.start);
    let mut out: Vec<Range<usize>> = Vec::new();
    for r in all {
        match out.last_mut() {
            Some(last) if last.end == r.start => last.end = r.end,
            _ => out.push(r),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_cover_the_records_and_pieces_rejoin() {
        let recs = [0..10, 20..25, 40..55];
        let b = blocks(&recs, 3);
        assert_eq!(b, vec![vec![0..10], vec![20..25, 40..45], vec![45..55]]);
        // Leaving out the middle block: the first and last stay separate records.
        assert_eq!(pieces(&b, &[0, 2]), vec![0..10, 45..55]);
        // All blocks: the records themselves.
        assert_eq!(pieces(&b, &[0, 1, 2]), recs.to_vec());
    }
}
