//! The cell grid (DynamO's *globals*): which bodies are near each other.
//!
//! The container's bounding box is divided into cells at one or more *levels*; level `l` has
//! cells at least `w_l` wide, with `w_0 > w_1 > …` (each level half as wide as the one
//! above). A body of interaction radius `R` is registered at the finest level whose cells are
//! at least `2R` wide. Two bodies of the same level that are closer than `w_l` then sit in
//! neighbouring cells (Alder and Wainwright's cell method, paper 001 §5.4 step 5), so a
//! same-level query looks at the 27 cells around a point; a query reaching further (a large
//! body looking for small ones at a fine level) looks at a `(2k+1)³` block with
//! `k = ⌈reach / w_l⌉`.
//!
//! One level is all a monodisperse scene uses. With a wide size distribution (concrete:
//! diameters 0.5–16 mm, ratio 32) a single level would need cells as wide as the largest
//! body, holding thousands of small ones; the levels keep every cell's population O(1).
//!
//! Members are kept in intrusive singly linked lists (`head` per cell, `next` per body):
//! insert is `O(1)`, remove walks the body's cell, and neither allocates. A cell holds `O(1)`
//! bodies (one or two in a dense packing), so the walk costs about what a `prev` link would,
//! without its 4 bytes per body (BENCHMARKS.md, "Memory").

use crate::prefetch;
use crate::shape::Vec3;
use smallvec::SmallVec;

const NONE: u32 = u32::MAX;

/// Cells whose first members [`CellGrid::for_each_within`] gathers before walking their
/// lists: a neighbour-list update of equal spheres visits some 20 cells.
const GATHER: usize = 32;

/// The cells of one level.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
struct Level {
    /// Actual cell widths per axis (≥ the requested width).
    width: Vec3,
    dims: [u32; 3],
    /// Index of this level's first cell in the grid's cell numbering.
    first: u32,
}

/// A multi-level uniform cell grid over an axis-aligned box, periodic or bounded per axis.
/// Serialisable so that a kernel checkpoint restores the exact member order of every cell.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct CellGrid {
    origin: Vec3,
    levels: Vec<Level>,
    periodic: [bool; 3],
    head: Vec<u32>,
    next: Vec<u32>,
    cell_of: Vec<u32>,
}

/// Up to 27 distinct cell indices.
pub struct CellSet {
    cells: [u32; 27],
    len: usize,
}

impl CellSet {
    /// The cells.
    #[inline]
    pub fn as_slice(&self) -> &[u32] {
        &self.cells[..self.len]
    }
}

/// Most levels a grid builds (a size ratio of 2⁷ = 128 between the coarsest and finest).
pub const MAX_LEVELS: usize = 8;

impl CellGrid {
    /// A single-level grid over `[min, max]` with cells at least `min_width` wide, for `n`
    /// bodies.
    pub fn new(min: Vec3, max: Vec3, periodic: [bool; 3], min_width: f64, n: usize) -> Self {
        Self::with_levels(min, max, periodic, &[min_width], n)
    }

    /// A grid with one level per requested width (decreasing), for `n` bodies.
    ///
    /// The cell count of a level is capped at `4n + 64` (and each axis at 2^20) so that tiny
    /// bodies in a big box cannot exhaust memory; its cells are then wider than asked, which
    /// is correct, only slower.
    pub fn with_levels(
        min: Vec3,
        max: Vec3,
        periodic: [bool; 3],
        widths: &[f64],
        n: usize,
    ) -> Self {
        assert!(!widths.is_empty() && widths.len() <= MAX_LEVELS);
        let len = max - min;
        let cap = (4 * n + 64) as f64;
        let mut levels = Vec::with_capacity(widths.len());
        let mut first = 0u32;
        for &requested in widths {
            let mut w = requested.max(f64::MIN_POSITIVE);
            let mut dims = [1u32; 3];
            loop {
                for k in 0..3 {
                    dims[k] = ((len[k] / w).floor() as u64).clamp(1, 1 << 20) as u32;
                }
                if (dims[0] as f64) * (dims[1] as f64) * (dims[2] as f64) <= cap {
                    break;
                }
                w *= 1.25;
            }
            let width = Vec3::new(
                len.x / dims[0] as f64,
                len.y / dims[1] as f64,
                len.z / dims[2] as f64,
            );
            levels.push(Level { width, dims, first });
            first += dims[0] * dims[1] * dims[2];
        }
        Self {
            origin: min,
            levels,
            periodic,
            head: vec![NONE; first as usize],
            next: vec![NONE; n],
            cell_of: vec![NONE; n],
        }
    }

