//! A bounded cache of decoded frames, keyed by view index, with decode-ahead.
//!
//! A capture can be far larger than memory (N3DV at half resolution: 300 frames × 20 cameras
//! of 1352×1014, about 25 GB as 8-bit RGB and four times that as the f32 images training
//! compares against). Training therefore reads its frames through a [`FrameCache`]: each
//! frame is a [`FrameSource`], either an image already in memory (a small dataset decoded
//! at load, or views built in code) or a file decoded when first asked for. Decoded frames
//! stay while they fit the memory budget; the least recently used leave first.
//!
//! [`FrameCache::prefetch`] starts decoding the frames the caller will ask for next on the
//! rayon pool (with the `rayon` feature; without it, frames are decoded when asked for), so
//! decoding overlaps the work on the current frames. What a caller receives never depends on
//! timing: [`FrameCache::get`] returns the same decoded image whether it was cached,
//! prefetched or decoded on the spot, and the order of use is the caller's.
//!
//! The budget counts the decoded frames the cache holds and those being decoded for it. A
//! frame asked for is always delivered, so the budget can be exceeded by the frames in use
//! at once (a training batch) when it is smaller than they are.

use super::dataset::View;
use evogs_splat::Image;
use std::collections::HashMap;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};

/// Where one frame comes from.
#[derive(Clone, Debug)]
pub enum FrameSource {
    /// Already decoded (never evicted, not counted in the budget).
    Memory(Arc<Image<f32>>),
    /// Decoded from the view's file when needed ([`View::decode_image`]).
    File(Box<View>),
}

impl FrameSource {
    fn bytes(&self) -> usize {
        match self {
            Self::Memory(img) => std::mem::size_of_val(img.data()),
            Self::File(v) => v.decoded_bytes(),
        }
    }
}

/// Counters of a cache's work.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CacheStats {
    /// Requests answered from the cache (including frames a prefetch had decoded).
    pub hits: u64,
    /// Requests that decoded the frame on the spot.
    pub misses: u64,
    /// Requests that waited for a prefetch still decoding.
    pub waits: u64,
    /// Frames decoded ahead of use.
    pub prefetched: u64,
    /// Frames dropped to stay within the budget.
    pub evicted: u64,
    /// Bytes of decoded frames held now (and being decoded for the cache).
    pub bytes: usize,
    /// The most bytes held at once.
    pub peak_bytes: usize,
}

#[derive(Debug)]
enum Slot {
    Ready {
        image: Arc<Image<f32>>,
        used: u64,
    },
    Decoding,
    #[cfg_attr(
        not(feature = "rayon"),
        allow(
            dead_code,
            reason = "only background decodes (rayon) leave a failure behind"
        )
    )]
    Failed(String),
}

#[derive(Debug, Default)]
struct State {
    slots: HashMap<usize, Slot>,
    tick: u64,
    stats: CacheStats,
}

#[derive(Debug, Default)]
struct Shared {
    state: Mutex<State>,
    changed: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, State> {
        // A panic while holding the lock leaves the counters at worst stale; the slots stay
        // consistent (each update is one assignment), so the poison is ignored.
        self.state
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Stores a background decode's result and wakes the waiters.
    #[cfg_attr(
        not(feature = "rayon"),
        allow(dead_code, reason = "background decodes need rayon")
    )]
    fn finish(&self, i: usize, bytes: usize, result: Result<Image<f32>, String>) {
        let mut st = self.lock();
        match result {
            Ok(img) => {
                st.tick += 1;
                let used = st.tick;
                st.slots.insert(
                    i,
                    Slot::Ready {
                        image: Arc::new(img),
                        used,
                    },
                );
            }
            Err(e) => {
                st.stats.bytes -= bytes;
                st.slots.insert(i, Slot::Failed(e));
            }
        }
        drop(st);
        self.changed.notify_all();
    }
}

/// A bounded cache of decoded frames (see the module documentation).
#[derive(Debug)]
pub struct FrameCache {
    sources: Vec<FrameSource>,
    budget: usize,
    shared: Arc<Shared>,
}

impl Clone for FrameCache {
    /// The same frames and budget, with an empty cache of its own.
    fn clone(&self) -> Self {
        Self::new(self.sources.clone(), self.budget)
    }
}

impl FrameCache {
    /// A cache over `sources` holding at most `budget_bytes` of decoded frames.
    #[must_use]
    pub fn new(sources: Vec<FrameSource>, budget_bytes: usize) -> Self {
        Self {
            sources,
            budget: budget_bytes,
            shared: Arc::default(),
        }
    }

    /// Number of frames.
    #[must_use]
    pub fn len(&self) -> usize {
        self.sources.len()
    }

