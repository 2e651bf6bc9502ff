//! Neighbour lists (Donev, Torquato, Stillinger 2005): the state the kernel keeps to know
//! which pairs a prediction must look at, beside the event loop and the prediction passes
//! that read it ([`NeighbourLists`]).
//!
//! The kernel calls this module to build every list (at the start and when image tracking
//! switches on), to move one particle's list sphere and rebuild its list (its list-update
//! event), to renumber the particles in cell order with the grid, to record list exits and
//! to adapt the skin; the prediction passes read lists, list spheres, exits and separations
//! through narrow inline accessors, so the hot loops stay monomorphised and index the same
//! arrays as before.

use super::images;
use super::{permute_in_place, Particle};
use crate::boundary::Boundary;
use crate::prefetch;
use crate::shape::{Collidable, EnvelopeModel, PeriodicImages, Vec3};
use crate::spatial::{CellGrid, MAX_LEVELS};
use crate::tuning::MAX_SKIN;

/// Neighbours held inline in a particle's list before it moves to the heap.
///
/// 14 `u32`s and the length make 64 bytes, one cache line. Lists of equal spheres hold about
/// 12–14 partners from the fluid to jamming (the skin adapts), so they rarely leave the line;
/// large particles among small ones spill to the heap. Against a `Vec` per particle this
/// saves the 24-byte header and a heap block with its allocator overhead (peak memory of a
/// 2·10⁵-sphere run 67.0 → 64.4 MB) and a pointer chase in every prediction.
pub(crate) const NEIGHBOURS_INLINE: usize = 14;

/// A particle's neighbour list (indices of the particles whose list spheres overlap its own).
pub(crate) type NeighbourList = smallvec::SmallVec<[u32; NEIGHBOURS_INLINE]>;

/// A neighbour-list sphere (see [`NeighbourLists`]): the centre and the radius share one
/// 32-byte record, so the list updates, which test a sphere against some fifty candidates,
/// and the list-exit predictions load one cache line per sphere rather than two.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
#[repr(C, align(32))]
pub(crate) struct ListSphere {
    /// Centre (wrapped into the box).
    pub(super) centre: Vec3,
    /// Radius.
    pub(super) radius: f64,
}

/// The neighbour lists of a kernel: list spheres, envelopes and their exits, the lists, the
/// cell grid over the sphere centres and the skin.
///
/// Invariants, between any two events of the kernel:
/// - **Spheres.** Particle `i` owns a list sphere of centre `c_i` (its centre, wrapped into
///   the box, when its list was last built) and radius `R_i = r_i + skin·min(l_i, l̄)`, with
///   `r_i` its bounding radius and `l_i` its skin length ([`Collidable::skin_length`], `r_i`
///   for spheres) at that time and `l̄` the mean skin length at the start of the barrier
///   interval: the skin is relative to the skin length, and a big particle's shell is
///   no thicker than a typical particle's.
/// - **Containment.** `i` stays inside its list sphere, `|p_i(t) − c_i| + r_i(t) ≤ R_i`
///   (and inside its envelope, [`EnvelopeModel`]), until its list-update event, which the
///   kernel predicts from [`Self::sphere`] or the recorded exit ([`Self::exits`]) and
///   handles by [`Self::update`]. So two particles whose spheres (or envelopes) do not
///   overlap cannot touch before one of them updates its list.
/// - **Completeness and symmetry.** `N(i)` holds every `j ≠ i` whose sphere and envelope
///   overlap `i`'s, and `j ∈ N(i) ⇔ i ∈ N(j)`. With image tracking an entry names a partner
///   and a lattice shift ([`images`]): `(j, n) ∈ N(i) ⇔ (i, −n) ∈ N(j)`, and `i`'s own
///   overlapping images are listed once per pair of opposite shifts.
/// - **Grid.** The grid indexes every sphere centre at the finest level whose cells hold
///   its diameter, and its coarsest cells hold every sphere's diameter (the kernel rebuilds
///   it before spheres outgrow it, [`Self::needed_cell_width`]).
/// - **Numbering.** Entries and arrays use the kernel's current particle numbering, which
///   [`Self::rebuild_grid`] changes together with the kernel's own arrays.
pub(super) struct NeighbourLists<S: Collidable> {
    /// The neighbour-list spheres.
    spheres: Vec<ListSphere>,
    /// Neighbour envelopes ([`Collidable::Envelope`]) of the lists, [`EnvelopeModel::kept`]
    /// of them (one per particle, or none when the list sphere is the envelope); read and
    /// written only by the envelope model.
    envelopes: Vec<S::Envelope>,
    /// Kernel time up to which each particle provably stays inside its envelope (its
    /// list-update event), recorded before its prediction passes
    /// ([`Self::refresh_exit`]); as many as envelopes, and read and written only by the
    /// envelope model. Pair predictions look no further than the earlier of the two:
    /// whichever particle updates its list then predicts the pair again.
    exits: Vec<f64>,
    /// Symmetric neighbour lists: `j ∈ neighbours[i] ⇔ i ∈ neighbours[j]`.
    neighbours: Vec<NeighbourList>,
    /// Cell grid over the neighbour-list sphere centres.
    grid: CellGrid,
    /// Current neighbour-list skin (relative to the skin length).
    skin: f64,
    /// Mean skin length ([`Collidable::skin_length`]; the bounding radius for spheres) at
    /// the start of the current barrier interval.
    mean_radius: f64,
    /// Lower and upper corners of the region where a list sphere needs no minimum image
    /// ([`free_of_images`]); set with the grid.
    image_free_zone: [Vec3; 2],
    /// Neighbour-list updates counted when the particles were last sorted into cell order.
    updates_at_sort: u64,
    /// Whether neighbour-list entries and collision partners carry periodic image shifts
    /// ([`images`]): the shape's licence ([`PeriodicImages::tracking`]) once switched on, for
    /// good, at a barrier where list spheres can reach half the shortest periodic edge.
    /// Always `None` for shapes without images ([`crate::shape::NoImages`] has no value), so
    /// every test of it is a constant there.
    images: Option<S::Images>,
    /// Reused buffer for the candidates of a list build ([`Self::overlapping_lists`],
    /// [`Self::list_candidates`]).
    candidates: Vec<u32>,
}

