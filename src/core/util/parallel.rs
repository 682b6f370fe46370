//! Data-parallel loops whose results do not depend on the thread count.
//!
//! Every kernel here computes each output element from its inputs alone
//! (a map, or a gather in a fixed order), so the bits are the same whether
//! rayon runs it on one thread or many. Reductions either pick an element by
//! a total order with ties broken by index (`first_min`, `first_max`,
//! `position_first`), or are left to the caller as a serial sum over a
//! per-element buffer, in element order, so a sum has the same rounding as
//! the single-threaded loop it replaces.
//!
//! Loops shorter than [`SPLIT_FACTOR`] grains run on the calling thread: at
//! that size waking the pool costs more than it saves.

use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Elements per rayon task by default (the grain). A loop splits only
/// from [`SPLIT_FACTOR`] grains.
///
/// Measured on the 2-core test VM (2026-12-06, the 10242-vertex RBC of
/// `scenes/fluid/red_blood_cell.ron` at h = 1/4 with plain FIRE, 100
/// iterations, medians of 3 runs of one binary): with every loop of that
/// mesh split, in tasks of 1024, 2 threads against 1 run the Gather and
/// Forces stages and the constraint projection 1.72× faster (18.5 → 10.8
/// ms a tick; the projection's 1-ring smoothing, a loop over the vertices,
/// 1.76×; the face geometry 2.5×, the edge samples 1.9×, the terms 1.5×);
/// split from 16384 (tasks of 2048) its vertex loops stayed on one thread.
/// Loops split from 8192, so a 2562-vertex mesh (5120 faces, 7680 edges)
/// stays on one thread as before: earlier measurements (before runs went
/// through [`on_pool`]) had it 1.5× slower on 2 threads with loops split
/// from 4096, and its Metropolis-flipped form rebuilds its incidence
/// ([`Incidence`]) every tick. The VM is shared: with another process on
/// the second core, 2 threads are no faster than one, and measurements are
/// only meaningful while a plain compute loop scales (≥ 1.7×).
pub const DEFAULT_GRAIN: usize = 1024;

/// A loop splits from this many grains (8192 elements by default: every
/// loop of a 10242-vertex mesh, none of a 2562-vertex one).
pub const SPLIT_FACTOR: usize = 8;

static GRAIN: AtomicUsize = AtomicUsize::new(DEFAULT_GRAIN);

/// Sets the grain for the whole process (see [`DEFAULT_GRAIN`]). Results do
/// not depend on it: tests lower it so a small mesh takes every parallel
/// path.
pub fn set_grain(elements: usize) {
    GRAIN.store(elements.max(1), Ordering::Relaxed);
}

/// The current grain (elements per task).
#[inline]
pub fn grain() -> usize {
    GRAIN.load(Ordering::Relaxed)
}

/// Runs `f` on a worker thread of the current rayon pool and waits for it.
///
/// A parallel loop started from a thread outside the pool hands its work
/// to the pool and sleeps until it is done: two thread wake-ups, ≈ 15-20 µs
/// on the 2-core test VM, per loop. Started from a worker, the loop splits
/// by work stealing and costs ≈ 1-4 µs. A whole run therefore goes through
/// here once.
/// On a one-thread pool `f` runs on the calling thread.
pub fn on_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    if rayon::current_num_threads() > 1 {
        rayon::scope(|_| f())
    } else {
        f()
    }
}

/// Whether a loop of `len` elements is split across threads (false on a
/// one-thread pool and below [`SPLIT_FACTOR`] tasks of [`grain`] elements).
#[inline]
pub fn splits(len: usize) -> bool {
    len >= SPLIT_FACTOR * grain() && rayon::current_num_threads() > 1 && !SERIAL.get()
}

