//! A single-slot mailbox: the latest value and its generation number. Posting replaces what
//! was there (the old value is never seen by anyone who had not taken it yet), so a burst of
//! slider moves costs one render, not one per move.
//!
//! ```text
//!   post(a) -> 1   post(b) -> 2   post(c) -> 3      latest() = (3, c)   a and b are dropped
//! ```

use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// The latest value of type `T`, numbered 1, 2, 3, ... in the order posted.
pub struct Mailbox<T> {
    slot: Mutex<Slot<T>>,
    changed: Condvar,
}

struct Slot<T> {
    generation: u64,
    value: Option<Arc<T>>,
}

impl<T> Default for Mailbox<T> {
    fn default() -> Self {
        Mailbox { slot: Mutex::new(Slot { generation: 0, value: None }), changed: Condvar::new() }
    }
}

impl<T> Mailbox<T> {
    fn lock(&self) -> MutexGuard<'_, Slot<T>> {
        // A holder that panicked left a consistent slot (every write is one assignment).
        self.slot.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Replaces the value; returns its generation (one more than the last).
    pub fn post(&self, value: T) -> u64 {
        let mut slot = self.lock();
        slot.generation += 1;
        slot.value = Some(Arc::new(value));
        self.changed.notify_all();
        slot.generation
    }

    /// The generation of the latest value (0 before the first post).
    pub fn generation(&self) -> u64 {
        self.lock().generation
    }

    /// The latest value and its generation, if anything was posted.
    pub fn latest(&self) -> Option<(u64, Arc<T>)> {
        let slot = self.lock();
        slot.value.clone().map(|v| (slot.generation, v))
    }

    /// Waits up to `timeout` for a value newer than generation `seen`.
    pub fn wait_newer(&self, seen: u64, timeout: Duration) -> Option<(u64, Arc<T>)> {
        let deadline = Instant::now() + timeout;
        let mut slot = self.lock();
        loop {
            if slot.generation > seen {
                if let Some(v) = &slot.value {
                    return Some((slot.generation, v.clone()));
                }
            }
            let left = deadline.checked_duration_since(Instant::now())?;
            slot = self.changed.wait_timeout(slot, left).unwrap_or_else(|e| e.into_inner()).0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_latest_value_wins_and_generations_count_posts() {
        let m = Mailbox::default();
        assert!(m.latest().is_none());
        assert_eq!(m.post("a"), 1);
        assert_eq!(m.post("b"), 2);
        assert_eq!(m.post("c"), 3);
        let (g, v) = m.latest().unwrap();
        assert_eq!((g, *v), (3, "c"));
        assert!(m.wait_newer(3, Duration::from_millis(10)).is_none());
        assert_eq!(*m.wait_newer(1, Duration::ZERO).unwrap().1, "c");
    }

    #[test]
    fn a_waiter_wakes_on_a_post_from_another_thread() {
        let m = Arc::new(Mailbox::default());
        let poster = {
            let m = m.clone();
            std::thread::spawn(move || {
                std::thread::sleep(Duration::from_millis(20));
                m.post(7)
            })
        };
        let (g, v) = m.wait_newer(0, Duration::from_secs(10)).unwrap();
        assert_eq!((g, *v), (1, 7));
        assert_eq!(poster.join().unwrap(), 1);
    }
}