impl<S: Collidable> NeighbourLists<S> {
    /// Lists for `particles` (wrapped into the box) with spheres of radius 0 at their
    /// centres, empty lists, no grid and the skin `skin`: the kernel sizes the spheres
    /// ([`Self::size_spheres`]), builds the grid and then the lists.
    pub(super) fn new<B: Boundary>(particles: &[Particle<S>], boundary: &B, skin: f64) -> Self {
        let n = particles.len();
        Self {
            spheres: particles
                .iter()
                .map(|p| ListSphere {
                    centre: p.pos,
                    radius: 0.0,
                })
                .collect(),
            envelopes: vec![S::Envelope::default(); S::Envelope::kept(n)],
            exits: vec![0.0; S::Envelope::kept(n)],
            neighbours: vec![NeighbourList::new(); n],
            grid: CellGrid::new(boundary.min(), boundary.max(), boundary.periodic(), 1.0, 0),
            skin,
            mean_radius: 0.0,
            // Nowhere until the grid is built.
            image_free_zone: [Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY)],
            updates_at_sort: 0,
            images: None,
            candidates: Vec::new(),
        }
    }

    /// Lists restored from a kernel snapshot (`super::checkpoint`, which has checked the
    /// lengths and indices); the exits are recomputed when the next interval begins.
    #[allow(clippy::too_many_arguments)] // the snapshot's fields, one each
    pub(super) fn restore<B: Boundary>(
        spheres: Vec<ListSphere>,
        envelopes: Vec<S::Envelope>,
        neighbours: Vec<NeighbourList>,
        grid: CellGrid,
        boundary: &B,
        updates_at_sort: u64,
        skin: f64,
        mean_radius: f64,
        images: Option<S::Images>,
    ) -> Self {
        let image_free_zone = image_free_zone(boundary, &grid);
        Self {
            spheres,
            exits: vec![0.0; envelopes.len()],
            envelopes,
            neighbours,
            grid,
            skin,
            mean_radius,
            image_free_zone,
            updates_at_sort,
            images,
            candidates: Vec::new(),
        }
    }

    /// The list spheres (for snapshots).
    pub(super) fn spheres(&self) -> &[ListSphere] {
        &self.spheres
    }

    /// The envelopes (for snapshots).
    pub(super) fn envelopes(&self) -> &[S::Envelope] {
        &self.envelopes
    }

    /// Every neighbour list (for snapshots).
    pub(super) fn all(&self) -> &[NeighbourList] {
        &self.neighbours
    }

    /// The cell grid over the sphere centres.
    pub(super) fn grid(&self) -> &CellGrid {
        &self.grid
    }

    /// Neighbour-list updates counted when the particles were last sorted into cell order.
    pub(super) fn updates_at_sort(&self) -> u64 {
        self.updates_at_sort
    }

    /// Mean skin length at the start of the current barrier interval.
    pub(super) fn mean_radius(&self) -> f64 {
        self.mean_radius
    }

    /// Current skin, relative to the skin length (the kernel's [`super::Edmd::skin`] says
    /// how it adapts).
    pub(super) fn skin(&self) -> f64 {
        self.skin
    }

    /// Particle `i`'s neighbour list.
    #[inline(always)]
    pub(super) fn list(&self, i: usize) -> &NeighbourList {
        &self.neighbours[i]
    }

    /// Particle `i`'s list sphere.
    #[inline(always)]
    pub(super) fn sphere(&self, i: usize) -> &ListSphere {
        &self.spheres[i]
    }

    /// The recorded envelope exits ([`EnvelopeModel::pair_horizon`],
    /// [`EnvelopeModel::list_update`]); empty when the list sphere is the envelope.
    #[inline(always)]
    pub(super) fn exits(&self) -> &[f64] {
        &self.exits
    }

    /// The licence to track images, while the lists track them.
    #[inline(always)]
    pub(super) fn images(&self) -> Option<S::Images> {
        self.images
    }

    /// Whether neighbour entries carry image shifts (never for shapes without images,
    /// [`crate::shape::NoImages`]: the test then compiles to `false`).
    #[inline(always)]
    pub(super) fn tracks_images(&self) -> bool {
        self.images.is_some()
    }

    /// Particle index of a neighbour entry.
    #[inline(always)]
    pub(super) fn partner_index(&self, entry: u32) -> usize {
        if self.tracks_images() {
            images::index(entry)
        } else {
            entry as usize
        }
    }

    /// Separation `c_i − c_j` of `i` at `pos_i` and the image of `j` at `pos_j` that the
    /// neighbour entry names: the minimum image, or with images the list-sphere offset of
    /// the entry's image plus each particle's (minimum-image) offset from its list centre.
    #[inline(always)]
    pub(super) fn separation<B: Boundary>(
        &self,
        boundary: &B,
        i: usize,
        pos_i: &Vec3,
        j: usize,
        pos_j: &Vec3,
        entry: u32,
    ) -> Vec3 {
        if self.tracks_images() {
            let mut offset_i = pos_i - self.spheres[i].centre;
            let mut offset_j = pos_j - self.spheres[j].centre;
            boundary.minimum_image(&mut offset_i);
            boundary.minimum_image(&mut offset_j);
            let image = images::translation(images::shift(entry), &period(boundary));
            return self.spheres[i].centre - self.spheres[j].centre - image + (offset_i - offset_j);
        }
        let mut dr = pos_i - pos_j;
        boundary.minimum_image(&mut dr);
        dr
    }

    /// Whether the separations between `i` and its neighbours (their centres and their list
    /// spheres' centres) are their own minimum images ([`free_of_images`]): then a pass
    /// over `i`'s list skips [`Boundary::minimum_image_lanes`].
    #[inline]
    pub(super) fn pairs_free_of_images(&self, i: usize) -> bool {
        let s = &self.spheres[i];
        free_of_images(&s.centre, s.radius, &self.image_free_zone)
    }

    /// Radius of a neighbour-list sphere for a particle of bounding radius `r` and skin
    /// length `l` ([`Collidable::skin_length`], `≤ r`; `r` itself for spheres):
    /// `r + skin·min(l, l̄)` with `l̄` the mean skin length. Small particles get a skin
    /// proportional to their size; large ones a shell no thicker than that of a typical
    /// particle, so a big particle's list holds the small ones touching its surface, not a
    /// thick layer of them (its list is re-predicted at every one of its collisions).
    #[inline]
    fn radius_for(&self, r: f64, l: f64) -> f64 {
        r + self.skin * l.min(self.mean_radius)
    }

    /// Adapts the skin to the list updates and collisions of the last interval of `n`
    /// particles (the rule: [`super::Edmd::skin`]).
    pub(super) fn adapt_skin(&mut self, collisions: u64, updates: u64, n: usize) {
        if collisions + updates < n as u64 {
            return; // too few events to judge
        }
        let ratio = updates as f64 / collisions.max(1) as f64;
        if ratio > 0.15 {
            self.skin = (self.skin * 1.2).min(MAX_SKIN);
        } else if ratio < 0.05 {
            self.skin = (self.skin / 1.2).max(0.01);
        }
    }

    /// Sets the mean skin length from the particles at kernel time 0.
    pub(super) fn update_mean_radius(&mut self, particles: &[Particle<S>]) {
        let n = particles.len().max(1) as f64;
        let sum: f64 = particles.iter().map(|p| p.shape.skin_length(0.0)).sum();
        self.mean_radius = sum / n;
    }

    /// Sizes every list sphere and builds every envelope for the particles at kernel time
    /// 0 (a new kernel).
    pub(super) fn size_spheres(&mut self, particles: &[Particle<S>]) {
        for (i, p) in particles.iter().enumerate() {
            let shape = &p.shape;
            let (r, l) = (shape.bounding_radius(0.0), shape.skin_length(0.0));
            self.spheres[i].radius = self.radius_for(r, l);
            let skin = self.spheres[i].radius - r;
            S::Envelope::build(&mut self.envelopes, i, &p.shape, &p.spin, 0.0, skin);
        }
    }

    /// Cell width that holds every neighbour-list sphere existing now or built for a
    /// particle of bounding radius up to `r`.
    pub(super) fn needed_cell_width(&self, r: f64) -> f64 {
        let current = self
            .spheres
            .iter()
            .fold(0.0_f64, |m, s| m.max(2.0 * s.radius));
        current.max(2.0 * self.radius_for(r, r))
    }

    /// Rebuilds the cell grid of list centres for cells at least `width` wide, and
    /// renumbers the particles in cell order (cells along a Morton curve,
    /// [`CellGrid::locality_key`]) so that neighbours sit close in memory. The lists
    /// permute their own arrays and rewrite their entries; `permute_others(order, visited)`
    /// permutes the kernel's (`v_new[i] = v_old[order[i]]`, [`permute_in_place`] with the
    /// scratch `visited`). `updates` is the kernel's count of list updates now.
    pub(super) fn rebuild_grid<B: Boundary>(
        &mut self,
        boundary: &B,
        width: f64,
        updates: u64,
        permute_others: impl FnOnce(&[u32], &mut [bool]),
    ) {
        let b = boundary;
        let n = self.spheres.len();
        // Levels halve down to the smallest neighbour-list sphere (one level when all are
        // alike).
        let smallest = self
            .spheres
            .iter()
            .fold(f64::INFINITY, |m, s| m.min(2.0 * s.radius));
        let mut widths = vec![width];
        while widths.len() < MAX_LEVELS && widths[widths.len() - 1] * 0.5 >= smallest {
            widths.push(widths[widths.len() - 1] * 0.5);
        }
        self.grid = CellGrid::with_levels(b.min(), b.max(), b.periodic(), &widths, n);
        self.image_free_zone = image_free_zone(b, &self.grid);
        // The keys are dropped before `new_index` exists and the cells are looked up again
        // after the permutation, so the renumbering's scratch peaks at 12 bytes per particle
        // (the memory target is ≤ 300 B per particle at N = 10⁶).
        let keys: Vec<u64> = (0..n)
            .map(|i| self.grid.locality_key(self.home_cell(i)))
            .collect();
        let mut order: Vec<u32> = (0..n as u32).collect();
        order.sort_unstable_by_key(|&i| (keys[i as usize], i));
        drop(keys);
        let mut new_index = vec![0u32; n];
        for (new, &old) in order.iter().enumerate() {
            new_index[old as usize] = new as u32;
        }
        let mut visited = vec![false; n];
        permute_in_place(&mut self.spheres, &order, &mut visited);
        if !self.envelopes.is_empty() {
            permute_in_place(&mut self.envelopes, &order, &mut visited);
        }
        permute_others(&order, &mut visited);
        let mut neighbours = std::mem::take(&mut self.neighbours);
        permute_in_place(&mut neighbours, &order, &mut visited);
        let tracks_images = self.tracks_images();
        for list in &mut neighbours {
            for j in list.iter_mut() {
                *j = if tracks_images {
                    images::encode(new_index[images::index(*j)] as usize, images::shift(*j))
                } else {
                    new_index[*j as usize]
                };
            }
        }
        self.neighbours = neighbours;
        for i in 0..n {
            let cell = self.home_cell(i);
            self.grid.insert(i, cell);
        }
        self.updates_at_sort = updates;
    }

    /// The grid cell for particle `i`'s neighbour-list sphere: at the finest level that holds
    /// its diameter.
    #[inline]
    fn home_cell(&self, i: usize) -> u32 {
        let level = self.grid.level_for(2.0 * self.spheres[i].radius);
        self.grid.cell_at(level, &self.spheres[i].centre)
    }

    /// Switches image tracking on if list spheres up to `width` in diameter need it
    /// ([`needs_images`]); `true` if it did (then every list must be built again, with
    /// images).
    pub(super) fn track_images_if_needed<B: Boundary>(&mut self, boundary: &B, width: f64) -> bool {
        match self.needs_images(boundary, width) {
            Some(tracking) => {
                self.images = Some(tracking);
                true
            }
            None => false,
        }
    }

    /// The shape's licence to track images ([`PeriodicImages::tracking`]) if image tracking
    /// must be switched on for neighbour-list spheres up to `width` in diameter: two of them
    /// can then reach half the shortest periodic edge, where minimum image stops being
    /// exact. `None` if it is on already or the shape has no images.
    fn needs_images<B: Boundary>(&self, boundary: &B, width: f64) -> Option<S::Images> {
        let tracking = S::Images::tracking()?;
        if self.images.is_some() {
            return None;
        }
        let shortest = period(boundary)
            .iter()
            .copied()
            .filter(|&l| l > 0.0)
            .fold(f64::INFINITY, f64::min);
        let needed = width >= 0.5 * shortest;
        assert!(
            !needed || self.spheres.len() <= images::MAX_PARTICLES,
            "periodic images are tracked for at most {} particles",
            images::MAX_PARTICLES
        );
        needed.then_some(tracking)
    }

    /// Calls `f` with every particle whose neighbour-list sphere may overlap `i`'s (a
    /// superset, `i` included).
    #[inline]
    fn for_each_candidate(&self, i: usize, mut f: impl FnMut(usize)) {
        for level in 0..self.grid.levels() {
            // Spheres registered at `level` have radii ≤ half its cell width.
            let reach = self.spheres[i].radius + 0.5 * self.grid.level_width(level);
            self.grid
                .for_each_within(level, &self.spheres[i].centre, reach, &mut f);
        }
    }

    /// [`Self::for_each_candidate`] into `out` (cleared first), for the image-tracking
    /// list builds, which test each candidate's images.
    fn list_candidates(&self, i: usize, out: &mut Vec<u32>) {
        out.clear();
        self.for_each_candidate(i, |j| out.push(j as u32));
    }

    /// Appends to `out` the particles `j ≥ first`, `j ≠ i`, whose neighbour-list spheres
    /// overlap `i`'s (`|c_i − c_j|² < (r_i + r_j)²`), and their envelopes
    /// ([`EnvelopeModel::may_overlap`]), in the order of the cell walk; `candidates` is
    /// scratch. The walk (some 20 cells for about 70 candidates and 13 neighbours) collects
    /// the candidates and asks for their spheres, and a second pass tests them: the spheres
    /// are scattered through memory at 10⁶ particles, and their loads then overlap instead
    /// of each waiting behind the walk of the cell lists (10⁶ fluid: 0.95 of the time,
    /// 10⁴: 1.007, same lists).
    fn overlapping_lists<B: Boundary>(
        &self,
        boundary: &B,
        i: usize,
        first: usize,
        out: &mut NeighbourList,
        candidates: &mut Vec<u32>,
    ) {
        candidates.clear();
        self.for_each_candidate(i, |j| {
            prefetch(&self.spheres[j]);
            candidates.push(j as u32);
        });
        let sphere_i = &self.spheres[i];
        let wraps = !self.pairs_free_of_images(i);
        // The kept candidates are compacted to the front of `candidates` by moving the end
        // past each one, not by a branch: about one candidate in five is kept, at random,
        // and a branch on it mispredicted once per kept neighbour.
        let mut kept = 0;
        for next in 0..candidates.len() {
            let j = candidates[next] as usize;
            let sphere_j = &self.spheres[j];
            let mut d = sphere_i.centre - sphere_j.centre;
            if wraps {
                boundary.minimum_image(&mut d);
            }
            let reach = sphere_i.radius + sphere_j.radius;
            let near = (d.norm_squared() < reach * reach) & (j >= first) & (j != i);
            let keep = near && S::Envelope::may_overlap(&self.envelopes, i, j, &d);
            candidates[kept] = j as u32;
            kept += usize::from(keep);
        }
        out.extend_from_slice(&candidates[..kept]);
    }

    /// Builds every neighbour list from the current spheres.
    pub(super) fn build_all<B: Boundary>(&mut self, boundary: &B) {
        for list in &mut self.neighbours {
            list.clear();
        }
        let mut candidates = std::mem::take(&mut self.candidates);
        let mut overlapping = NeighbourList::new();
        for i in 0..self.neighbours.len() {
            if self.tracks_images() {
                self.list_candidates(i, &mut candidates);
                let mut own = std::mem::take(&mut self.neighbours[i]);
                for &j in candidates.iter().filter(|&&j| j as usize >= i) {
                    self.link_images(boundary, i, j as usize, &mut own);
                }
                self.neighbours[i] = own;
                continue;
            }
            // Each pair once, from its lower index.
            overlapping.clear();
            self.overlapping_lists(boundary, i, i + 1, &mut overlapping, &mut candidates);
            for &j in &overlapping {
                self.neighbours[i].push(j);
                self.neighbours[j as usize].push(i as u32);
            }
        }
        self.candidates = candidates;
    }

    /// Particle `i`'s list update at kernel time `t`: moves its sphere to `centre` (its
    /// centre `p` at `t`, wrapped into the box; the kernel has moved its flight line by the
    /// same period), resizes it and its envelope, re-registers it in the grid and rebuilds
    /// its list (symmetrically).
    pub(super) fn update<B: Boundary>(
        &mut self,
        boundary: &B,
        i: usize,
        p: &Particle<S>,
        centre: Vec3,
        t: f64,
    ) {
        let old = std::mem::take(&mut self.neighbours[i]);
        self.spheres[i].centre = centre;
        let shape = &p.shape;
        let (r, l) = (shape.bounding_radius(t), shape.skin_length(t));
        self.spheres[i].radius = self.radius_for(r, l);
        let skin = self.spheres[i].radius - r;
        S::Envelope::build(&mut self.envelopes, i, &p.shape, &p.spin_at(t), t, skin);
        self.grid.remove(i);
        let cell = self.home_cell(i);
        self.grid.insert(i, cell);
        let mut new = NeighbourList::new();
        if self.tracks_images() {
            let mut candidates = std::mem::take(&mut self.candidates);
            self.list_candidates(i, &mut candidates);
            for &j in &old {
                // Every image of `i` leaves `j`'s list (`j` may be listed once per image).
                self.neighbours[images::index(j)].retain(|x| images::index(*x) != i);
            }
            for &j in &candidates {
                self.link_images(boundary, i, j as usize, &mut new);
            }
            self.candidates = candidates;
        } else {
            let mut candidates = std::mem::take(&mut self.candidates);
            self.overlapping_lists(boundary, i, 0, &mut new, &mut candidates);
            self.candidates = candidates;
            // Most partners stay: only the lists of those that leave or arrive are edited
            // (two scans of the short lists instead of a cache miss on every partner's
            // list).
            let listed = |list: &[u32], j: u32| list.iter().fold(false, |a, &x| a | (x == j));
            for &j in old.iter().filter(|&&j| !listed(&new, j)) {
                let list = &mut self.neighbours[j as usize];
                if let Some(k) = list.iter().position(|&x| x as usize == i) {
                    list.swap_remove(k);
                }
            }
            for &j in new.iter().filter(|&&j| !listed(&old, j)) {
                self.neighbours[j as usize].push(i as u32);
            }
        }
        self.neighbours[i] = new;
    }

    /// Adds to `list_i` (`i`'s new list) every image of `j` whose list sphere (and envelope)
    /// overlaps `i`'s, and the mirrored entries to `j`'s list; for `j == i`, `i`'s own
    /// images, once each.
    fn link_images<B: Boundary>(
        &mut self,
        boundary: &B,
        i: usize,
        j: usize,
        list_i: &mut NeighbourList,
    ) {
        let d = self.spheres[i].centre - self.spheres[j].centre;
        let reach = self.spheres[i].radius + self.spheres[j].radius;
        let period = period(boundary);
        let envelopes = &self.envelopes;
        let list_j = &mut self.neighbours[j];
        images::overlapping_shifts(&d, reach, &period, i == j, |n| {
            let image = d - images::translation(n, &period);
            if !S::Envelope::may_overlap(envelopes, i, j, &image) {
                return;
            }
            let entry = images::encode(j, n);
            list_i.push(entry);
            if i != j {
                list_j.push(images::mirrored(i, entry));
            }
        });
    }

    /// Records `i`'s list exit ([`EnvelopeModel::record_exit`]) at kernel time `t` before a
    /// prediction pass of `i`. Nothing when the list sphere is the envelope (its exit is
    /// predicted after the pass and bounds no pair).
    #[inline]
    pub(super) fn refresh_exit<B: Boundary>(
        &mut self,
        boundary: &B,
        particles: &[Particle<S>],
        i: usize,
        t: f64,
    ) {
        let spheres = &self.spheres;
        let at = || {
            let p = &particles[i];
            let mut q = p.position_at(t) - spheres[i].centre;
            boundary.minimum_image(&mut q);
            (&p.shape, p.spin_at(t), q, p.vel)
        };
        S::Envelope::record_exit(&self.envelopes, &mut self.exits, i, t, at);
    }
}

