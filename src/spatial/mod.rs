//! The cell grid (DynamO's *globals*): which bodies are near each other.
//!
//! The container's bounding box is divided into `nx × ny × nz` cells whose width is at least
//! the largest interaction diameter `w` of the registered bodies. Two bodies closer than `w`
//! then sit in neighbouring cells (Alder and Wainwright's cell method, paper 001 §5.4 step 5),
//! so a query looks at the members of the 27 cells around a point. The kernel registers the
//! centres of the particles' neighbour-list spheres here and queries the grid only when a
//! particle's neighbour list is rebuilt (see [`crate::kernel`]).
//!
//! Members are kept in intrusive doubly linked lists (`head` per cell, `next`/`prev` per
//! particle): insert, remove and move are `O(1)` and need no allocation.
//!
//! The kernel rebuilds the grid at a barrier when the particles have outgrown its cells.

use crate::shape::Vec3;

const NONE: u32 = u32::MAX;

/// A uniform cell grid over an axis-aligned box, periodic or bounded per axis.
#[derive(Clone, Debug)]
pub struct CellGrid {
    origin: Vec3,
    width: Vec3,
    dims: [u32; 3],
    periodic: [bool; 3],
    head: Vec<u32>,
    next: Vec<u32>,
    prev: Vec<u32>,
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

    #[inline]
    fn push_unique(&mut self, c: u32, dedup: bool) {
        if dedup && self.cells[..self.len].contains(&c) {
            return;
        }
        self.cells[self.len] = c;
        self.len += 1;
    }
}

impl CellGrid {
    /// A grid over `[min, max]` with cells at least `min_width` wide, for `n` particles.
    ///
    /// The cell count is capped at `4n + 64` (and each axis at 2^20) so that tiny particles
    /// in a big box cannot exhaust memory; the cells are then wider than needed, which is
    /// correct, only slower.
    pub fn new(min: Vec3, max: Vec3, periodic: [bool; 3], min_width: f64, n: usize) -> Self {
        let len = max - min;
        let cap = (4 * n + 64) as f64;
        let mut w = min_width.max(f64::MIN_POSITIVE);
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
        let ncells = (dims[0] * dims[1] * dims[2]) as usize;
        Self {
            origin: min,
            width,
            dims,
            periodic,
            head: vec![NONE; ncells],
            next: vec![NONE; n],
            prev: vec![NONE; n],
            cell_of: vec![NONE; n],
        }
    }

    /// Smallest cell width over the three axes.
    pub fn min_width(&self) -> f64 {
        self.width.min()
    }

    /// Number of cells along each axis.
    pub fn dims(&self) -> [u32; 3] {
        self.dims
    }

    /// The cell containing point `p` (clamped to the grid).
    pub fn cell_at(&self, p: &Vec3) -> u32 {
        let mut c = [0u32; 3];
        for k in 0..3 {
            let x = ((p[k] - self.origin[k]) / self.width[k]).floor();
            c[k] = x.clamp(0.0, (self.dims[k] - 1) as f64) as u32;
        }
        self.index(c)
    }

    #[inline]
    fn index(&self, c: [u32; 3]) -> u32 {
        c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])
    }

    #[inline]
    fn coords(&self, cell: u32) -> [u32; 3] {
        let x = cell % self.dims[0];
        let yz = cell / self.dims[0];
        [x, yz % self.dims[1], yz / self.dims[1]]
    }

    /// The cell particle `i` is registered in.
    #[inline]
    pub fn cell_of(&self, i: usize) -> u32 {
        self.cell_of[i]
    }

    /// Registers particle `i` in `cell`.
    #[inline]
    pub fn insert(&mut self, i: usize, cell: u32) {
        let h = self.head[cell as usize];
        self.next[i] = h;
        self.prev[i] = NONE;
        if h != NONE {
            self.prev[h as usize] = i as u32;
        }
        self.head[cell as usize] = i as u32;
        self.cell_of[i] = cell;
    }

    /// Unregisters particle `i`.
    #[inline]
    pub fn remove(&mut self, i: usize) {
        let (p, n) = (self.prev[i], self.next[i]);
        if p != NONE {
            self.next[p as usize] = n;
        } else {
            self.head[self.cell_of[i] as usize] = n;
        }
        if n != NONE {
            self.prev[n as usize] = p;
        }
        self.cell_of[i] = NONE;
    }

    /// The particles registered in `cell`.
    #[inline]
    pub fn members(&self, cell: u32) -> Members<'_> {
        Members {
            next: &self.next,
            cur: self.head[cell as usize],
        }
    }

    /// Whether some periodic axis has fewer than 3 cells, so that neighbour offsets alias.
    #[inline]
    fn aliased(&self) -> bool {
        (0..3).any(|k| self.periodic[k] && self.dims[k] < 3)
    }

    /// Neighbour cell along one axis (`None` past a bounded edge).
    #[inline]
    fn step(&self, c: u32, k: usize, d: i32) -> Option<u32> {
        let n = self.dims[k] as i32;
        let x = c as i32 + d;
        if (0..n).contains(&x) {
            Some(x as u32)
        } else if self.periodic[k] {
            Some(x.rem_euclid(n) as u32)
        } else {
            None
        }
    }

    /// The cell itself and its up to 26 neighbours, each once.
    pub fn neighbourhood(&self, cell: u32) -> CellSet {
        let c = self.coords(cell);
        // Neighbour coordinates per axis first (at most 3 each), then their products.
        let mut axes = [[0u32; 3]; 3];
        let mut counts = [0usize; 3];
        for k in 0..3 {
            for d in -1..=1 {
                if let Some(x) = self.step(c[k], k, d) {
                    axes[k][counts[k]] = x;
                    counts[k] += 1;
                }
            }
        }
        let dedup = self.aliased();
        let mut set = CellSet {
            cells: [0; 27],
            len: 0,
        };
        for &z in &axes[2][..counts[2]] {
            for &y in &axes[1][..counts[1]] {
                let row = self.dims[0] * (y + self.dims[1] * z);
                for &x in &axes[0][..counts[0]] {
                    set.push_unique(row + x, dedup);
                }
            }
        }
        set
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
    fn neighbourhood_is_27_cells_in_big_periodic_grid() {
        let g = CellGrid::new(
            Vec3::zeros(),
            Vec3::new(10.0, 10.0, 10.0),
            [true; 3],
            1.0,
            1000,
        );
        assert_eq!(g.dims(), [10, 10, 10]);
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

    #[test]
    fn members_follow_inserts_and_removes() {
        let mut g = CellGrid::new(Vec3::zeros(), Vec3::new(3.0, 3.0, 3.0), [true; 3], 1.0, 4);
        for i in 0..4 {
            g.insert(i, 5);
        }
        g.remove(2);
        g.remove(3);
        let mut m: Vec<_> = g.members(5).collect();
        m.sort();
        assert_eq!(m, vec![0, 1]);
    }
}
