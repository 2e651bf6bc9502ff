//! The memory floor of the EDMD kernel's access pattern: how much dearer is a collision at
//! 10⁶ particles than at 10⁴ when only the memory system differs?
//!
//! Replays the cache lines that the kernel's events touch, with the kernel's record sizes and
//! event mix, the arithmetic reduced to a stand-in contact-time quadratic per partner, and a
//! prefetch pipeline that knows every future event (the kernel has to guess it from the
//! queue). The particles are uniform random points at unit number density, numbered in Morton
//! order of their cells (as the kernel sorts them), each listing the ~13 nearest as
//! neighbours (the kernel's mean at φ = 0.5). Per pop, as in the φ = 0.5 fluid at 10⁶
//! (32 468 852 collisions, 3 434 329 list updates, 11 019 531 stale pops):
//! - **collision** (69.2 %): both states and change records, both list spheres (the list
//!   exits), a prediction pass over each neighbour list, both local lists and queue records,
//!   the four bucket neighbours the queue unlinks them from, and two inserts (a bucket head,
//!   then the old head's back-link);
//! - **list update** (7.3 %): a walk of the 27 grid cells around the particle (their heads,
//!   asked for one event ahead, the links, the list spheres of the members, gathered before
//!   they are tested), a prediction pass and an insert;
//! - **stale pop** (23.5 %): the local list, the partner's change record and an insert;
//! - every pop reads one queue record that the calendar's read-ahead asked for one pop
//!   earlier.
//!
//! Each variant runs at 10⁴ and at 10⁶ particles, alternated over rounds; the table gives
//! the median time per collision (all pops over the collisions) and the ratio. Variants:
//! the whole pattern; without list updates; without stale pops; collisions alone (no list
//! updates, stale pops, read-ahead, queue links, list spheres or change records); the
//! whole pattern with 32-byte particle states (`f32`, which the kernel cannot use: it would
//! change trajectories).
//!
//! The figures bound what a better pipeline can give the kernel's pattern on a machine; they
//! do not predict a single lever (the cell heads asked for one event ahead save about 15 % of
//! the whole pattern's time at 10⁶ here, and nothing in the kernel).
//!
//! `cargo bench --bench memory_floor [-- --depth D --events E --rounds R]`: `D` events of
//! look-ahead for the partners' states (own records `D + 1`; the kernel asks for partners one
//! event ahead, and for own records up to four), `E` pops per
//! run (default 4·10⁶), `R` rounds (default 3). The look-ahead is a no-op off x86-64.

use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::time::Instant;

/// Asks for the cache line of `value` (records here never straddle a line).
#[inline(always)]
fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: a prefetch never faults.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(value as *const T as *const i8) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

/// A particle's state: centre and velocity at kernel time 0, radius, growth rate.
trait State: Copy + Default {
    fn new(p: [f64; 3], v: [f64; 3]) -> Self;
    fn pos(&self, k: usize) -> f64;
    fn vel(&self, k: usize) -> f64;
    fn kick(&mut self, k: usize, dv: f64);
}

/// The kernel's sphere record: one aligned 64-byte line.
#[derive(Clone, Copy, Default)]
#[repr(C, align(64))]
struct Wide {
    p: [f64; 3],
    v: [f64; 3],
    // Radius and growth rate: not read here, present for the record's size.
    r: f64,
    g: f64,
}

/// The same in `f32`: two states per line.
#[derive(Clone, Copy, Default)]
#[repr(C, align(32))]
struct Narrow {
    p: [f32; 3],
    v: [f32; 3],
    r: f32,
    g: f32,
}

impl State for Wide {
    fn new(p: [f64; 3], v: [f64; 3]) -> Self {
        Self {
            p,
            v,
            r: 0.5,
            g: 0.0,
        }
    }
    #[inline(always)]
    fn pos(&self, k: usize) -> f64 {
        self.p[k]
    }
    #[inline(always)]
    fn vel(&self, k: usize) -> f64 {
        self.v[k]
    }
    #[inline(always)]
    fn kick(&mut self, k: usize, dv: f64) {
        self.v[k] += dv;
    }
}

