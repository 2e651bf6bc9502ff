//! Calendar queue after Paul (2007), *J. Comput. Phys.* 221:615, "A complexity O(1) priority
//! queue for event driven molecular dynamics simulations".
//!
//! # Structure
//!
//! The time axis from `origin` on is cut into `nb` buckets of equal width `w`; an entry of
//! time `t` belongs to bucket `s(t) = floor((t - origin) / w)`, clamped to `0..=nb`, where
//! `nb` stands for "beyond the calendar". `s` is non-decreasing in `t` (floating-point
//! subtraction and multiplication by a positive constant are monotone), so an entry in a
//! lower bucket is never later than one in a higher bucket. One bucket, `cur`, is *current*:
//!
//! - the **front** holds every entry with `s(t) <= cur`: the current bucket's entries and
//!   any entry scheduled before it (which the kernel only does by rounding; it stays correct
//!   for any time). It has two parts:
//!   - the **run**: the current bucket's entries as the bucket was taken, sorted once by
//!     `(time, key)`, earliest last, so that the bucket's events pop in order at the cost of
//!     one comparison each, where a binary heap would sift each pop down its levels (at 10⁴
//!     particles a bucket holds some 13 entries when taken, and the heap's sifting took 5 %
//!     of the run time, its samples on the comparisons' branches). An entry that leaves the run
//!     early (its key is scheduled elsewhere or cancelled) stays behind, stale, until it
//!     reaches the end, where its key's place (no longer `Run`) gives it away;
//!   - the **heap**: a small indexed binary heap ordered by `(time, key)` for the entries
//!     scheduled into the current bucket after it was taken (rare in the kernel: a few in
//!     10⁴ schedules), and for every entry when the queue has no buckets;
//! - each later bucket `cur < b < nb` is an **unsorted doubly linked list** of keys, threaded
//!   through per-key links (Paul's own layout: no allocation per bucket, 8 bytes of links per
//!   key and 4 bytes of list head per bucket);
//! - entries with `s(t) = nb` go to the unsorted **overflow** list.
//!
//! Every key knows where it is (the run, a heap position, a bucket, or a position in the
//! overflow), so `cancel` and re-`schedule` are `O(1)` outside the heap (leaving the run,
//! unlinking from a bucket list, or `swap_remove` from the overflow) and `O(log m)` in a heap
//! of `m` entries. `peek`/`pop` serve the earlier of the run's last entry and the heap's root,
//! which is the global minimum by the invariants above. When the front runs empty, `cur`
//! advances to the next non-empty bucket, whose entries are sorted into the run. When `cur`
//! runs past the last bucket, only the overflow is left and the calendar is rebuilt around
//! it.
//!
//! # Bucket width
//!
//! [`EventQueue::reset`] lays the calendar over the kernel's window `[start, end]` with
//! `nb = expected_len` rounded up to a power of two and `w = (end - start) / nb`: with the
//! entries spread over the window a bucket holds `O(1)` of them. A **rebuild** derives the
//! calendar from the entries themselves: `origin` is the earliest finite time, `nb` the
//! entry count rounded up to a power of two, and `w` such that the 7/8-quantile of the
//! times falls at the middle of the calendar, which leaves the second half for events
//! scheduled later and keeps far outliers from inflating the width. The queue rebuilds when
//!
//! - the calendar is exhausted and entries remain in the overflow (this is also how a queue
//!   that is never `reset` finds its window, and how it follows a simulation that runs past
//!   the `end` of its window), or
//! - the front holds more than `FRONT_LIMIT` (64) entries (the width does not fit the times,
//!   e.g. a window that was far too wide) and at least `len` operations have happened since
//!   the last rebuild, so that the `O(len + nb)` rebuild costs `O(1)` per operation.
//!
//! Without a usable window (an empty or non-finite `reset` window, before the first rebuild
//! of a queue that was never `reset`, or entries with no spread in time) the calendar has no
//! bucket and the queue is a plain indexed heap (`nb = 0`, everything in the front's heap).
//!
//! # Complexity
//!
//! With the times spread over the calendar so that a bucket holds `O(1)` entries, `schedule`,
//! `cancel`, `peek` and `pop` take amortized `O(1)` time: a pop scans on average `O(1)` empty
//! buckets, a taken bucket's `O(1)` entries are sorted once, and a rebuild is paid for by the
//! operations since the last one. In the worst case (all times clustered in one bucket) the
//! queue degrades to `O(log n)` per operation: the run is sorted once in `O(n log n)` and
//! the heap takes `O(log n)`. Memory is `O(capacity + nb)`.