    /// Whether there are no frames.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.sources.is_empty()
    }

    /// The memory budget in bytes.
    #[must_use]
    pub fn budget(&self) -> usize {
        self.budget
    }

    /// The frames' sources.
    #[must_use]
    pub fn sources(&self) -> &[FrameSource] {
        &self.sources
    }

    /// The counters so far.
    #[must_use]
    pub fn stats(&self) -> CacheStats {
        self.shared.lock().stats
    }

    /// Frame `i`: from memory, from the cache, from a prefetch (waiting for it to finish) or
    /// decoded now.
    ///
    /// # Errors
    /// The decode failed (the message names the file).
    ///
    /// # Panics
    /// If `i` is out of range.
    pub fn get(&self, i: usize) -> Result<Arc<Image<f32>>, String> {
        let view = match &self.sources[i] {
            FrameSource::Memory(img) => return Ok(Arc::clone(img)),
            FrameSource::File(v) => v,
        };
        let mut st = self.shared.lock();
        let mut waited = false;
        loop {
            st.tick += 1;
            let tick = st.tick;
            match st.slots.get_mut(&i) {
                Some(Slot::Ready { image, used }) => {
                    *used = tick;
                    let image = Arc::clone(image);
                    if !waited {
                        st.stats.hits += 1;
                    }
                    return Ok(image);
                }
                Some(Slot::Failed(_)) => {
                    let Some(Slot::Failed(e)) = st.slots.remove(&i) else {
                        unreachable!("matched a failed slot")
                    };
                    return Err(e);
                }
                Some(Slot::Decoding) => {
                    if !waited {
                        st.stats.waits += 1;
                        waited = true;
                    }
                    st = self.wait(st);
                }
                None => break,
            }
        }
        let bytes = view.decoded_bytes();
        self.make_room(&mut st, bytes, &[i]);
        st.slots.insert(i, Slot::Decoding);
        st.stats.misses += 1;
        reserve(&mut st.stats, bytes);
        drop(st);
        let result = view.decode_image().map_err(|e| e.to_string());
        let mut st = self.shared.lock();
        let out = match result {
            Ok(img) => {
                let image = Arc::new(img);
                st.tick += 1;
                let used = st.tick;
                st.slots.insert(
                    i,
                    Slot::Ready {
                        image: Arc::clone(&image),
                        used,
                    },
                );
                Ok(image)
            }
            Err(e) => {
                st.slots.remove(&i);
                st.stats.bytes -= bytes;
                Err(e)
            }
        };
        drop(st);
        self.shared.changed.notify_all();
        out
    }

    /// Starts decoding the frames of `upcoming` (the indices the caller will ask for next,
    /// soonest first) that are neither cached nor decoding, while they fit the budget
    /// (dropping least recently used frames not in `upcoming` to make room). Decodes run
    /// on the rayon pool; without the `rayon` feature this does nothing.
    pub fn prefetch(&self, upcoming: &[usize]) {
        #[cfg(feature = "rayon")]
        {
            let mut st = self.shared.lock();
            for (k, &i) in upcoming.iter().enumerate() {
                let FrameSource::File(view) = &self.sources[i] else {
                    continue;
                };
                if st.slots.contains_key(&i) || upcoming[..k].contains(&i) {
                    continue;
                }
                let bytes = view.decoded_bytes();
                if !self.make_room(&mut st, bytes, upcoming) {
                    break;
                }
                st.slots.insert(i, Slot::Decoding);
                st.stats.prefetched += 1;
                reserve(&mut st.stats, bytes);
                let shared = Arc::clone(&self.shared);
                let view = view.clone();
                rayon::spawn(move || {
                    let result = view.decode_image().map_err(|e| e.to_string());
                    shared.finish(i, bytes, result);
                });
            }
        }
        #[cfg(not(feature = "rayon"))]
        let _ = upcoming;
    }

    /// Drops least recently used frames (not in `keep`) until `bytes` more fit the budget;
    /// whether they fit.
    fn make_room(&self, st: &mut State, bytes: usize, keep: &[usize]) -> bool {
        while st.stats.bytes + bytes > self.budget {
            let oldest = st
                .slots
                .iter()
                .filter_map(|(&j, s)| match s {
                    Slot::Ready { used, .. } if !keep.contains(&j) => Some((*used, j)),
                    _ => None,
                })
                .min();
            let Some((_, j)) = oldest else {
                return false;
            };
            st.slots.remove(&j);
            st.stats.bytes -= self.sources[j].bytes();
            st.stats.evicted += 1;
        }
        true
    }

    /// Waits for a decode to finish. Inside a rayon pool the waiting thread first runs
    /// pending pool work (perhaps the very decode it waits for), so a pool of one thread
    /// cannot deadlock.
    fn wait<'a>(&'a self, st: MutexGuard<'a, State>) -> MutexGuard<'a, State> {
        #[cfg(feature = "rayon")]
        {
            drop(st);
            if matches!(rayon::yield_now(), Some(rayon::Yield::Executed)) {
                return self.shared.lock();
            }
            let st = self.shared.lock();
            self.shared
                .changed
                .wait_timeout(st, std::time::Duration::from_millis(2))
                .map(|(g, _)| g)
                .unwrap_or_else(|e| e.into_inner().0)
        }
        #[cfg(not(feature = "rayon"))]
        {
            self.shared
                .changed
                .wait(st)
                .unwrap_or_else(std::sync::PoisonError::into_inner)
        }
    }
}