/// Periodic edge lengths of `boundary` (0 on walled axes).
pub(super) fn period<B: Boundary>(boundary: &B) -> Vec3 {
    let (lo, hi, periodic) = (boundary.min(), boundary.max(), boundary.periodic());
    Vec3::from_fn(|k, _| if periodic[k] { hi[k] - lo[k] } else { 0.0 })
}

/// The zone of [`free_of_images`] for `boundary` and a `grid` whose coarsest cells hold every
/// neighbour-list sphere: along each periodic axis of length `L ≥ 4w`, with `w` that width,
/// `[min + w/2 + δ, max − w/2 − δ]` (`δ = 10⁻⁹ L` absorbs the rounding of the bounds and of
/// the test), and nothing along a shorter one; every point along other axes.
pub(super) fn image_free_zone<B: Boundary>(boundary: &B, grid: &CellGrid) -> [Vec3; 2] {
    let half = 0.5 * grid.min_width();
    let (min, max, periodic) = (boundary.min(), boundary.max(), boundary.periodic());
    let mut zone = [Vec3::repeat(f64::NEG_INFINITY), Vec3::repeat(f64::INFINITY)];
    for k in (0..3).filter(|&k| periodic[k]) {
        let len = max[k] - min[k];
        if len >= 8.0 * half {
            let inset = half + 1e-9 * len;
            (zone[0][k], zone[1][k]) = (min[k] + inset, max[k] - inset);
        } else {
            (zone[0][k], zone[1][k]) = (f64::INFINITY, f64::NEG_INFINITY);
        }
    }
    zone
}