use super::{EventQueue, UPCOMING};
use crate::prefetch;
use std::cmp::Ordering;

/// A front larger than this triggers a rebuild (see the module documentation).
const FRONT_LIMIT: usize = 64;

/// Mean entries per bucket the calendar is laid out for: a few entries keep the front
/// tiny while a quarter as many bucket heads as keys keep memory low (BENCHMARKS.md,
/// "Memory").
const ENTRIES_PER_BUCKET: usize = 4;

/// Upper bound on the number of buckets (and with it on the memory a `reset` can allocate).
const MAX_BUCKETS: usize = 1 << 24;

/// Buckets after the current one that `settle` looks through for the read-ahead cursor.
const READ_AHEAD_SCAN: usize = 8;

/// End of a bucket list (keys are below `u32::MAX`).
const NIL: u32 = u32::MAX;

/// Where a key's entry is stored. Positions index the named `Vec`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Place {
    /// The key has no entry.
    Absent,
    /// In the front's run ([`CalendarQueue::run`]).
    Run,
    /// In the front's heap, at this position of `heap`.
    Heap(u32),
    /// In the list of this bucket (`cur < index < nb`).
    Bucket(u32),
    /// In the overflow list, at this position.
    Overflow(u32),
}

/// What the queue knows of one key, in one 24-byte record: a schedule, a cancel or a bucket
/// hand-over touches a key's time, place and links together, and at 10⁵ keys each separate
/// array would cost a cache miss of its own.
#[derive(Clone, Copy, Debug)]
struct KeyRecord {
    /// Time of the key's entry; meaningless when `place` is `Absent`.
    time: f64,
    /// Where the key's entry is stored.
    place: Place,
    /// `[previous, next]` key in the list of the key's bucket ([`NIL`] at the ends);
    /// meaningful only while `place` is `Bucket`.
    link: [u32; 2],
}

impl KeyRecord {
    const ABSENT: Self = Self {
        time: 0.0,
        place: Place::Absent,
        link: [NIL; 2],
    };
}

/// Calendar queue (Paul 2007): amortized `O(1)` schedule, cancel and pop when the times are
/// spread over the window given to [`EventQueue::reset`].
///
/// The window is cut into about `expected_len` buckets (a power of two). Entries of the
/// current bucket (and any earlier ones) sit in a small indexed binary heap, later buckets
/// are unsorted, and entries beyond the last bucket wait in an overflow list until the
/// calendar, once exhausted, is rebuilt around them. The calendar also rebuilds itself when
/// the current bucket gets crowded, so a queue that is never `reset`, or whose window does not
/// fit the times, finds a fitting bucket width; with no usable width it is a plain binary heap.
/// Results are identical to [`HeapQueue`](super::HeapQueue)'s in every case.
///
/// Keys are stored as `u32`: keys must be below `u32::MAX`.
pub struct CalendarQueue {
    /// `keys[k]` is what the queue knows of key `k`: its time, where its entry is stored and
    /// its bucket links ([`KeyRecord`]).
    keys: Vec<KeyRecord>,
    /// The run: the entries of bucket `cur` as it was taken, as [`order`] keys sorted in
    /// decreasing order (the earliest last). An entry is live while its key's place is
    /// `Run`, and stale after (its key left the run); each live key has exactly one entry,
    /// and the last entry is live after every `settle`. Empty whenever a bucket is taken.
    run: Vec<u128>,
    /// Number of live entries in `run`.
    run_live: usize,
    /// Indexed binary min-heap by `(time, key)` of the entries with bucket `<= cur` that are
    /// not in the run; `keys[heap[i]].place == Heap(i)`. In heap mode (`heads` empty) it
    /// holds every entry.
    heap: Vec<u32>,
    /// `heads.len() == nb`, the number of buckets of the calendar (0 in heap mode).
    /// `heads[b]` for `cur < b < nb` is the first key of the list that holds, unsorted,
    /// exactly the keys whose time falls in bucket `b` (each with `place == Bucket(b)`), or
    /// [`NIL`]; buckets `b <= cur` are empty.
    heads: Vec<u32>,
    /// Unsorted keys whose time falls beyond the last bucket;
    /// `keys[overflow[i]].place == Overflow(i)`. Empty in heap mode.
    overflow: Vec<u32>,
    /// The current bucket: `cur < nb`, or `cur == 0` in heap mode.
    cur: usize,
    /// Start time of bucket 0 (finite).
    origin: f64,
    /// `1 / w`, the inverse bucket width (finite, positive).
    inv_width: f64,
    /// Number of entries (run + heap + buckets + overflow).
    len: usize,
    /// Schedules, cancels and pops since the last rebuild or reset; a rebuild forced by an
    /// oversized front waits until `ops >= len`.
    ops: usize,
    /// Read-ahead cursor into the list of the next non-empty bucket after `cur` (a hint, never
    /// relied on): each `peek` reads the record it points to, which the previous `peek` asked
    /// the memory system for, steps to that key's successor and prefetches its record. The
    /// bucket's list chain is thus loaded one link per event while the current bucket drains,
    /// instead of as a chain of dependent cache misses when `settle` takes the bucket (at 10⁵
    /// keys the lists no longer fit the caches). Keys unlinked or
    /// moved meanwhile keep valid (stale) links, so the cursor may wander into another list
    /// or end early; it never affects results.
    read_ahead: u32,
    /// Scratch buffer for the keys moved by a rebuild (kept to reuse its allocation).
    scratch_keys: Vec<u32>,
    /// Scratch buffer for the times examined by a rebuild (kept to reuse its allocation).
    scratch_times: Vec<f64>,
}