impl State for Narrow {
    fn new(p: [f64; 3], v: [f64; 3]) -> Self {
        Self {
            p: p.map(|x| x as f32),
            v: v.map(|x| x as f32),
            r: 0.5,
            g: 0.0,
        }
    }
    #[inline(always)]
    fn pos(&self, k: usize) -> f64 {
        f64::from(self.p[k])
    }
    #[inline(always)]
    fn vel(&self, k: usize) -> f64 {
        f64::from(self.v[k])
    }
    #[inline(always)]
    fn kick(&mut self, k: usize, dv: f64) {
        self.v[k] += dv as f32;
    }
}

/// A neighbour list on one line: the length and up to 15 entries (the kernel keeps 14
/// inline and its capacity).
#[derive(Clone, Copy, Default)]
#[repr(C, align(64))]
struct List {
    len: u32,
    entries: [u32; 15],
}

/// A local event list: two events of 16 bytes.
#[derive(Clone, Copy, Default)]
#[repr(C, align(32))]
struct Local {
    time: [f64; 2],
    tags: [u32; 4],
}

/// A calendar record: time, place and bucket links (24 bytes).
#[derive(Clone, Copy, Default)]
#[repr(C)]
struct Key {
    time: f64,
    // The entry's place: not read here, present for the record's size.
    place: [u32; 2],
    link: [u32; 2],
}

/// A list sphere: centre and radius.
#[derive(Clone, Copy, Default)]
#[repr(C, align(32))]
struct ListSphere {
    centre: [f64; 3],
    radius: f64,
}

const NONE: u32 = u32::MAX;

/// What happens at a pop.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Collision,
    ListUpdate,
    Stale,
}

/// One pop: its particles, kind, the queue records its unlinks and read-ahead touch, and
/// the buckets its inserts go to.
#[derive(Clone, Copy)]
struct Pop {
    i: u32,
    j: u32,
    kind: Kind,
    links: [u32; 4],
    read_ahead: u32,
    buckets: [u32; 2],
}

/// Which parts of the pattern a variant replays.
#[derive(Clone, Copy)]
struct Pattern {
    name: &'static str,
    list_updates: bool,
    stale_pops: bool,
    /// Read-ahead, bucket links and inserts' back-links, list spheres, change records.
    bookkeeping: bool,
    narrow: bool,
}

impl Pattern {
    /// Whether the variant's stream holds pops of this kind.
    fn keeps(&self, kind: Kind) -> bool {
        match kind {
            Kind::Collision => true,
            Kind::ListUpdate => self.list_updates,
            Kind::Stale => self.stale_pops,
        }
    }
}

/// The particles' arrays and the grid, at one size.
struct Scene<T: State> {
    states: Vec<T>,
    lists: Vec<List>,
    local: Vec<Local>,
    keys: Vec<Key>,
    spheres: Vec<ListSphere>,
    changed: Vec<u32>,
    buckets: Vec<u32>,
    cell_of: Vec<u32>,
    heads: Vec<u32>,
    links: Vec<u32>,
    cells: usize,
}

/// Unit-density random points in a periodic cube, sorted into Morton order of their
/// cells, with neighbour lists of the points within the radius that holds ~13 on average.
struct Layout {
    points: Vec<[f64; 3]>,
    neighbours: Vec<List>,
    cell_of: Vec<u32>,
    cells: usize,
}

/// The 27 cells around cell `c` (numbered `(x·cells + y)·cells + z`) of a periodic grid
/// of `cells`³ cells.
fn neighbourhood(cells: usize, c: usize) -> impl Iterator<Item = usize> {
    let home = [c / (cells * cells), c / cells % cells, c % cells];
    (0..27).map(move |d| {
        let shift = [d / 9, d / 3 % 3, d % 3];
        let other = [0, 1, 2].map(|k| (home[k] + cells + shift[k] - 1) % cells);
        (other[0] * cells + other[1]) * cells + other[2]
    })
}

fn morton(c: [usize; 3]) -> u64 {
    let spread = |v: usize| (0..21).fold(0u64, |acc, b| acc | (((v as u64 >> b) & 1) << (3 * b)));
    spread(c[0]) | spread(c[1]) << 1 | spread(c[2]) << 2
}