    /// Number of levels.
    pub fn levels(&self) -> usize {
        self.levels.len()
    }

    /// Smallest cell width of `level` over the three axes.
    pub fn level_width(&self, level: usize) -> f64 {
        self.levels[level].width.min()
    }

    /// Smallest cell width of the coarsest level.
    pub fn min_width(&self) -> f64 {
        self.level_width(0)
    }

    /// The finest level whose cells are at least `diameter` wide (level 0 if none is).
    pub fn level_for(&self, diameter: f64) -> usize {
        (0..self.levels.len())
            .rev()
            .find(|&l| self.level_width(l) >= diameter)
            .unwrap_or(0)
    }

    /// The cell of `level` containing point `p` (clamped to the grid).
    pub fn cell_at(&self, level: usize, p: &Vec3) -> u32 {
        let lv = &self.levels[level];
        let c = self.coords_at(lv, p);
        lv.first + index(lv, c)
    }

    fn coords_at(&self, lv: &Level, p: &Vec3) -> [u32; 3] {
        std::array::from_fn(|k| {
            let x = floor_to_i64((p[k] - self.origin[k]) / lv.width[k]);
            x.clamp(0, i64::from(lv.dims[k]) - 1) as u32
        })
    }

    /// The level holding `cell` and its index.
    fn level_of_cell(&self, cell: u32) -> (usize, &Level) {
        self.levels
            .iter()
            .enumerate()
            .rev()
            .find(|(_, lv)| lv.first <= cell)
            .expect("level 0 starts at cell 0")
    }

    /// A sort key that orders cells along a Z-order (Morton) curve within each level, levels
    /// one after the other: the interleaved bits of the cell's coordinates (20 per axis: an
    /// axis has at most 2^20 cells), the level in the bits above them. Cells close in space
    /// get close keys along all three axes at once, where the row-major cell number keeps
    /// only the x-neighbours close: the kernel numbers its particles in this order so that a
    /// particle's neighbours share memory pages and cache lines.
    pub fn locality_key(&self, cell: u32) -> u64 {
        let (level, lv) = self.level_of_cell(cell);
        let c = coords(lv, cell - lv.first);
        (level as u64) << 60 | spread_bits(c[0]) | spread_bits(c[1]) << 1 | spread_bits(c[2]) << 2
    }

    /// The cell body `i` is registered in.
    #[inline]
    pub fn cell_of(&self, i: usize) -> u32 {
        self.cell_of[i]
    }

    /// Registers body `i` in `cell`, first among its members.
    #[inline]
    pub fn insert(&mut self, i: usize, cell: u32) {
        self.next[i] = self.head[cell as usize];
        self.head[cell as usize] = i as u32;
        self.cell_of[i] = cell;
    }

    /// Unregisters body `i`; the other members of its cell keep their order.
    #[inline]
    pub fn remove(&mut self, i: usize) {
        let cell = self.cell_of[i] as usize;
        let after = self.next[i];
        let mut at = self.head[cell];
        if at == i as u32 {
            self.head[cell] = after;
        } else {
            // `i` is a member of `cell`, so the walk meets it before the end.
            while self.next[at as usize] != i as u32 {
                at = self.next[at as usize];
            }
            self.next[at as usize] = after;
        }
        self.next[i] = NONE;
        self.cell_of[i] = NONE;
    }

