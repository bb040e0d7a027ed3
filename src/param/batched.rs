//! Candidates tried in order until one is kept, evaluated a batch at a time side by side.

use rayon::prelude::*;

use super::CancelCheck;

/// Tries `items` in order and stops at the first that `take` keeps, as a plain loop would,
/// but evaluates them (`eval`, the costly repair of a candidate) a batch of the thread pool's
/// width at a time, side by side: `take` sees the outcomes in order, so what is kept is what
/// the loop would keep, and at most a batch's width less one is evaluated beyond it. A
/// windings re-rounding's try is a repair of the whole map, tens of milliseconds each
/// (fandisk with features at 40°: three tries, none kept, 256 → 165 ms on two cores).
pub(crate) fn first_taken<T: Send, R: Send>(
    items: Vec<T>,
    cancel: CancelCheck<'_>,
    eval: impl Fn(T) -> R + Sync,
    mut take: impl FnMut(R) -> bool,
) -> bool {
    let width = rayon::current_num_threads().max(1);
    let mut items = items.into_iter().peekable();
    while items.peek().is_some() {
        if cancel() {
            return false;
        }
        let batch: Vec<T> = items.by_ref().take(width).collect();
        let outcomes: Vec<R> = batch.into_par_iter().map(&eval).collect();
        for r in outcomes {
            if take(r) {
                return true;
            }
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The batched tries keep what the plain loop keeps: the first in order that `take`
    /// accepts, with every earlier outcome seen in order, and nothing evaluated past the batch
    /// of the kept one; a cancel before a batch stops it.
    #[test]
    fn batched_tries_keep_the_first_in_order() {
        let width = rayon::current_num_threads().max(1);
        for kept_at in [0usize, 1, 2, 5, 9, 40] {
            let items: Vec<usize> = (0..12).collect();
            let evaluated = std::sync::Mutex::new(Vec::new());
            let mut seen = Vec::new();
            let found = first_taken(
                items,
                &|| false,
                |i| {
                    evaluated.lock().unwrap().push(i);
                    i * 10
                },
                |r| {
                    seen.push(r);
                    r == kept_at * 10
                },
            );
            let sequential: Vec<usize> = (0..12)
                .take_while(|&i| i < kept_at)
                .chain((kept_at < 12).then_some(kept_at))
                .map(|i| i * 10)
                .collect();
            assert_eq!(found, kept_at < 12);
            assert_eq!(seen, sequential, "kept at {kept_at}");
            let last_batch_end = if kept_at < 12 {
                (kept_at / width + 1) * width
            } else {
                12
            };
            let mut ev = evaluated.into_inner().unwrap();
            ev.sort_unstable();
            assert_eq!(ev, (0..last_batch_end.min(12)).collect::<Vec<_>>());
        }
        let calls = std::sync::atomic::AtomicUsize::new(0);
        let taken = first_taken(
            vec![1, 2, 3],
            &|| true,
            |i: i32| {
                calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                i
            },
            |_| true,
        );
        assert!(!taken);
        assert_eq!(calls.into_inner(), 0);
    }
}