impl Layout {
    fn new(n: usize, draw: &mut Xoshiro256PlusPlus) -> Self {
        let side = (n as f64).cbrt();
        let reach = (13.0 / (4.0 / 3.0 * std::f64::consts::PI)).cbrt();
        let cells = ((side / reach).floor() as usize).max(3);
        let width = side / cells as f64;
        let cell = |p: &[f64; 3]| p.map(|x| ((x / width) as usize).min(cells - 1));
        let mut points: Vec<[f64; 3]> = (0..n)
            .map(|_| [draw.gen::<f64>(), draw.gen::<f64>(), draw.gen::<f64>()].map(|u| u * side))
            .collect();
        points.sort_by_key(|p| morton(cell(p)));
        let flat = |c: [usize; 3]| (c[0] * cells + c[1]) * cells + c[2];
        let mut members = vec![Vec::new(); cells * cells * cells];
        for (i, p) in points.iter().enumerate() {
            members[flat(cell(p))].push(i as u32);
        }
        let mut neighbours = vec![List::default(); n];
        for (i, p) in points.iter().enumerate() {
            for other in neighbourhood(cells, flat(cell(p))) {
                for &j in &members[other] {
                    let q = &points[j as usize];
                    let d2: f64 = (0..3)
                        .map(|k| {
                            let d = p[k] - q[k];
                            let d = d - side * (d / side).round();
                            d * d
                        })
                        .sum();
                    let list = &mut neighbours[i];
                    if j as usize != i && d2 < reach * reach && (list.len as usize) < 15 {
                        list.entries[list.len as usize] = j;
                        list.len += 1;
                    }
                }
            }
        }
        let cell_of = points.iter().map(|p| flat(cell(p)) as u32).collect();
        Self {
            points,
            neighbours,
            cell_of,
            cells,
        }
    }
}

impl<T: State> Scene<T> {
    fn new(layout: &Layout, draw: &mut Xoshiro256PlusPlus) -> Self {
        let n = layout.points.len();
        let cells = layout.cells;
        let mut heads = vec![NONE; cells * cells * cells];
        let mut links = vec![NONE; n];
        for (i, &c) in layout.cell_of.iter().enumerate() {
            links[i] = heads[c as usize];
            heads[c as usize] = i as u32;
        }
        Self {
            states: layout
                .points
                .iter()
                .map(|&p| {
                    T::new(
                        p,
                        [
                            draw.gen::<f64>() - 0.5,
                            draw.gen::<f64>() - 0.5,
                            draw.gen::<f64>() - 0.5,
                        ],
                    )
                })
                .collect(),
            lists: layout.neighbours.clone(),
            local: vec![Local::default(); n],
            keys: vec![Key::default(); n],
            spheres: layout
                .points
                .iter()
                .map(|&centre| ListSphere {
                    centre,
                    radius: 0.6,
                })
                .collect(),
            changed: vec![0; n],
            buckets: vec![0; n / 4 + 1],
            cell_of: layout.cell_of.clone(),
            heads,
            links,
            cells,
        }
    }

    /// The earliest contact of `q` with its neighbours (the kernel's screen and quadratic).
    #[inline(always)]
    fn predict(&self, q: usize) -> f64 {
        let list = &self.lists[q];
        let own = &self.states[q];
        let mut earliest = f64::INFINITY;
        for &k in &list.entries[..list.len as usize] {
            let other = &self.states[k as usize];
            let (mut a, mut b, mut c) = (0.0, 0.0, -1.0);
            for x in 0..3 {
                let dr = other.pos(x) - own.pos(x);
                let dv = other.vel(x) - own.vel(x);
                a += dv * dv;
                b += dr * dv;
                c += dr * dr;
            }
            let disc = b * b - a * c;
            if b < 0.0 && disc > 0.0 {
                earliest = earliest.min(c / (-b + disc.sqrt()));
            }
        }
        earliest
    }

    /// A calendar insert: the bucket's head, then (with the bookkeeping) the old head's
    /// back-link.
    #[inline(always)]
    fn insert(&mut self, k: usize, bucket: u32, time: f64, bookkeeping: bool) {
        self.keys[k].time = time;
        let old = std::mem::replace(&mut self.buckets[bucket as usize], k as u32);
        if bookkeeping {
            self.keys[old as usize].link[0] = k as u32;
        }
    }