    /// The bodies registered in `cell`.
    #[inline]
    pub fn members(&self, cell: u32) -> Members<'_> {
        Members {
            next: &self.next,
            cur: self.head[cell as usize],
        }
    }

    /// The cell itself and its up to 26 neighbours of the same level, each once.
    pub fn neighbourhood(&self, cell: u32) -> CellSet {
        let (_, lv) = self.level_of_cell(cell);
        let c = coords(lv, cell - lv.first);
        let mut axes = [[0u32; 3]; 3];
        let mut counts = [0usize; 3];
        for k in 0..3 {
            for d in -1..=1 {
                if let Some(x) = step(lv, self.periodic[k], c[k], k, d) {
                    if !axes[k][..counts[k]].contains(&x) {
                        axes[k][counts[k]] = x;
                        counts[k] += 1;
                    }
                }
            }
        }
        let mut set = CellSet {
            cells: [0; 27],
            len: 0,
        };
        for &z in &axes[2][..counts[2]] {
            for &y in &axes[1][..counts[1]] {
                let row = lv.first + lv.dims[0] * (y + lv.dims[1] * z);
                for &x in &axes[0][..counts[0]] {
                    set.cells[set.len] = row + x;
                    set.len += 1;
                }
            }
        }
        set
    }

    /// Calls `f` with every body registered at `level` in a cell within `reach` of `p` (a
    /// superset of the bodies whose registered point is within `reach`).
    #[inline]
    pub fn for_each_within<F: FnMut(usize)>(&self, level: usize, p: &Vec3, reach: f64, mut f: F) {
        let lv = &self.levels[level];
        // Widened by 1e-9 so that rounding never drops a cell that holds a body in reach.
        let limit = (reach * (1.0 + 1e-9)).powi(2);
        let along = |k: usize| self.axis_cells(lv, k, p[k], reach);
        let (xs, ys, zs) = (along(0), along(1), along(2));
        // The cells' first members are gathered, up to `GATHER` cells at a time, before their
        // lists are walked: the loads of the cells' heads and of their first members' links
        // then overlap, where a walk cell by cell waits for each head and link in turn behind
        // the mispredicted end of the list before (at 10⁶ bodies both arrays are out of
        // cache). The members come in the same order.
        let mut heads = [NONE; GATHER];
        let mut gathered = 0;
        let last = self.next.len().saturating_sub(1);
        let walk = |heads: &[u32], f: &mut F| {
            for &cur in heads {
                Members {
                    next: &self.next,
                    cur,
                }
                .for_each(&mut *f);
            }
        };
        // The block of cells, z outermost; corners beyond `reach` skipped by their summed gaps.
        for &(z, gz) in &zs {
            for &(y, gy) in &ys {
                let gyz = gz + gy;
                if gyz > limit {
                    continue;
                }
                let row = lv.first + lv.dims[0] * (y + lv.dims[1] * z);
                for &(x, gx) in &xs {
                    if gyz + gx > limit {
                        continue;
                    }
                    let head = self.head[(row + x) as usize];
                    // An empty cell asks for the last link instead: no branch on the load.
                    if let Some(link) = self.next.get((head as usize).min(last)) {
                        prefetch(link);
                    }
                    heads[gathered] = head;
                    gathered += 1;
                    if gathered == GATHER {
                        walk(&heads, &mut f);
                        gathered = 0;
                    }
                }
            }
        }
        walk(&heads[..gathered], &mut f);
    }

    /// The cells of `lv` along axis `k` that overlap `[x − reach, x + reach]`, wrapped on a
    /// periodic axis (the whole axis, each cell once, when the range would wrap onto itself;
    /// clamped on a bounded one), each with the squared distance from `x` to the cell along
    /// the axis (0 for a whole axis, where no distance is known). Taking the exact overlap
    /// rather than ±⌈reach/width⌉ cells around `x`'s cell scans about (2·reach/width + 1)
    /// cells per axis instead of (2·⌈reach/width⌉ + 1): 8 instead of 27 cells for a reach
    /// just over half a cell. The distances let a query skip the corners of its block, which
    /// lie beyond `reach` (about a quarter of the cells of a neighbour-list update); they are
    /// computed once per axis rather than once per cell. On a bounded axis the end
    /// cells also hold the points beyond the grid ([`Self::coords_at`] clamps), so they reach
    /// out to infinity.
    #[inline]
    fn axis_cells(&self, lv: &Level, k: usize, x: f64, reach: f64) -> SmallVec<[(u32, f64); 4]> {
        let n = lv.dims[k] as i64;
        let x = (x - self.origin[k]) / lv.width[k];
        let r = reach / lv.width[k];
        let (mut lo, mut hi) = (floor_to_i64(x - r), floor_to_i64(x + r));
        let open = !self.periodic[k];
        if open {
            (lo, hi) = (lo.clamp(0, n - 1), hi.clamp(0, n - 1));
        } else if hi - lo + 1 >= n {
            return (0..n as u32).map(|c| (c, 0.0)).collect();
        }
        let mut cells = SmallVec::new();
        for c in lo..=hi {
            let lower = if open && c == 0 {
                f64::NEG_INFINITY
            } else {
                c as f64
            };
            let upper = if open && c == n - 1 {
                f64::INFINITY
            } else {
                c as f64 + 1.0
            };
            let g = (lower - x).max(x - upper).max(0.0) * lv.width[k];
            cells.push((wrap_cell(c, n), g * g));
        }
        cells
    }
}

