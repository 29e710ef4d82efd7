//! Place recognition by the signature: `D(θ)` correlated over every shift
//! (the paper's own correlation, eqs. 11–12) is the same for a place seen
//! from any heading, so it ranks stored keyframes for a new scan without a
//! pose. It is a weak descriptor on its own (many rooms share their wall
//! directions: DESIGN.md §3g measured the right place first for 9–22 % of
//! revisits, among the first five for 20–45 %), so rank within a gate from
//! the pose's own uncertainty where there is one, take the first few, and
//! verify each by the prior-free estimate (confident, checked on the beams)
//! before it counts.

use heapless::Vec;

use crate::correlation::Correlation;
use crate::Score;

/// How alike two places are: the best Pearson correlation of their
/// signatures `D(θ)` (a reference's `signature().peaks()`) over every
/// circular shift, in [−1, 1] (Q16.16); 0 when either has no structure.
/// `HALF²` multiply-adds.
pub fn place_similarity<const HALF: usize>(a: &[u16; HALF], b: &[u16; HALF]) -> Score {
    let correlation = Correlation::of(a, b);
    correlation
        .best()
        .map_or(Score::ZERO, |peak| correlation.score(peak))
}

/// A stored place and how alike it is to the query.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PlaceMatch {
    /// The caller's index of the stored place.
    pub index: usize,
    /// [`place_similarity`] with the query.
    pub similarity: Score,
}

/// The `K` stored places most like `query`, most alike first (ties: the
/// earlier given first). `places` gives each stored place's index (the
/// caller's, e.g. a keyframe number) and signature `D(θ)`; filter it first
/// by whatever gate the caller has (distance from the pose, scans apart).
pub fn rank_places<'a, const HALF: usize, const K: usize>(
    query: &[u16; HALF],
    places: impl IntoIterator<Item = (usize, &'a [u16; HALF])>,
) -> Vec<PlaceMatch, K> {
    let mut best: Vec<PlaceMatch, K> = Vec::new();
    for (index, signature) in places {
        let candidate = PlaceMatch {
            index,
            similarity: place_similarity(query, signature),
        };
        let at = best
            .iter()
            .position(|m| m.similarity < candidate.similarity)
            .unwrap_or(best.len());
        if at < K {
            if best.is_full() {
                best.pop();
            }
            // Cannot fail: there is room after the pop.
            let _ = best.insert(at, candidate);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn signature<const HALF: usize>(values: [u16; HALF]) -> [u16; HALF] {
        values
    }

    /// A made-up place: walls at a few directions of given lengths.
    fn place(walls: &[(usize, u16)]) -> [u16; 36] {
        let mut d = [10u16; 36];
        for &(k, len) in walls {
            d[k % 36] += len;
            d[(k + 1) % 36] += len / 2;
        }
        d
    }

    #[test]
    fn a_place_turned_is_the_same_place() {
        let room = place(&[(0, 200), (9, 120), (20, 60)]);
        let mut turned = room;
        turned.rotate_left(13);
        let (a, b) = (signature(room), signature(turned));
        assert_eq!(place_similarity(&a, &b), Score::from_num(1));
        // Against the f64 Pearson correlation at the best shift.
        let other = signature(place(&[(3, 150), (5, 150), (30, 40)]));
        let got = place_similarity(&a, &other).to_num::<f64>();
        let want = (0..36)
            .map(|k| pearson(&room, &other, k))
            .fold(f64::MIN, f64::max);
        assert!((got - want).abs() < 1e-4, "{got} vs {want}");
    }

    fn pearson(a: &[u16; 36], b: &[u16; 36], shift: usize) -> f64 {
        let n = 36.0;
        let ma = a.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
        let mb = b.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
        let (mut num, mut va, mut vb) = (0.0, 0.0, 0.0);
        for i in 0..36 {
            let (x, y) = (f64::from(a[i]) - ma, f64::from(b[(i + shift) % 36]) - mb);
            num += x * y;
            va += x * x;
            vb += y * y;
        }
        num / (va * vb).sqrt()
    }

    #[test]
    fn ranking_keeps_the_most_alike_first() {
        let query = place(&[(0, 200), (9, 120)]);
        let mut seen = query;
        seen.rotate_left(5);
        let places = [
            signature(place(&[(4, 90), (20, 200), (30, 70)])),
            signature(seen),
            signature(place(&[(2, 200), (11, 50), (25, 100)])),
            signature([10; 36]),
        ];
        let ranked: Vec<PlaceMatch, 2> = rank_places(&signature(query), places.iter().enumerate());
        assert_eq!(ranked.len(), 2);
        assert_eq!(ranked[0].index, 1);
        assert!(ranked[0].similarity >= ranked[1].similarity);
        // No structure (a flat signature) is similarity 0, and nothing to
        // rank gives nothing.
        assert_eq!(place_similarity(&places[3], &signature(query)), Score::ZERO);
        let none: Vec<PlaceMatch, 2> = rank_places(&signature(query), core::iter::empty());
        assert!(none.is_empty());
    }
}
