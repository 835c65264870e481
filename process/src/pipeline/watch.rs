//! Progress from inside a long stage. The stage runs on a thread of its own and counts what it has
//! done in an atomic counter; the caller's thread reads the counter a few times a second and hands it
//! to its progress display, which need not be shareable between threads (the command line's bar, a
//! Python callback).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

/// Runs `work` with a counter it adds to as it goes (up to `total`), calling `tick(done, total)` on
/// this thread whenever the count moved, about ten times a second, until `work` ends; returns what
/// `work` returned. A panic in `work` continues here. Work of one step (the global reconstruction,
/// which counts nothing) has nothing to show before it returns: it runs here, with no ticks.
pub fn watched<T: Send>(
    total: usize,
    work: impl FnOnce(&AtomicUsize) -> T + Send,
    mut tick: impl FnMut(usize, usize),
) -> T {
    let counter = AtomicUsize::new(0);
    // On a rayon worker (the Python bindings run their work on one) this thread must not sleep in a
    // polling loop: the work's own parallel loops may need this very worker (a pool of one thread, as
    // a Ray task has, would wait for ever). There the work runs here, with no ticks.
    if rayon::current_thread_index().is_some() || total <= 1 {
        return work(&counter);
    }
    std::thread::scope(|s| {
        let handle = s.spawn(|| work(&counter));
        let mut shown = None;
        while !handle.is_finished() {
            // Short of the total until the work has returned: the last step (writing) is still to come.
            let done = counter.load(Ordering::Relaxed).min(total.saturating_sub(1));
            if shown != Some(done) {
                tick(done, total);
                shown = Some(done);
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        handle.join().unwrap_or_else(|p| std::panic::resume_unwind(p))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_count_is_shown_as_it_moves_and_the_result_returned() {
        let mut seen = Vec::new();
        let out = watched(
            5,
            |c| {
                for _ in 0..5 {
                    c.fetch_add(1, Ordering::Relaxed);
                    std::thread::sleep(Duration::from_millis(150));
                }
                42
            },
            |d, t| seen.push((d, t)),
        );
        assert_eq!(out, 42);
        // Several distinct counts, rising, all below the total, each against the total.
        assert!(seen.len() >= 3, "{seen:?}");
        assert!(seen.windows(2).all(|w| w[0].0 < w[1].0) && seen.iter().all(|&(d, t)| d < 5 && t == 5), "{seen:?}");
    }

    #[test]
    fn work_of_one_step_shows_no_progress() {
        let mut seen = Vec::new();
        let out = watched(1, |_| 7, |d, t| seen.push((d, t)));
        assert_eq!(out, 7);
        assert!(seen.is_empty(), "{seen:?}");
    }

    #[test]
    fn on_a_pool_of_one_thread_parallel_work_still_finishes() {
        // A Ray task: RAYON_NUM_THREADS=1 and the bindings' work running on that one worker.
        use rayon::prelude::*;
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let sum = pool.install(|| {
            watched(
                1000,
                |c| {
                    (0..1000u64)
                        .into_par_iter()
                        .map(|i| {
                            c.fetch_add(1, Ordering::Relaxed);
                            i
                        })
                        .sum::<u64>()
                },
                |_, _| {},
            )
        });
        assert_eq!(sum, 999 * 1000 / 2);
    }
}
