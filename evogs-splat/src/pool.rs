//! Work items on the pool: the crate's two ways of running independent pieces of work,
//! on rayon's pool with [`Par::Rayon`](evogs_math::Par) (work stealing over the items) or in
//! order on the calling thread with `Par::Seq`.
//!
//! Every caller splits its work into items of a **fixed** size (chunks of Gaussians, tiles,
//! bands of tile rows) and every item writes only itself, so what is computed does not depend
//! on the schedule or on the number of threads; results that combine items (a camera
//! gradient, a flag) are combined in item order by the caller.

use alloc::vec::Vec;
use evogs_math::Par;

/// Runs `f(index, item)` on every item.
pub(crate) fn for_each_item<S: Send>(
    par: Par,
    items: &mut [S],
    f: impl Fn(usize, &mut S) + Sync + Send,
) {
    #[cfg(feature = "rayon")]
    if matches!(par, Par::Rayon) {
        use rayon::prelude::*;
        items.par_iter_mut().enumerate().for_each(|(i, s)| f(i, s));
        return;
    }
    let _ = par;
    for (i, s) in items.iter_mut().enumerate() {
        f(i, s);
    }
}

/// Runs `f` on every item, collecting the results in item order.
pub(crate) fn run_items<S: Send, R: Send>(
    par: Par,
    items: &mut [S],
    f: impl Fn(&mut S) -> R + Sync + Send,
) -> Vec<R> {
    #[cfg(feature = "rayon")]
    if matches!(par, Par::Rayon) {
        use rayon::prelude::*;
        return items.par_iter_mut().map(f).collect();
    }
    let _ = par;
    items.iter_mut().map(f).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_item_is_visited_once_with_its_index_and_results_keep_item_order() {
        for par in [Par::Seq, Par::best()] {
            let mut items: Vec<(usize, u32)> = (0..100).map(|i| (i, 0)).collect();
            for_each_item(par, &mut items, |i, s| {
                assert_eq!(i, s.0, "index");
                s.1 += 1;
            });
            assert!(items.iter().all(|s| s.1 == 1), "{par:?}: once each");
            let doubled = run_items(par, &mut items, |s| 2 * s.0);
            assert_eq!(
                doubled,
                (0..100).map(|i| 2 * i).collect::<Vec<_>>(),
                "{par:?}"
            );
        }
    }
}