/// The key of an entry in the run: its time's bits in `f64::total_cmp` order above the key,
/// so that comparing two of them compares `(time, key)` as the queue orders entries.
#[inline]
fn order(time: f64, k: u32) -> u128 {
    let bits = time.to_bits() as i64;
    // `total_cmp`'s map to a signed integer of the same order, then its sign bit flipped to
    // order the same way unsigned.
    let ordered = (bits ^ (((bits >> 63) as u64) >> 1) as i64) as u64 ^ (1 << 63);
    u128::from(ordered) << 32 | u128::from(k)
}

/// Empties the list of bucket `b` (`heads[b]`, threaded through `keys`), calling `f` with each
/// key and its record in list order; `f` must leave the links alone.
#[inline]
fn drain_list(
    heads: &mut [u32],
    keys: &mut [KeyRecord],
    b: usize,
    mut f: impl FnMut(u32, &mut KeyRecord),
) {
    let mut k = std::mem::replace(&mut heads[b], NIL);
    while k != NIL {
        let record = &mut keys[k as usize];
        f(k, record);
        k = record.link[1];
    }
}

impl CalendarQueue {
    /// Bucket of time `t`: `0..nb` inside the calendar, `nb` beyond it. Earlier than bucket 0
    /// maps to 0. Non-decreasing in `t` under `f64::total_cmp` (NaNs, which the kernel never
    /// schedules, go to the end of the order their sign gives them).
    #[inline]
    fn slot(&self, t: f64) -> usize {
        let nb = self.heads.len();
        let x = (t - self.origin) * self.inv_width;
        if x >= 0.0 {
            if x < nb as f64 {
                // `x < nb ≤ MAX_BUCKETS` fits a `u32`, whose conversion is one instruction,
                // where the saturating one to `usize` needs a correction sequence (SSE2 has no
                // unsigned conversion); both truncate to the same bucket.
                x as u32 as usize
            } else {
                nb
            }
        } else if x < 0.0 || t.is_sign_negative() {
            0
        } else {
            nb
        }
    }

    /// Whether entry `a` comes before entry `b` in `(time, key)` order.
    #[inline]
    fn before(&self, a: u32, b: u32) -> bool {
        match self.keys[a as usize]
            .time
            .total_cmp(&self.keys[b as usize].time)
        {
            Ordering::Less => true,
            Ordering::Greater => false,
            Ordering::Equal => a < b,
        }
    }

    /// Writes key `k` at position `i` of the heap and records it.
    #[inline]
    fn heap_set(&mut self, i: usize, k: u32) {
        self.heap[i] = k;
        self.keys[k as usize].place = Place::Heap(i as u32);
    }