fn reserve(stats: &mut CacheStats, bytes: usize) {
    stats.bytes += bytes;
    stats.peak_bytes = stats.peak_bytes.max(stats.bytes);
}

#[cfg(test)]
#[allow(clippy::float_cmp, reason = "a stored value is returned unchanged")]
mod tests {
    use super::*;
    use crate::data::image_io::{FrameDecode, save_png};
    use std::path::Path;

    /// `n` 4×3 PNG frames with distinct colours, as views.
    fn frames(dir: &Path, n: usize) -> Vec<FrameSource> {
        std::fs::create_dir_all(dir).expect("tmp");
        (0..n)
            .map(|i| {
                let img = Image::filled(4, 3, [i as f32 / 255.0, 0.5, 1.0]);
                let file = dir.join(format!("{i:04}.png"));
                save_png(&img, &file).expect("save");
                FrameSource::File(Box::new(View {
                    file,
                    time: 0.0,
                    c2w: [[0.0; 4]; 4],
                    fov_x: 1.0,
                    width: 4,
                    height: 3,
                    image: None,
                    decode: FrameDecode::default(),
                }))
            })
            .collect()
    }

    fn red(img: &Image<f32>) -> f32 {
        img.get(0, 0)[0] * 255.0
    }

    #[test]
    fn least_recently_used_frames_leave_first_and_the_budget_holds() {
        let dir = std::env::temp_dir().join(format!("evogs-cache-lru-{}", std::process::id()));
        let src = frames(&dir, 6);
        let frame = 4 * 3 * 3 * 4;
        let cache = FrameCache::new(src, 3 * frame);
        for i in [0, 1, 2] {
            assert!(
                (red(&cache.get(i).expect("get")) - i as f32).abs() < 1e-3,
                "frame {i}"
            );
        }
        assert!(cache.get(0).is_ok(), "hit");
        // Frame 1 is now the least recently used: asking for 3 evicts it, not 0.
        assert!(cache.get(3).is_ok(), "decode");
        let s = cache.stats();
        assert_eq!((s.hits, s.misses, s.evicted), (1, 4, 1), "{s:?}");
        assert!(s.bytes <= 3 * frame && s.peak_bytes <= 3 * frame, "{s:?}");
        assert!(cache.get(0).is_ok() && cache.stats().hits == 2, "0 kept");
        assert!(
            cache.get(1).is_ok() && cache.stats().misses == 5,
            "1 was evicted"
        );
        std::fs::remove_dir_all(dir).ok();
    }

    #[test]
    fn prefetched_frames_equal_frames_decoded_on_demand() {
        let dir = std::env::temp_dir().join(format!("evogs-cache-pre-{}", std::process::id()));
        let src = frames(&dir, 8);
        let cold = FrameCache::new(src.clone(), usize::MAX);
        let warm = FrameCache::new(src, 4 * 4 * 3 * 3 * 4);
        warm.prefetch(&[5, 6, 7, 5, 0, 1]);
        for i in [5, 6, 7, 0, 1, 2] {
            let (a, b) = (cold.get(i).expect("cold"), warm.get(i).expect("warm"));
            assert_eq!(*a, *b, "frame {i} identical either way");
        }
        let s = warm.stats();
        #[cfg(feature = "rayon")]
        assert_eq!(s.prefetched, 4, "four fit the budget: {s:?}");
        assert_eq!(
            s.hits + s.waits + s.misses,
            6,
            "every request counted once: {s:?}"
        );
        assert!(s.peak_bytes <= 4 * 4 * 3 * 3 * 4, "{s:?}");
        std::fs::remove_dir_all(dir).ok();
    }

    #[test]
    fn memory_frames_pass_through_and_errors_name_the_file() {
        let dir = std::env::temp_dir().join(format!("evogs-cache-err-{}", std::process::id()));
        let mut src = frames(&dir, 2);
        src.push(FrameSource::Memory(Arc::new(Image::filled(
            2, 2, [0.25; 3],
        ))));
        std::fs::write(dir.join("0001.png"), b"not a png").expect("corrupt");
        let cache = FrameCache::new(src, usize::MAX);
        assert_eq!(cache.get(2).expect("memory").get(1, 1), [0.25; 3], "memory");
        cache.prefetch(&[1]);
        let e = cache.get(1).expect_err("corrupt frame");
        assert!(e.contains("0001.png"), "{e}");
        let e = cache.get(1).expect_err("still corrupt on retry");
        assert!(e.contains("0001.png"), "{e}");
        assert_eq!(cache.stats().bytes, 0, "failed decodes release their bytes");
        std::fs::remove_dir_all(dir).ok();
    }
}