    /// The 27 grid cells around particle `i`'s cell.
    fn cells_around(&self, i: usize) -> impl Iterator<Item = usize> {
        neighbourhood(self.cells, self.cell_of[i] as usize)
    }

    /// The grid walk of a list update, as the kernel's: the members of the 27 cells around
    /// `i` gathered (their spheres asked for), then tested against `i`'s sphere.
    fn walk_cells(&mut self, i: usize, members: &mut Vec<u32>) {
        members.clear();
        for cell in self.cells_around(i) {
            let mut m = self.heads[cell];
            while m != NONE {
                prefetch(&self.spheres[m as usize]);
                members.push(m);
                m = self.links[m as usize];
            }
        }
        let centre = self.spheres[i].centre;
        let mut near = 0u32;
        for &m in members.iter() {
            let s = &self.spheres[m as usize];
            let d2: f64 = (0..3).map(|k| (s.centre[k] - centre[k]).powi(2)).sum();
            near += u32::from(d2 < (s.radius + 0.6).powi(2));
        }
        self.spheres[i].radius = 0.6 + f64::from(near) * 1e-12;
    }

    /// Replays `pops` with `depth` events of look-ahead; returns the seconds taken.
    fn replay(&mut self, pops: &[Pop], pattern: Pattern, depth: usize) -> f64 {
        let mut members = Vec::with_capacity(256);
        let start = Instant::now();
        let mut sum = 0.0;
        for e in 0..pops.len() {
            if let Some(ahead) = pops.get(e + depth + 1) {
                for x in [ahead.i, ahead.j].map(|x| x as usize) {
                    prefetch(&self.states[x]);
                    prefetch(&self.lists[x]);
                    prefetch(&self.local[x]);
                    prefetch(&self.keys[x]);
                    if pattern.bookkeeping {
                        prefetch(&self.spheres[x]);
                        prefetch(&self.changed[x]);
                    }
                }
            }
            if let Some(ahead) = pops.get(e + depth) {
                if ahead.kind == Kind::ListUpdate {
                    for cell in self.cells_around(ahead.i as usize) {
                        prefetch(&self.heads[cell]);
                    }
                }
                for x in [ahead.i, ahead.j] {
                    let list = &self.lists[x as usize];
                    for &k in &list.entries[..list.len as usize] {
                        prefetch(&self.states[k as usize]);
                    }
                }
            }
            let pop = pops[e];
            let (i, j) = (pop.i as usize, pop.j as usize);
            if pattern.bookkeeping {
                if let Some(next) = pops.get(e + 1) {
                    prefetch(&self.keys[next.read_ahead as usize]);
                }
                sum += self.keys[pop.read_ahead as usize].time;
            }
            match pop.kind {
                Kind::Stale => {
                    let time = self.local[i].time[1];
                    sum += f64::from(self.changed[j]);
                    self.local[i].time[0] = time;
                    self.insert(i, pop.buckets[0], time, pattern.bookkeeping);
                }
                Kind::ListUpdate => {
                    self.walk_cells(i, &mut members);
                    let time = self.predict(i);
                    self.local[i].time[0] = time;
                    self.insert(i, pop.buckets[0], time, pattern.bookkeeping);
                }
                Kind::Collision => {
                    let dv: f64 = (0..3)
                        .map(|x| {
                            (self.states[i].pos(x) - self.states[j].pos(x))
                                * (self.states[i].vel(x) - self.states[j].vel(x))
                        })
                        .sum();
                    for x in 0..3 {
                        self.states[i].kick(x, -dv * 1e-9);
                        self.states[j].kick(x, dv * 1e-9);
                    }
                    if pattern.bookkeeping {
                        self.changed[i] = e as u32;
                        self.changed[j] = e as u32;
                        sum += self.spheres[i].radius + self.spheres[j].radius;
                        for (k, &l) in pop.links.iter().enumerate() {
                            self.keys[l as usize].link[k % 2] = pop.i;
                        }
                    }
                    for (q, bucket) in [(i, pop.buckets[0]), (j, pop.buckets[1])] {
                        let time = self.predict(q);
                        self.local[q].time[0] = time;
                        self.local[q].tags[0] = e as u32;
                        self.insert(q, bucket, time, pattern.bookkeeping);
                    }
                }
            }
        }
        let seconds = start.elapsed().as_secs_f64();
        std::hint::black_box(sum);
        seconds
    }
}