    /// Moves the heap entry at `i` towards the root until the heap order holds.
    /// Returns its final position.
    fn sift_up(&mut self, mut i: usize) -> usize {
        let k = self.heap[i];
        while i > 0 {
            let parent = (i - 1) / 2;
            let p = self.heap[parent];
            if !self.before(k, p) {
                break;
            }
            self.heap_set(i, p);
            i = parent;
        }
        self.heap_set(i, k);
        i
    }

    /// Moves the heap entry at `i` towards the leaves until the heap order holds.
    fn sift_down(&mut self, mut i: usize) {
        let k = self.heap[i];
        let n = self.heap.len();
        loop {
            let left = 2 * i + 1;
            if left >= n {
                break;
            }
            let right = left + 1;
            let mut child = left;
            if right < n && self.before(self.heap[right], self.heap[left]) {
                child = right;
            }
            let c = self.heap[child];
            if !self.before(c, k) {
                break;
            }
            self.heap_set(i, c);
            i = child;
        }
        self.heap_set(i, k);
    }

    /// Restores the heap order around position `i` after its entry's time changed.
    fn heap_fix(&mut self, i: usize) {
        if self.sift_up(i) == i {
            self.sift_down(i);
        }
    }

    /// Removes the heap entry at position `i` (its key's place is left to the caller).
    fn heap_remove(&mut self, i: usize) {
        let last = self.heap.pop().expect("heap_remove on an empty heap");
        if i < self.heap.len() {
            self.heap_set(i, last);
            self.heap_fix(i);
        }
    }

    /// Stores key `k` (absent, with its time set) where its time belongs.
    fn insert(&mut self, k: u32) {
        let s = self.slot(self.keys[k as usize].time);
        if s <= self.cur {
            self.heap.push(k);
            let i = self.heap.len() - 1;
            self.sift_up(i);
        } else if s < self.heads.len() {
            let head = self.heads[s];
            self.keys[k as usize].link = [NIL, head];
            if head != NIL {
                self.keys[head as usize].link[0] = k;
            }
            self.heads[s] = k;
            self.keys[k as usize].place = Place::Bucket(s as u32);
        } else {
            self.keys[k as usize].place = Place::Overflow(self.overflow.len() as u32);
            self.overflow.push(k);
        }
    }

    /// Takes key `k` out of whichever structure holds it and marks it absent. Does not
    /// change `len`.
    fn unlink(&mut self, k: u32) {
        match self.keys[k as usize].place {
            Place::Absent => return,
            // Its entry stays behind, stale (see `run`).
            Place::Run => self.run_live -= 1,
            Place::Heap(i) => self.heap_remove(i as usize),
            Place::Bucket(index) => {
                let [prev, next] = self.keys[k as usize].link;
                if prev == NIL {
                    self.heads[index as usize] = next;
                } else {
                    self.keys[prev as usize].link[1] = next;
                }
                if next != NIL {
                    self.keys[next as usize].link[0] = prev;
                }
            }
            Place::Overflow(pos) => {
                self.overflow.swap_remove(pos as usize);
                if let Some(&moved) = self.overflow.get(pos as usize) {
                    self.keys[moved as usize].place = Place::Overflow(pos);
                }
            }
        }
        self.keys[k as usize].place = Place::Absent;
    }

    /// Drops every bucket: the queue becomes a plain heap (everything goes to the front's
    /// heap).
    fn heap_mode(&mut self) {
        self.heads.clear();
        self.cur = 0;
        self.origin = 0.0;
        self.inv_width = 1.0;
    }

    /// Lays out `nb` empty buckets of width `width` from `origin`; falls back to heap mode if
    /// the width is not a positive number with a finite inverse.
    fn lay_out(&mut self, origin: f64, width: f64, nb: usize) {
        let inv_width = width.recip();
        if !(origin.is_finite() && width > 0.0 && width.is_finite() && inv_width.is_finite()) {
            self.heap_mode();
            return;
        }
        let nb = nb.clamp(1, MAX_BUCKETS);
        // Every list is empty here (the entries were taken out first).
        self.heads.clear();
        self.heads.resize(nb, NIL);
        self.cur = 0;
        self.origin = origin;
        self.inv_width = inv_width;
    }