/// Whether every separation a pass over the list of the list sphere `(centre, radius)`
/// computes is its own minimum image, so that [`Boundary::minimum_image`] would return it
/// unchanged: the sphere lies inside `zone` ([`image_free_zone`]).
///
/// Along a periodic axis of length `L ≥ 4w` (`w` the coarsest cell width, at least every
/// list sphere's diameter, so every list radius `R_j ≤ w/2`): list centres are wrapped into
/// `[min, max)` and the sphere's centre `c` lies at least `R + w/2 ≥ R + R_j` inside both
/// faces, so the plain difference `c − c_j` to a centre whose sphere overlaps it (minimum
/// image `< R + R_j`) is that minimum image, and one whose spheres do not overlap stays at
/// least `R + R_j` apart either way (the list test's outcome is the same). A particle's
/// centre stays inside its list sphere until its list update, so the centres of two listed
/// particles differ by less than `2(R + R_j) ≤ 2w ≤ L/2`, which minimum image leaves as it
/// is. (The same reasoning as the `nearboxedge` flag of Smallenburg's EDMD codes.)
#[inline]
fn free_of_images(centre: &Vec3, radius: f64, zone: &[Vec3; 2]) -> bool {
    let r = Vec3::repeat(radius);
    let (low, high) = (centre - r, centre + r);
    (low.x >= zone[0].x)
        & (low.y >= zone[0].y)
        & (low.z >= zone[0].z)
        & (high.x <= zone[1].x)
        & (high.y <= zone[1].y)
        & (high.z <= zone[1].z)
}