thread_local! {
    /// Set while this thread runs a task of [`serially`].
    static SERIAL: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f` with every loop of this module on the calling thread (no
/// loop [`splits`]): for a task that already runs beside others (the
/// force terms, each on its own worker), where the loops' own splitting
/// would only add the work of their parallel forms.
pub fn serially<R>(f: impl FnOnce() -> R) -> R {
    /// Puts the flag back however `f` ends (a panic caught further up, as
    /// the Python bindings do, must not leave a worker serial).
    struct Restore(bool);
    impl Drop for Restore {
        fn drop(&mut self) {
            SERIAL.set(self.0);
        }
    }
    let _restore = Restore(SERIAL.replace(true));
    f()
}

// Every helper hands the caller's closure a whole chunk (or the whole range
// on one thread), so the per-element loop is compiled inside one closure
// body and the element code inlines into it; a per-element closure called
// from both a serial and a parallel loop stays out of line and costs ~2×.

/// Calls `body(start, chunk)` on consecutive chunks of `out` (`start` is
/// the chunk's first index).
pub fn for_chunks<T: Send>(out: &mut [T], body: impl Fn(usize, &mut [T]) + Sync + Send) {
    if splits(out.len()) {
        let g = grain();
        out.par_chunks_mut(g)
            .enumerate()
            .for_each(|(c, chunk)| body(c * g, chunk));
    } else {
        body(0, out);
    }
}

/// [`for_chunks`] over two slices of the same length at once:
/// `body(start, a_chunk, b_chunk)`.
pub fn for_chunks2<A: Send, B: Send>(
    a: &mut [A],
    b: &mut [B],
    body: impl Fn(usize, &mut [A], &mut [B]) + Sync + Send,
) {
    assert_eq!(a.len(), b.len());
    if splits(a.len()) {
        let g = grain();
        a.par_chunks_mut(g)
            .zip(b.par_chunks_mut(g))
            .enumerate()
            .for_each(|(c, (x, y))| body(c * g, x, y));
    } else {
        body(0, a, b);
    }
}

/// `map(range)` on consecutive index ranges covering `0..len`, combined in
/// any grouping by `combine`: the result is thread-count independent when
/// `combine` is associative and commutative on the values `map` returns.
pub fn reduce_ranges<R: Send>(
    len: usize,
    identity: impl Fn() -> R + Sync + Send,
    map: impl Fn(std::ops::Range<usize>) -> R + Sync + Send,
    combine: impl Fn(R, R) -> R + Sync + Send,
) -> R {
    if splits(len) {
        let g = grain();
        (0..len.div_ceil(g))
            .into_par_iter()
            .map(|c| map(c * g..((c + 1) * g).min(len)))
            .reduce(identity, combine)
    } else {
        map(0..len)
    }
}

/// Resizes `out` to `len` (writing defaults only when the length changes;
/// every element is then overwritten) and sets `out[i] = f(i)`.
pub fn fill_vec<T: Send + Default + Clone>(
    out: &mut Vec<T>,
    len: usize,
    f: impl Fn(usize) -> T + Sync + Send,
) {
    if out.len() != len {
        out.clear();
        reserve_for(out, len);
        out.resize(len, T::default());
    }
    fill(out, f);
}

/// Makes room in `out` for `len` elements, with 1/32 of headroom when it
/// has to grow: a mesh that grows by remeshing reallocates its buffers once
/// per few per cent of growth, instead of doubling them (a 40962-vertex
/// run held 11 MB of face geometry it never used).
pub fn reserve_for<T>(out: &mut Vec<T>, len: usize) {
    if len > out.capacity() {
        out.reserve_exact(len + len / 32 - out.len());
    }
}

/// Sets `out[i] = f(i)` for every index.
pub fn fill<T: Send>(out: &mut [T], f: impl Fn(usize) -> T + Sync + Send) {
    for_chunks(out, |start, chunk| {
        for (j, x) in chunk.iter_mut().enumerate() {
            *x = f(start + j);
        }
    });
}

/// Calls `f(i, &mut out[i])` for every index.
pub fn for_each_mut<T: Send>(out: &mut [T], f: impl Fn(usize, &mut T) + Sync + Send) {
    for_chunks(out, |start, chunk| {
        for (j, x) in chunk.iter_mut().enumerate() {
            f(start + j, x);
        }
    });
}

/// The smallest index `i < len` with `pred(i)`, if any.
pub fn position_first(len: usize, pred: impl Fn(usize) -> bool + Sync + Send) -> Option<usize> {
    reduce_ranges(
        len,
        || None,
        |range| range.into_iter().find(|&i| pred(i)),
        |a, b| match (a, b) {
            (Some(i), Some(j)) => Some(i.min(j)),
            (a, b) => a.or(b),
        },
    )
}

/// The first index whose `key(i)` is strictly smaller than every earlier
/// key and than `bound`: what a serial scan `if key < best { best = key }`
/// starting from `bound` ends with. NaN keys never win. `None` when no key
/// is below `bound`.
pub fn first_min(
    len: usize,
    bound: f64,
    key: impl Fn(usize) -> f64 + Sync + Send,
) -> Option<(usize, f64)> {
    reduce_ranges(
        len,
        || None,
        |range| {
            let (mut best, mut value) = (None, bound);
            for i in range {
                let k = key(i);
                if k < value {
                    value = k;
                    best = Some(i);
                }
            }
            best.map(|i| (i, value))
        },
        |a, b| match (a, b) {
            // Values below the bound are never NaN: a total order, ties to
            // the lower index.
            (Some((i, x)), Some((j, y))) => Some(if y < x || (y == x && j < i) {
                (j, y)
            } else {
                (i, x)
            }),
            (a, b) => a.or(b),
        },
    )
}

/// The first index whose `key(i)` is strictly larger than every earlier key
/// and than `bound` (see [`first_min`]).
pub fn first_max(
    len: usize,
    bound: f64,
    key: impl Fn(usize) -> f64 + Sync + Send,
) -> Option<(usize, f64)> {
    first_min(len, -bound, |i| -key(i)).map(|(i, k)| (i, -k))
}

/// The indices `i < len` with `pred(i)`, ascending, into `out`.
pub fn filter_indices(len: usize, out: &mut Vec<u32>, pred: impl Fn(usize) -> bool + Sync + Send) {
    out.clear();
    let pick = |range: std::ops::Range<usize>, out: &mut Vec<u32>| {
        out.extend(range.filter(|&i| pred(i)).map(|i| i as u32));
    };
    if splits(len) {
        let g = grain();
        let parts: Vec<Vec<u32>> = (0..len.div_ceil(g))
            .into_par_iter()
            .map(|c| {
                let mut part = Vec::new();
                pick(c * g..((c + 1) * g).min(len), &mut part);
                part
            })
            .collect();
        out.extend(parts.into_iter().flatten());
    } else {
        pick(0..len, out);
    }
}

/// Adds each item's per-vertex contributions into its vertices with
/// `add(&mut out[v], c)` and returns Σ of the items' values, where an item
/// is a face (`K = 3`) or an edge (`K = 2`) and `contribution(item) =
/// (value, [c_0 … c_K−1])` for its vertices `items[item]`.
///
/// The items go in blocks of [`SPLIT_FACTOR`] grains: a block's
/// contributions are computed in parallel into one half of `per_item` while
/// the previous block's are added (and their values summed) in item order on
/// one thread, so the additions overlap the next block's work and the result
/// has the rounding of the serial loop it replaces. Two blocks are held at a
/// time (1.3 MB for faces' pull-backs by default) instead of one
/// contribution per item (6.5 MB at 81920 faces). It pays where an item's
/// contribution costs much more than its additions (the dihedral bending;
/// the cotangent bending and V_in add theirs by [`gather`], in parallel).
pub fn accumulate<const K: usize, T: Copy + Send + Sync + Default, O: Send>(
    items: &[[u32; K]],
    out: &mut [O],
    per_item: &mut Vec<(f64, [T; K])>,
    contribution: impl Fn(usize) -> (f64, [T; K]) + Sync + Send,
    add: impl Fn(&mut O, T) + Sync + Send,
) -> f64 {
    if items.is_empty() {
        return 0.0;
    }
    let block = (SPLIT_FACTOR * grain()).min(items.len());
    if per_item.len() != 2 * block {
        per_item.clear();
        per_item.resize(2 * block, (0.0, [T::default(); K]));
    }
    let (mut ready, mut next) = per_item.split_at_mut(block);
    let (g, blocks) = (grain(), items.len().div_ceil(block));
    let mut sum = 0.0;
    // Step b computes block b while adding block b − 1. (One call site
    // each, so `contribution` inlines into the chunk loop.)
    for b in 0..=blocks {
        let (added, computed) = (b.checked_sub(1), (b < blocks).then_some(b));
        let (s, ()) = rayon::join(
            || match added {
                Some(a) => {
                    let range = a * block..((a + 1) * block).min(items.len());
                    let mut sum = sum;
                    for (vertices, (value, c)) in items[range].iter().zip(ready.iter()) {
                        sum += value;
                        for (j, &v) in vertices.iter().enumerate() {
                            add(&mut out[v as usize], c[j]);
                        }
                    }
                    sum
                }
                None => sum,
            },
            || {
                if let Some(b) = computed {
                    let start = b * block;
                    let len = block.min(items.len() - start);
                    next[..len]
                        .par_chunks_mut(g)
                        .enumerate()
                        .for_each(|(c, chunk)| {
                            let first = start + c * g;
                            for (j, x) in chunk.iter_mut().enumerate() {
                                *x = contribution(first + j);
                            }
                        });
                }
            },
        );
        sum = s;
        std::mem::swap(&mut ready, &mut next);
    }
    sum
}

/// Each element's incident items in ascending item order, as entries
/// `item << 2 | corner` ([`entry`]; `corner` is the element's place in the
/// item, < 4), in fixed-size blocks: element `v`'s entries are
/// `entries[v·stride ..][..len[v]]`. With it a loop over items that adds
/// each item's per-corner contributions into its elements (a scatter, one
/// thread) becomes a gather: every element sums its own items'
/// contributions in item order, which are the additions the scatter made
/// into that element, in the same order, so the same bits, and the
/// elements are independent ([`gather`]).
#[derive(Clone, Debug, Default)]
pub struct Incidence {
    stride: usize,
    len: Vec<u32>,
    entries: Vec<u32>,
}

/// Equal when every element has the same entries (whatever the blocks'
/// size).
impl PartialEq for Incidence {
    fn eq(&self, other: &Self) -> bool {
        self.elements() == other.elements()
            && (0..self.elements()).all(|v| self.of(v) == other.of(v))
    }
}

impl Eq for Incidence {}

/// The [`Incidence`] entry of corner `corner` of item `item`.
#[inline(always)]
pub fn entry(item: usize, corner: usize) -> u32 {
    debug_assert!(corner < 4 && item < (1 << 30));
    ((item as u32) << 2) | corner as u32
}

impl Incidence {
    /// Builds the blocks of `elements` elements of `stride` entries, in
    /// parallel: `fill(v, block)` writes element v's entries (in ascending
    /// item order) into the start of `block` and returns how many.
    pub fn build(
        elements: usize,
        stride: usize,
        fill: impl Fn(usize, &mut [u32]) -> usize + Sync + Send,
    ) -> Self {
        let mut out = Incidence {
            stride,
            len: vec![0; elements],
            entries: vec![0; elements * stride],
        };
        if stride == 0 {
            return out;
        }
        let entries = &mut out.entries;
        let len = &mut out.len;
        let body = |first: usize, blocks: &mut [u32], lens: &mut [u32]| {
            for (j, (block, l)) in blocks.chunks_mut(stride).zip(lens).enumerate() {
                *l = fill(first + j, block) as u32;
            }
        };
        if splits(elements) {
            let g = grain();
            entries
                .par_chunks_mut(g * stride)
                .zip(len.par_chunks_mut(g))
                .enumerate()
                .for_each(|(c, (blocks, lens))| body(c * g, blocks, lens));
        } else {
            body(0, entries, len);
        }
        out
    }

    /// The incidence of `items` (each naming K of `elements` elements),
    /// one thread (tests, and where no topology keeps one).
    pub fn from_items<const K: usize>(items: &[[u32; K]], elements: usize) -> Self {
        let mut count = vec![0u32; elements];
        for item in items {
            for &v in item {
                count[v as usize] += 1;
            }
        }
        let stride = count.iter().copied().max().unwrap_or(0) as usize;
        let mut out = Incidence {
            stride,
            len: vec![0; elements],
            entries: vec![0; elements * stride],
        };
        for (i, item) in items.iter().enumerate() {
            for (k, &v) in item.iter().enumerate() {
                let v = v as usize;
                out.entries[v * stride + out.len[v] as usize] = entry(i, k);
                out.len[v] += 1;
            }
        }
        out
    }

    /// Number of elements.
    #[inline]
    pub fn elements(&self) -> usize {
        self.len.len()
    }

    /// Element `v`'s entries, in ascending item order.
    #[inline(always)]
    pub fn of(&self, v: usize) -> &[u32] {
        let lo = v * self.stride;
        &self.entries[lo..lo + self.len[v] as usize]
    }
}

/// For every element `v` of `out`, in parallel: `add(&mut out[v], c)` for
/// each of its items' contributions `c = per_item[item][corner]`, in
/// ascending item order ([`Incidence`]): the bits of the serial loop
/// `for item { for corner { add(&mut out[items[item][corner]], …) } }`,
/// on any thread count.
pub fn gather<const K: usize, T: Copy + Sync, O: Send>(
    incidence: &Incidence,
    per_item: &[[T; K]],
    out: &mut [O],
    add: impl Fn(&mut O, T) + Sync + Send,
) {
    debug_assert_eq!(incidence.elements(), out.len());
    for_chunks(out, |start, chunk| {
        for (j, o) in chunk.iter_mut().enumerate() {
            for &e in incidence.of(start + j) {
                add(o, per_item[(e >> 2) as usize][(e & 3) as usize]);
            }
        }
    });
}

/// A rayon pool of `threads` threads, for the tests that run a kernel on
/// 1, 2 and 3 threads.
#[cfg(test)]
pub(crate) fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accumulate_adds_in_item_order_for_any_thread_count() {
        // Two and a half blocks of faces on 5000 vertices, so every vertex
        // gets contributions from several blocks.
        let (n, items) = (5000u32, 5 * SPLIT_FACTOR * grain() / 2 + 7);
        let faces: Vec<[u32; 3]> = (0..items as u32)
            .map(|k| [k % n, (k * 7 + 1) % n, (k * 13 + 2) % n])
            .collect();
        let value = |k: usize| ((k * 2654435761) % 1000003) as f64 / 7.0;
        let contribution = |k: usize| {
            (
                value(k) * 1e-3,
                [value(k), 1.0 / (1.0 + value(k)), value(k).sqrt()],
            )
        };
        let (mut serial, mut serial_sum) = (vec![0.0f64; n as usize], 0.0);
        for (k, f) in faces.iter().enumerate() {
            let (v, c) = contribution(k);
            serial_sum += v;
            for j in 0..3 {
                serial[f[j] as usize] += c[j];
            }
        }
        for threads in [1, 2, 3] {
            let mut out = vec![0.0f64; n as usize];
            let sum = pool(threads).install(|| {
                accumulate(&faces, &mut out, &mut Vec::new(), contribution, |o, c| {
                    *o += c
                })
            });
            assert_eq!(sum.to_bits(), serial_sum.to_bits(), "{threads} threads");
            assert!(
                out.iter()
                    .zip(&serial)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "{threads} threads"
            );
        }
        let none: &[[u32; 3]] = &[];
        let mut nothing: Vec<f64> = Vec::new();
        let empty = accumulate(none, &mut nothing, &mut Vec::new(), contribution, |o, c| {
            *o += c
        });
        assert_eq!(empty, 0.0, "no items");
    }

    #[test]
    fn gather_adds_in_item_order_for_any_thread_count() {
        // Small grains, so that 3000 elements split (results do not depend
        // on the grain: other tests may run meanwhile).
        set_grain(64);
        let (n, items) = (3000u32, 7001usize);
        let faces: Vec<[u32; 3]> = (0..items as u32)
            .map(|k| [k % n, (k * 7 + 1) % n, (k * 13 + 2) % n])
            .collect();
        let value = |k: usize, j: usize| ((k * 2654435761 + j * 40503) % 1000003) as f64 / 7.0;
        let per_item: Vec<[f64; 3]> = (0..items)
            .map(|k| [value(k, 0), 1.0 / (1.0 + value(k, 1)), -value(k, 2).sqrt()])
            .collect();
        let start = |v: usize| 1.0 / (1.0 + v as f64);
        let mut serial: Vec<f64> = (0..n as usize).map(start).collect();
        for (f, c) in faces.iter().zip(&per_item) {
            for j in 0..3 {
                serial[f[j] as usize] -= c[j];
            }
        }
        let incidence = Incidence::from_items(&faces, n as usize);
        for threads in [1, 2, 3] {
            let mut out: Vec<f64> = (0..n as usize).map(start).collect();
            pool(threads).install(|| gather(&incidence, &per_item, &mut out, |o, c| *o -= c));
            assert!(
                out.iter()
                    .zip(&serial)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "{threads} threads"
            );
            // The same blocks, built in parallel.
            let built = pool(threads).install(|| {
                Incidence::build(n as usize, incidence.stride, |v, block| {
                    let of = incidence.of(v);
                    block[..of.len()].copy_from_slice(of);
                    of.len()
                })
            });
            assert_eq!(built, incidence, "{threads} threads");
        }
        // Entries in item order, each naming the element's corner.
        for v in 0..n as usize {
            let of = incidence.of(v);
            assert!(of.windows(2).all(|w| w[0] >> 2 < w[1] >> 2));
            assert!(
                of.iter()
                    .all(|&e| faces[(e >> 2) as usize][(e & 3) as usize] == v as u32)
            );
        }
        set_grain(DEFAULT_GRAIN);
    }

    #[test]
    fn reductions_match_the_serial_scan_for_any_thread_count() {
        let n = (SPLIT_FACTOR + 3) * grain() + 17;
        // Repeated minima: the first one must win.
        let key = |i: usize| ((i * 7919) % 1013) as f64;
        let serial = {
            let (mut best, mut at) = (f64::INFINITY, None);
            for i in 0..n {
                if key(i) < best {
                    best = key(i);
                    at = Some(i);
                }
            }
            at.map(|i| (i, best))
        };
        for threads in [1, 2, 3] {
            let got = pool(threads).install(|| first_min(n, f64::INFINITY, key));
            assert_eq!(got, serial, "{threads} threads");
            let max = pool(threads).install(|| first_max(n, f64::NEG_INFINITY, key));
            assert_eq!(max.map(|m| m.1), Some(1012.0));
            let pos = pool(threads).install(|| position_first(n, |i| key(i) == 5.0));
            assert_eq!(pos, (0..n).position(|i| key(i) == 5.0));
            let mut idx = Vec::new();
            pool(threads).install(|| filter_indices(n, &mut idx, |i| i % 3 == 0));
            assert_eq!(idx.len(), n.div_ceil(3));
            assert!(idx.windows(2).all(|w| w[0] < w[1]));
        }
        assert_eq!(
            first_min(10, 0.0, |i| i as f64),
            None,
            "nothing below the bound"
        );
        assert_eq!(first_min(3, 1.0, |_| f64::NAN), None, "NaN never wins");
    }
}