    /// Rebuilds the calendar from the entries it holds (see the module documentation).
    fn rebuild(&mut self) {
        let mut keys = std::mem::take(&mut self.scratch_keys);
        keys.clear();
        self.take_run(&mut keys);
        keys.append(&mut self.heap);
        for b in 0..self.heads.len() {
            self.take_bucket(b, &mut keys);
        }
        keys.append(&mut self.overflow);

        let mut times = std::mem::take(&mut self.scratch_times);
        times.clear();
        times.extend(
            keys.iter()
                .map(|&k| self.keys[k as usize].time)
                .filter(|t| t.is_finite()),
        );
        let nb = keys.len().div_ceil(ENTRIES_PER_BUCKET).next_power_of_two();
        if times.len() < 2 {
            self.heap_mode();
        } else {
            let lowest = times.iter().copied().fold(f64::INFINITY, f64::min);
            let rank = (times.len() - 1) * 7 / 8;
            let (_, &mut quantile, _) = times.select_nth_unstable_by(rank, f64::total_cmp);
            let highest = times.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            // Ties up to the quantile: spread the calendar over all the times instead.
            let reach = if quantile > lowest { quantile } else { highest };
            let half = (nb / 2).max(1) as f64;
            self.lay_out(lowest, (reach - lowest) / half, nb);
        }

        for &k in &keys {
            self.keys[k as usize].place = Place::Absent;
        }
        for &k in &keys {
            self.insert(k);
        }
        self.ops = 0;
        self.scratch_keys = keys;
        self.scratch_times = times;
    }

    /// Makes the front hold the minimum entry whenever the queue is not empty, with a live
    /// last entry in the run if the run has any: drops the run's stale last entries,
    /// advances the current bucket over empty ones and rebuilds when needed.
    fn settle(&mut self) {
        loop {
            while let Some(&e) = self.run.last() {
                if self.keys[e as u32 as usize].place == Place::Run {
                    break;
                }
                self.run.pop();
            }
            if !(self.run.is_empty() && self.heap.is_empty()) {
                if self.run_live + self.heap.len() > FRONT_LIMIT && self.ops >= self.len {
                    // Resets `ops`, so this branch is not taken twice in a row.
                    self.rebuild();
                    continue;
                }
                return;
            }
            if self.len == 0 {
                return;
            }
            // Entries outside the front exist only with buckets, so `cur < nb` here.
            let nb = self.heads.len();
            let mut b = self.cur + 1;
            while b < nb && self.heads[b] == NIL {
                b += 1;
            }
            if b == nb {
                // Calendar exhausted: everything left is in the overflow. The rebuild puts
                // the earliest entry into the front.
                self.rebuild();
                continue;
            }
            self.cur = b;
            // The run is empty here (its stale entries were dropped above).
            let run = &mut self.run;
            drain_list(&mut self.heads, &mut self.keys, b, |k, record| {
                record.place = Place::Run;
                run.push(order(record.time, k));
            });
            self.run_live = self.run.len();
            self.run.sort_unstable_by(|x, y| y.cmp(x));
            self.read_ahead = self.heads[b + 1..]
                .iter()
                .take(READ_AHEAD_SCAN)
                .copied()
                .find(|&k| k != NIL)
                .unwrap_or(NIL);
        }
    }

    /// Appends the run's live keys to `out` and empties the run (their places are left to
    /// the caller).
    fn take_run(&mut self, out: &mut Vec<u32>) {
        let keys = &self.keys;
        out.extend(
            self.run
                .drain(..)
                .map(|e| e as u32)
                .filter(|&k| keys[k as usize].place == Place::Run),
        );
        self.run_live = 0;
    }

    /// The front's earliest key, and whether it is the run's (else the heap's root), once
    /// the front is settled.
    #[inline]
    fn earliest(&self) -> Option<(u32, bool)> {
        match (self.run.last(), self.heap.first()) {
            (Some(&e), Some(&h)) if self.order_of(h) < e => Some((h, false)),
            (Some(&e), _) => Some((e as u32, true)),
            (None, Some(&h)) => Some((h, false)),
            (None, None) => None,
        }
    }

    /// The [`order`] key of key `k`'s entry.
    #[inline]
    fn order_of(&self, k: u32) -> u128 {
        order(self.keys[k as usize].time, k)
    }

