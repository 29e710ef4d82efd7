//! The translation search of the [`Aligner`]: branch and bound over
//! square blocks of shifts, each bounded from the pyramid (or the reach
//! tables) before its children are searched, best bound first.

use crate::math::sort_descending;
use crate::pose::pyramid::Pyramid;
use crate::pose::search::Aligner;

impl<const W: usize, const H: usize, const RW: usize, const PW: usize> Aligner<'_, W, H, RW, PW> {
    /// The best integer shift within `[centre − radius, centre + radius]` in
    /// both axes whose score beats `floor`, by branch and bound; `None` if
    /// none beats it. Ties keep the first found (blocks with the higher
    /// bound first). Each bound and score spends the grid rows it may read
    /// from the work budget ([`Self::with_budget`], [`Self::cost`]); when it
    /// runs out the search returns
    /// the best found so far and [`Self::cut`] is set. The radius is
    /// clamped to `2^(L+1)` cells (`L` the pyramid's levels: at least half
    /// the grid's larger side; the default window, ¼ of the ρ range, is
    /// that), so that at most 5 × 5 top blocks cover the window.
    pub(crate) fn search(
        &self,
        centre: (i32, i32),
        radius: i32,
        floor: u32,
    ) -> Option<((i32, i32), u32)> {
        // At most 5 × 5 top blocks of the largest pyramid level.
        let radius = radius.clamp(0, 2 << Pyramid::<W, H, PW>::LEVELS);
        let span = 2 * radius + 1;
        // Top level: blocks at most a quarter of the window, within the pyramid.
        let mut top = 0usize;
        while top < Pyramid::<W, H, PW>::LEVELS && (4i32 << top) < span {
            top += 1;
        }
        let side = 1i32 << top;
        let blocks = (span + side - 1) / side;
        let origin = (centre.0 - radius, centre.1 - radius);
        // Blocks are kept compact (8 bytes) relative to the origin: the
        // frames of the search are on the deepest stack path.
        let at = |b: &Block| (origin.0 + i32::from(b.col), origin.1 + i32::from(b.row));
        let mut tops: heapless::Vec<Block, TOP_BLOCKS> = heapless::Vec::new();
        for i in 0..blocks {
            for j in 0..blocks {
                let (col, row) = (j * side, i * side);
                let (c0, r0) = (origin.0 + col, origin.1 + row);
                if !self.spend(top) {
                    return None;
                }
                let b = if top == 0 {
                    self.score_above((c0, r0), floor)
                } else {
                    self.bound(top, c0, r0, floor)
                };
                if b > floor {
                    let _ = tops.push(Block::new(b, top, col, row));
                }
            }
        }
        let mut best: Option<((i32, i32), u32)> = None;
        let mut floor = floor;
        let last = span - 1;
        // Highest bound first.
        sort_descending(&mut tops, |t| u32::from(t.bound));
        let mut stack: heapless::Vec<Block, STACK> = heapless::Vec::new();
        for &block in &tops {
            if u32::from(block.bound) <= floor {
                break;
            }
            let _ = stack.push(block);
            while let Some(block) = stack.pop() {
                let (b, k) = (u32::from(block.bound), usize::from(block.level));
                if b <= floor || i32::from(block.col) > last || i32::from(block.row) > last {
                    continue;
                }
                if k == 0 {
                    // At level 0 the bound is the score.
                    floor = b;
                    best = Some((at(&block), b));
                    continue;
                }
                let half = 1i32 << (k - 1);
                let mut children = [Block::new(0, 0, 0, 0); 4];
                for (n, child) in children.iter_mut().enumerate() {
                    let col = i32::from(block.col) + half * (n as i32 & 1);
                    let row = i32::from(block.row) + half * (n as i32 >> 1);
                    let (c, r) = (origin.0 + col, origin.1 + row);
                    let cb = if col > last || row > last {
                        0
                    } else if !self.spend(k - 1) {
                        return best;
                    } else if k == 1 {
                        self.score_above((c, r), floor)
                    } else {
                        self.bound(k - 1, c, r, floor)
                    };
                    *child = Block::new(cb, k - 1, col, row);
                }
                // Push the lowest first so the highest is explored first.
                children.sort_unstable_by_key(|c| c.bound);
                for child in children {
                    if u32::from(child.bound) > floor {
                        let _ = stack.push(child);
                    }
                }
            }
        }
        best
    }
}

/// A block of shifts of the search: `2^level` square from `(col, row)`
/// cells past the window's origin, with its bound (scores ≤ 2 ×
/// [`ALIGN_POINTS`] fit 16 bits; offsets ≤ 8 · 2¹¹).
#[derive(Clone, Copy)]
struct Block {
    bound: u16,
    level: u8,
    col: u16,
    row: u16,
}

impl Block {
    fn new(bound: u32, level: usize, col: i32, row: i32) -> Self {
        Self {
            bound: bound.min(u32::from(u16::MAX)) as u16,
            level: level as u8,
            col: col.clamp(0, i32::from(u16::MAX)) as u16,
            row: row.clamp(0, i32::from(u16::MAX)) as u16,
        }
    }
}

/// Most top-level blocks of one search (a window of at most `4·2ᴸ + 1`
/// cells per axis in blocks of `2^top`, `4·2^top` ≥ the window or `top = L`).
const TOP_BLOCKS: usize = 25;
/// Depth-first stack: 4 children per level, 12 levels at most (W ≤ 2048).
const STACK: usize = 48;