#[cfg(test)]
mod tests {
    /// The lemma of `free_of_images`, sampled: for a list sphere inside the zone, the plain
    /// difference to any wrapped centre gives the list test's outcome, the plain difference to
    /// an overlapping one is its minimum image, and so is the difference of two points inside
    /// the two spheres (a partner's flight line is unwrapped from its sphere's centre). Near
    /// a face, or in a box shorter than four cells, the zone excludes the sphere.
    #[test]
    fn separations_from_the_image_free_zone_are_their_own_minimum_images() {
        use super::{free_of_images, image_free_zone};
        use crate::boundary::{Boundary, PeriodicBox, WalledBox};
        use crate::shape::Vec3;
        use crate::spatial::CellGrid;
        use rand::{Rng, SeedableRng};
        use rand_xoshiro::Xoshiro256PlusPlus;

        let boundary = PeriodicBox {
            min: Vec3::new(-1.0, 2.0, 0.5),
            len: Vec3::new(10.0, 12.0, 9.0),
        };
        let grid = CellGrid::new(boundary.min(), boundary.max(), [true; 3], 1.5, 100);
        let zone = image_free_zone(&boundary, &grid);
        let half = 0.5 * grid.min_width();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(16);
        let point_in = |rng: &mut Xoshiro256PlusPlus, r: f64| loop {
            let v = Vec3::from_fn(|_, _| rng.gen_range(-r..=r));
            if v.norm() < r {
                return v;
            }
        };
        let plain_is_image = |d: Vec3| {
            let mut m = d;
            boundary.minimum_image(&mut m);
            m == d
        };
        let mut free = 0;
        for _ in 0..200_000 {
            let (ri, rj) = (rng.gen_range(0.01..=half), rng.gen_range(0.01..=half));
            let mut ci = boundary.min + Vec3::from_fn(|k, _| rng.gen_range(0.0..boundary.len[k]));
            boundary.wrap(&mut ci);
            if !free_of_images(&ci, ri, &zone) {
                continue;
            }
            free += 1;
            // Any wrapped centre: the same list-test outcome either way.
            let mut cj = boundary.min + Vec3::from_fn(|k, _| rng.gen_range(0.0..boundary.len[k]));
            boundary.wrap(&mut cj);
            let mut image = ci - cj;
            boundary.minimum_image(&mut image);
            let reach2 = (ri + rj).powi(2);
            assert_eq!(
                (ci - cj).norm_squared() < reach2,
                image.norm_squared() < reach2
            );
            // An overlapping centre, and two points inside the spheres.
            let mut cj = ci + point_in(&mut rng, ri + rj);
            boundary.wrap(&mut cj);
            assert!(plain_is_image(ci - cj), "{ci} {cj}");
            let (xi, xj) = (ci + point_in(&mut rng, ri), cj + point_in(&mut rng, rj));
            assert!(plain_is_image(xi - xj), "{xi} {xj}");
        }
        assert!(free > 50_000, "{free}");
        // Near a face: outside the zone.
        let near = boundary.min + Vec3::new(half + 0.2, 5.0, 4.0);
        assert!(!free_of_images(&near, 0.25, &zone));
        assert!(free_of_images(&(near + Vec3::x() * 0.1), 0.25, &zone));
        // A periodic axis shorter than four cells: nowhere; a walled axis: everywhere.
        let short = PeriodicBox {
            min: Vec3::zeros(),
            len: Vec3::new(5.9, 20.0, 20.0),
        };
        let grid = CellGrid::new(short.min(), short.max(), [true; 3], 1.5, 100);
        let centre = Vec3::new(2.95, 10.0, 10.0);
        assert!(!free_of_images(
            &centre,
            0.01,
            &image_free_zone(&short, &grid)
        ));
        let walled = WalledBox {
            min: Vec3::zeros(),
            max: Vec3::new(5.9, 20.0, 20.0),
            periodic: [false, true, true],
        };
        let grid = CellGrid::new(walled.min(), walled.max(), walled.periodic(), 1.5, 100);
        let zone = image_free_zone(&walled, &grid);
        assert!(free_of_images(&Vec3::new(0.0, 10.0, 10.0), 0.7, &zone));
        assert!(!free_of_images(&Vec3::new(3.0, 0.5, 10.0), 0.1, &zone));
    }

    #[test]
    fn a_neighbour_list_fills_one_cache_line() {
        assert_eq!(std::mem::size_of::<super::NeighbourList>(), 64);
    }

    /// A neighbour-list sphere is half an aligned cache line: centre and radius load as one.
    #[test]
    fn a_list_sphere_is_half_a_cache_line() {
        assert_eq!(std::mem::size_of::<super::ListSphere>(), 32);
        assert_eq!(std::mem::align_of::<super::ListSphere>(), 32);
    }
}