    /// Moves the read-ahead cursor one key along its list (see [`Self::read_ahead`]).
    #[inline]
    fn step_read_ahead(&mut self) {
        if let Some(record) = self.keys.get(self.read_ahead as usize) {
            self.read_ahead = record.link[1];
            if let Some(next) = self.keys.get(self.read_ahead as usize) {
                prefetch(next);
            }
        }
    }

    /// Appends the keys of bucket `b` to `out` and empties the bucket (their places are left
    /// to the caller).
    fn take_bucket(&mut self, b: usize, out: &mut Vec<u32>) {
        drain_list(&mut self.heads, &mut self.keys, b, |k, _| out.push(k));
    }

    /// Converts a key to its stored form, growing the per-key arrays when needed.
    ///
    /// # Panics
    /// If `key >= u32::MAX`.
    fn key(&mut self, key: usize) -> u32 {
        let k = u32::try_from(key)
            .ok()
            .filter(|&k| k < u32::MAX)
            .expect("CalendarQueue keys must be below u32::MAX");
        if key >= self.keys.len() {
            self.keys.resize(key + 1, KeyRecord::ABSENT);
        }
        k
    }
}

impl EventQueue for CalendarQueue {
    fn with_capacity(capacity: usize) -> Self {
        Self {
            keys: vec![KeyRecord::ABSENT; capacity],
            run: Vec::new(),
            run_live: 0,
            heap: Vec::new(),
            heads: Vec::new(),
            overflow: Vec::new(),
            cur: 0,
            origin: 0.0,
            inv_width: 1.0,
            len: 0,
            ops: 0,
            read_ahead: NIL,
            scratch_keys: Vec::new(),
            scratch_times: Vec::new(),
        }
    }

    fn reset(&mut self, start: f64, end: f64, expected_len: usize) {
        let mut keys = std::mem::take(&mut self.scratch_keys);
        keys.clear();
        self.take_run(&mut keys);
        keys.append(&mut self.heap);
        for b in 0..self.heads.len() {
            self.take_bucket(b, &mut keys);
        }
        for &k in &keys {
            self.keys[k as usize].place = Place::Absent;
        }
        self.scratch_keys = keys;
        for k in self.overflow.drain(..) {
            self.keys[k as usize].place = Place::Absent;
        }
        self.len = 0;
        self.ops = 0;
        let nb = expected_len
            .div_ceil(ENTRIES_PER_BUCKET)
            .max(1)
            .next_power_of_two()
            .min(MAX_BUCKETS);
        self.lay_out(start, (end - start) / nb as f64, nb);
    }

    fn schedule(&mut self, key: usize, time: f64) {
        let k = self.key(key);
        self.ops += 1;
        match self.keys[key].place {
            Place::Absent => self.len += 1,
            // Staying in the heap or in the same bucket: update in place (a key of the run
            // moves to the heap).
            Place::Heap(i) if self.slot(time) <= self.cur => {
                self.keys[key].time = time;
                self.heap_fix(i as usize);
                return;
            }
            Place::Bucket(index) if self.slot(time) == index as usize => {
                self.keys[key].time = time;
                return;
            }
            _ => self.unlink(k),
        }
        self.keys[key].time = time;
        self.insert(k);
    }

    fn cancel(&mut self, key: usize) {
        if self.keys.get(key).is_some_and(|r| r.place != Place::Absent) {
            self.unlink(key as u32);
            self.len -= 1;
            self.ops += 1;
        }
    }

    fn peek(&mut self) -> Option<(usize, f64)> {
        self.settle();
        self.step_read_ahead();
        let (k, _) = self.earliest()?;
        Some((k as usize, self.keys[k as usize].time))
    }