/// Cell coordinate `c` wrapped into `[0, n)`. The ranges of [`CellGrid::for_each_within`]
/// around points inside the box lie within one period of it, where one correction suffices;
/// `rem_euclid`, a 64-bit division per visited cell, is left for points further out.
#[inline]
fn wrap_cell(c: i64, n: i64) -> u32 {
    let once = if c < 0 {
        c + n
    } else if c >= n {
        c - n
    } else {
        c
    };
    (if (0..n).contains(&once) {
        once
    } else {
        c.rem_euclid(n)
    }) as u32
}

/// `⌊x⌋` as an integer (saturating; NaN gives 0). Written out because `f64::floor` is a libm
/// call on the baseline x86-64 target (no SSE4.1 `roundsd`), and the neighbour search
/// calls it for every coordinate of every query.
#[inline]
pub(crate) fn floor_to_i64(x: f64) -> i64 {
    let truncated = x as i64;
    truncated - i64::from((truncated as f64) > x)
}

/// The low 20 bits of `x` moved to every third bit (bit `k` to bit `3k`): one axis of a
/// Morton code.
fn spread_bits(x: u32) -> u64 {
    let mut v = u64::from(x) & 0xf_ffff;
    v = (v | v << 32) & 0x001f_0000_0000_ffff;
    v = (v | v << 16) & 0x001f_0000_ff00_00ff;
    v = (v | v << 8) & 0x100f_00f0_0f00_f00f;
    v = (v | v << 4) & 0x10c3_0c30_c30c_30c3;
    v = (v | v << 2) & 0x1249_2492_4924_9249;
    v
}

#[inline]
fn index(lv: &Level, c: [u32; 3]) -> u32 {
    c[0] + lv.dims[0] * (c[1] + lv.dims[1] * c[2])
}

#[inline]
fn coords(lv: &Level, local: u32) -> [u32; 3] {
    let x = local % lv.dims[0];
    let yz = local / lv.dims[0];
    [x, yz % lv.dims[1], yz / lv.dims[1]]
}

/// Neighbour coordinate along one axis (`None` past a bounded edge).
#[inline]
fn step(lv: &Level, periodic: bool, c: u32, k: usize, d: i32) -> Option<u32> {
    let n = lv.dims[k] as i32;
    let x = c as i32 + d;
    if (0..n).contains(&x) {
        Some(x as u32)
    } else if periodic {
        Some(x.rem_euclid(n) as u32)
    } else {
        None
    }
}