/// The pop stream: kinds in the fluid's proportions, partners from the neighbour lists,
/// queue records and buckets at random.
fn pops(layout: &Layout, count: usize, draw: &mut Xoshiro256PlusPlus) -> Vec<Pop> {
    let n = layout.points.len();
    (0..count)
        .map(|_| {
            let i = draw.gen_range(0..n);
            let list = &layout.neighbours[i];
            let j = list.entries[draw.gen_range(0..list.len.max(1) as usize)];
            let u = draw.gen::<f64>();
            let kind = if u < 0.692 {
                Kind::Collision
            } else if u < 0.765 {
                Kind::ListUpdate
            } else {
                Kind::Stale
            };
            Pop {
                i: i as u32,
                j,
                kind,
                links: [0; 4].map(|_| draw.gen_range(0..n) as u32),
                read_ahead: draw.gen_range(0..n) as u32,
                buckets: [0; 2].map(|_| draw.gen_range(0..n / 4 + 1) as u32),
            }
        })
        .collect()
}

/// The whole number after `name` in `args`, `default` when `name` is absent. Other
/// arguments are left alone: `cargo bench` passes its own `--bench`.
fn option(args: &[String], name: &str, default: usize) -> usize {
    let Some(k) = args.iter().position(|a| a == name) else {
        return default;
    };
    args.get(k + 1)
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{name} takes a whole number"))
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let depth = option(&args, "--depth", 1);
    let count = option(&args, "--events", 4_000_000);
    let rounds = option(&args, "--rounds", 3);
    assert!(rounds >= 1, "--rounds takes a whole number of at least 1");
    let all = Pattern {
        name: "the kernel's whole pattern",
        list_updates: true,
        stale_pops: true,
        bookkeeping: true,
        narrow: false,
    };
    let patterns = [
        all,
        Pattern {
            name: "without list updates",
            list_updates: false,
            ..all
        },
        Pattern {
            name: "without stale pops",
            stale_pops: false,
            ..all
        },
        Pattern {
            name: "collisions alone",
            list_updates: false,
            stale_pops: false,
            bookkeeping: false,
            narrow: false,
        },
        Pattern {
            name: "whole pattern, 32-byte states",
            narrow: true,
            ..all
        },
    ];
    let sizes = [10_000, 1_000_000];
    let mut draw = Xoshiro256PlusPlus::seed_from_u64(2026);
    let layouts: Vec<Layout> = sizes.iter().map(|&n| Layout::new(n, &mut draw)).collect();
    let streams: Vec<Vec<Pop>> = layouts.iter().map(|l| pops(l, count, &mut draw)).collect();
    // ns per collision: [pattern][size][round].
    let mut times = vec![vec![Vec::new(); sizes.len()]; patterns.len()];
    for _ in 0..rounds {
        for (p, &pattern) in patterns.iter().enumerate() {
            for s in 0..sizes.len() {
                let pops: Vec<Pop> = streams[s]
                    .iter()
                    .filter(|e| pattern.keeps(e.kind))
                    .copied()
                    .collect();
                let pops = &pops;
                let seconds = if pattern.narrow {
                    Scene::<Narrow>::new(&layouts[s], &mut draw).replay(pops, pattern, depth)
                } else {
                    Scene::<Wide>::new(&layouts[s], &mut draw).replay(pops, pattern, depth)
                };
                let collisions = pops.iter().filter(|e| e.kind == Kind::Collision).count();
                times[p][s].push(seconds / collisions as f64 * 1e9);
            }
        }
    }
    println!("look-ahead {depth} event(s), {count} pops per run, median of {rounds} rounds");
    println!("| pattern | 10⁴ ns per collision | 10⁶ | ratio |");
    println!("|---|---|---|---|");
    for (p, pattern) in patterns.iter().enumerate() {
        let [small, large] = [0, 1].map(|s| median(times[p][s].clone()));
        println!(
            "| {} | {small:.0} | {large:.0} | {:.2} |",
            pattern.name,
            large / small
        );
    }
}