    /// The next keys of the run after the earliest, in order: exact unless the caller
    /// schedules an entry before them or moves them (a stale entry may be named). When the
    /// heap holds entries (rare), the likeliest next is the earlier of the run's next and the
    /// heap's next, and the other places go to the runner-up of each.
    #[inline]
    fn upcoming(&self) -> [Option<usize>; UPCOMING] {
        let n = self.run.len();
        let run_at = |d: usize| n.checked_sub(d).map(|i| self.run[i]);
        let run_key = |e: Option<u128>| e.map(|e| e as u32 as usize);
        if self.heap.is_empty() {
            return [2, 3, 4, 5].map(|d| run_key(run_at(d)));
        }
        let (a, b) = match (self.heap.get(1), self.heap.get(2)) {
            (Some(&x), Some(&y)) if self.before(y, x) => (2, 1),
            _ => (1, 2),
        };
        // The run's next two and the heap's, after the earliest entry of the front.
        let ((r1, r2), (h1, h2)) = match self.earliest() {
            Some((_, true)) => ((run_at(2), run_at(3)), (0, a)),
            _ => ((run_at(1), run_at(2)), (a, b)),
        };
        let (h1, h2) = (self.heap.get(h1).copied(), self.heap.get(h2).copied());
        let run_first = match (r1, h1) {
            (Some(e), Some(h)) => e < self.order_of(h),
            (r1, _) => r1.is_some(),
        };
        let heap_key = |h: Option<u32>| h.map(|k| k as usize);
        if run_first {
            [run_key(r1), heap_key(h1), run_key(r2), heap_key(h2)]
        } else {
            [heap_key(h1), run_key(r1), heap_key(h2), run_key(r2)]
        }
    }

    fn pop(&mut self) -> Option<(usize, f64)> {
        self.settle();
        let (k, in_run) = self.earliest()?;
        if in_run {
            self.run.pop();
            self.run_live -= 1;
        } else {
            self.heap_remove(0);
        }
        self.keys[k as usize].place = Place::Absent;
        self.len -= 1;
        self.ops += 1;
        Some((k as usize, self.keys[k as usize].time))
    }

    /// The key's record: a schedule reads its place, and its time and links move with it.
    fn prefetch(&self, key: usize) {
        if let Some(record) = self.keys.get(key) {
            prefetch(record);
        }
    }