/// Iterator over the members of a cell.
pub struct Members<'a> {
    next: &'a [u32],
    cur: u32,
}

impl Iterator for Members<'_> {
    type Item = usize;
    #[inline]
    fn next(&mut self) -> Option<usize> {
        if self.cur == NONE {
            return None;
        }
        let i = self.cur as usize;
        self.cur = self.next[i];
        Some(i)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrapped_cells_match_the_euclidean_remainder() {
        for n in [1, 2, 3, 7] {
            for c in -5 * n..5 * n {
                assert_eq!(i64::from(wrap_cell(c, n)), c.rem_euclid(n), "c {c}, n {n}");
            }
        }
    }

    #[test]
    fn integer_floor_matches_f64_floor() {
        for x in [
            -2.5,
            -2.0,
            -1e-300,
            -0.0,
            0.0,
            1e-300,
            0.999_999_999_999_9,
            3.0,
            7.25,
            -1e15 - 0.5,
        ] {
            assert_eq!(floor_to_i64(x), x.floor() as i64, "{x}");
        }
        assert_eq!(floor_to_i64(f64::NAN), 0);
    }

    #[test]
    fn locality_keys_interleave_coordinate_bits_level_by_level() {
        let g = CellGrid::with_levels(
            Vec3::zeros(),
            Vec3::new(8.0, 8.0, 8.0),
            [true; 3],
            &[2.0, 1.0],
            1000,
        );
        // Level 0 is 4³ cells, level 1 8³; cell (x, y, z) = (1, 2, 3) of level 1.
        let cell = 64 + 1 + 8 * (2 + 8 * 3);
        // x = 001, y = 010, z = 011 → bits z1 y1 x1 z0 y0 x0 = 110 101 (bit 3k + axis).
        assert_eq!(g.locality_key(cell), (1 << 60) | 0b110_101);
        assert_eq!(spread_bits(0xf_ffff), 0x0249_2492_4924_9249);
        assert_eq!(spread_bits(0b1011), 0b1_000_001_001);
        // Keys of one level are distinct and every level-0 key is below every level-1 key.
        let mut keys: Vec<u64> = (0..64 + 512).map(|c| g.locality_key(c)).collect();
        assert!(keys[..64].iter().all(|&k| k < 1 << 60));
        keys.sort_unstable();
        keys.dedup();
        assert_eq!(keys.len(), 64 + 512);
    }

    #[test]
    fn neighbourhood_is_27_cells_in_big_periodic_grid() {
        let g = CellGrid::new(
            Vec3::zeros(),
            Vec3::new(10.0, 10.0, 10.0),
            [true; 3],
            1.0,
            1000,
        );
        assert_eq!(g.neighbourhood(0).as_slice().len(), 27);
        let walled = CellGrid::new(
            Vec3::zeros(),
            Vec3::new(10.0, 10.0, 10.0),
            [false; 3],
            1.0,
            1000,
        );
        assert_eq!(walled.neighbourhood(0).as_slice().len(), 8);
    }

    #[test]
    fn aliased_periodic_grid_lists_each_cell_once() {
        let g = CellGrid::new(Vec3::zeros(), Vec3::new(2.0, 2.0, 2.0), [true; 3], 1.0, 8);
        assert_eq!(g.neighbourhood(0).as_slice().len(), 8);
    }

    /// Members come newest first; removing the head, a middle member or the last one
    /// keeps the others in order, and the cell of a removed body is none.
    #[test]
    fn members_follow_inserts_and_removes_in_order() {
        let mut g = CellGrid::new(Vec3::zeros(), Vec3::new(3.0, 3.0, 3.0), [true; 3], 1.0, 6);
        for i in 0..5 {
            g.insert(i, 5);
        }
        g.insert(5, 7);
        assert_eq!(g.members(5).collect::<Vec<_>>(), vec![4, 3, 2, 1, 0]);
        g.remove(2);
        assert_eq!(g.members(5).collect::<Vec<_>>(), vec![4, 3, 1, 0]);
        g.remove(4);
        assert_eq!(g.members(5).collect::<Vec<_>>(), vec![3, 1, 0]);
        g.remove(0);
        assert_eq!(g.members(5).collect::<Vec<_>>(), vec![3, 1]);
        assert_eq!(g.cell_of(0), NONE);
        g.insert(4, 5);
        g.remove(5);
        assert_eq!(g.members(5).collect::<Vec<_>>(), vec![4, 3, 1]);
        assert_eq!(g.members(7).count(), 0);
        assert_eq!(g.cell_of(4), 5);
    }

    /// Every body whose registered point is within the reach (minimum image on periodic
    /// axes) is reported, for points inside the box and, on bounded axes, beyond it.
    #[test]
    fn for_each_within_reports_every_body_in_reach() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(3);
        let b = Vec3::new(12.0, 9.0, 15.0);
        for periodic in [[true; 3], [false; 3], [true, false, true]] {
            let mut g = CellGrid::with_levels(Vec3::zeros(), b, periodic, &[1.7], 400);
            let point = |rng: &mut rand_xoshiro::Xoshiro256PlusPlus| {
                Vec3::from_fn(|k, _| {
                    let x = rng.gen_range(-1.0..b[k] + 1.0);
                    if periodic[k] {
                        x.rem_euclid(b[k])
                    } else {
                        x
                    }
                })
            };
            let points: Vec<Vec3> = (0..400).map(|_| point(&mut rng)).collect();
            for (i, p) in points.iter().enumerate() {
                g.insert(i, g.cell_at(0, p));
            }
            for _ in 0..300 {
                let q = point(&mut rng);
                let reach = rng.gen_range(0.05..3.0);
                let mut found = vec![false; points.len()];
                let mut reported = Vec::new();
                g.for_each_within(0, &q, reach, |i| {
                    assert!(!found[i], "body {i} reported twice");
                    found[i] = true;
                    reported.push(i);
                });
                // Each cell's members come together and in their list's order (a block of
                // over `GATHER` cells is walked in parts).
                for run in reported.chunk_by(|&a, &b| g.cell_of(a) == g.cell_of(b)) {
                    let members: Vec<usize> = g.members(g.cell_of(run[0])).collect();
                    assert_eq!(run, &members[..]);
                }
                for (i, p) in points.iter().enumerate() {
                    let mut d = p - q;
                    for k in 0..3 {
                        if periodic[k] {
                            d[k] -= b[k] * (d[k] / b[k]).round();
                        }
                    }
                    assert!(
                        found[i] || d.norm() >= reach,
                        "{periodic:?}: body at {p:?} within {reach} of {q:?} not reported"
                    );
                }
            }
        }
    }

    #[test]
    fn levels_halve_and_queries_reach_across_periodic_faces() {
        let b = Vec3::new(16.0, 16.0, 16.0);
        let mut g = CellGrid::with_levels(Vec3::zeros(), b, [true; 3], &[4.0, 2.0, 1.0], 5000);
        assert_eq!(g.levels(), 3);
        assert_eq!(g.level_for(1.5), 1);
        assert_eq!(g.level_for(0.5), 2);
        // A fine-level body just across the periodic face is found from the far side.
        let p = Vec3::new(0.2, 8.0, 8.0);
        g.insert(0, g.cell_at(2, &p));
        let mut found = Vec::new();
        g.for_each_within(2, &Vec3::new(15.9, 8.0, 8.0), 2.5, |i| found.push(i));
        assert_eq!(found, vec![0]);
        found.clear();
        g.for_each_within(2, &Vec3::new(8.0, 8.0, 8.0), 2.5, |i| found.push(i));
        assert!(found.is_empty());
    }
}