    fn len(&self) -> usize {
        self.len
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    impl CalendarQueue {
        /// Asserts the invariants stated on the fields.
        fn check_invariants(&self) {
            let nb = self.heads.len();
            assert!(self.cur < nb || (nb == 0 && self.cur == 0));
            assert!(nb > 0 || self.overflow.is_empty());
            assert!(
                self.run.windows(2).all(|w| w[0] > w[1]),
                "the run is not sorted"
            );
            let mut live = 0;
            for &e in &self.run {
                let k = e as u32;
                if self.keys[k as usize].place == Place::Run {
                    assert_eq!(e, self.order_of(k));
                    assert!(self.slot(self.keys[k as usize].time) <= self.cur);
                    live += 1;
                }
            }
            assert_eq!(live, self.run_live);
            let in_run = self.keys.iter().filter(|r| r.place == Place::Run).count();
            assert_eq!(
                in_run, self.run_live,
                "a key of the run has two live entries"
            );
            for (i, &k) in self.heap.iter().enumerate() {
                assert_eq!(self.keys[k as usize].place, Place::Heap(i as u32));
                assert!(self.slot(self.keys[k as usize].time) <= self.cur);
                if i > 0 {
                    assert!(self.before(self.heap[(i - 1) / 2], k));
                }
            }
            let mut in_buckets = 0;
            for (b, &head) in self.heads.iter().enumerate() {
                assert!(b > self.cur || head == NIL);
                let (mut prev, mut k) = (NIL, head);
                while k != NIL {
                    assert_eq!(self.keys[k as usize].place, Place::Bucket(b as u32));
                    assert_eq!(self.slot(self.keys[k as usize].time), b);
                    assert_eq!(self.keys[k as usize].link[0], prev);
                    in_buckets += 1;
                    assert!(in_buckets <= self.len, "a bucket list has a cycle");
                    (prev, k) = (k, self.keys[k as usize].link[1]);
                }
            }
            for (pos, &k) in self.overflow.iter().enumerate() {
                assert_eq!(self.keys[k as usize].place, Place::Overflow(pos as u32));
                assert_eq!(self.slot(self.keys[k as usize].time), nb);
            }
            let total = self.run_live + self.heap.len() + in_buckets + self.overflow.len();
            assert_eq!(total, self.len);
            let present = self
                .keys
                .iter()
                .filter(|r| r.place != Place::Absent)
                .count();
            assert_eq!(present, self.len);
        }
    }

    /// Run entries order as `(time, key)` with times under `f64::total_cmp`.
    #[test]
    fn order_keys_sort_as_time_then_key() {
        let times = [
            f64::NEG_INFINITY,
            -3.5,
            -1e-300,
            -0.0,
            0.0,
            1e-300,
            0.25,
            7.0,
            f64::MAX,
            f64::INFINITY,
        ];
        for &a in &times {
            for &b in &times {
                for (ka, kb) in [(0, 1), (1, 0), (5, 5), (u32::MAX - 1, 0)] {
                    let expected = a.total_cmp(&b).then(ka.cmp(&kb));
                    assert_eq!(
                        order(a, ka).cmp(&order(b, kb)),
                        expected,
                        "{a} {ka} / {b} {kb}"
                    );
                }
            }
        }
    }

    /// A key's time, place and links share one 24-byte record (one cache miss per key).
    #[test]
    fn a_key_record_is_24_bytes() {
        assert_eq!(std::mem::size_of::<KeyRecord>(), 24);
    }

    /// The hold pattern keeps the calendar in calendar mode with a small front, with or
    /// without a reset, and the invariants hold throughout.
    #[test]
    fn hold_pattern_stays_a_calendar() {
        for use_reset in [true, false] {
            let n = 4096;
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
            let mut q = CalendarQueue::with_capacity(n);
            if use_reset {
                q.reset(0.0, 8.0, n);
            }
            for k in 0..n {
                q.schedule(k, -rng.gen::<f64>().ln());
            }
            let mut max_front = 0;
            for i in 0..200_000 {
                let (k, t) = q.pop().unwrap();
                q.schedule(k, t - rng.gen::<f64>().ln());
                q.schedule(rng.gen_range(0..n), t - rng.gen::<f64>().ln());
                if i > 1000 {
                    assert!(!q.heads.is_empty(), "heap mode at pop {i}");
                    max_front = max_front.max(q.run_live + q.heap.len());
                }
                if i % 10_000 == 0 {
                    q.check_invariants();
                }
            }
            q.check_invariants();
            assert!(max_front <= FRONT_LIMIT, "front grew to {max_front}");
        }
    }

    /// `upcoming` names the next minimum first: after the root is popped, the next peek
    /// returns the key it named (whenever it named one).
    #[test]
    fn upcoming_names_the_next_earliest_first() {
        let n = 4096;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
        let mut q = CalendarQueue::with_capacity(n);
        q.reset(0.0, 8.0, n);
        for k in 0..n {
            q.schedule(k, -rng.gen::<f64>().ln());
        }
        let mut named = 0;
        for _ in 0..50_000 {
            let next = q.peek().and(q.upcoming()[0]);
            let (k, t) = q.pop().unwrap();
            if let Some(expected) = next {
                assert_eq!(q.peek().map(|e| e.0), Some(expected));
                named += 1;
            }
            q.schedule(k, t - rng.gen::<f64>().ln());
        }
        assert!(named > 25_000, "named the next key only {named} times");
    }

    /// The read-ahead cursor walks the list of the next non-empty bucket, one key per peek.
    #[test]
    fn read_ahead_walks_the_next_bucket() {
        let mut q = CalendarQueue::with_capacity(8);
        q.reset(0.0, 16.0, 16); // 4 buckets of width 4
        for (k, t) in [(0, 1.0), (1, 5.0), (2, 5.5), (3, 6.0), (4, 9.0), (5, 9.5)] {
            q.schedule(k, t);
        }
        assert_eq!(q.pop(), Some((0, 1.0)));
        // Taking bucket 1 points the cursor at the head of bucket 2 (key 5, inserted last);
        // the peek steps it to key 4, the next one to the end of the list.
        assert_eq!(q.peek(), Some((1, 5.0)));
        assert_eq!(q.read_ahead, 4);
        assert_eq!(q.peek(), Some((1, 5.0)));
        assert_eq!(q.read_ahead, NIL);
    }

    /// A window far too wide crowds the front; the queue rebuilds itself a fitting calendar.
    #[test]
    fn bad_window_is_repaired() {
        let n = 10_000;
        let mut q = CalendarQueue::with_capacity(n);
        q.reset(0.0, 1e9, 16);
        for k in 0..n {
            q.schedule(k, k as f64 * 1e-3);
        }
        for k in 0..n {
            assert_eq!(q.pop(), Some((k, k as f64 * 1e-3)));
            assert!(q.run_live + q.heap.len() <= FRONT_LIMIT + 1);
            if k % 1000 == 0 {
                q.check_invariants();
            }
        }
        assert_eq!(q.pop(), None);
    }
}
