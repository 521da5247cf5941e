//! Time: the [`Clock`] trait with a [`VirtualClock`] (simulated seconds,
//! advanced only by the event loop) and a [`WallClock`] (real seconds since
//! a start instant), and the [`EventQueue`] that orders simulated events.
//!
//! Actor code never holds a clock: drivers read theirs and pass `now` into
//! [`crate::net::Actor::handle`]. The same actor therefore runs on virtual
//! or wall time unchanged.
//!
//! The queue orders entries by `(time, sequence number)`: earliest first,
//! and among equal times in insertion order (FIFO), as nexosim's priority
//! queue does. Times compare with `f64::total_cmp`, so ordering never
//! panics; callers keep times finite (the simulator checks every duration an
//! actor returns).

use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::time::Instant;

/// A source of "now", in seconds.
pub trait Clock {
    /// Seconds since the start of the run.
    fn now(&self) -> f64;
}

/// Simulated time: stands still until the event loop advances it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VirtualClock {
    now: f64,
}

impl VirtualClock {
    /// A clock at time 0.
    pub fn new() -> Self {
        Self::default()
    }

    /// Moves the clock to `t`. Time never runs backwards: an earlier `t`
    /// leaves the clock where it is.
    pub fn advance_to(&mut self, t: f64) {
        if t > self.now {
            self.now = t;
        }
    }
}

impl Clock for VirtualClock {
    fn now(&self) -> f64 {
        self.now
    }
}

/// Real time since the clock was created.
#[derive(Clone, Copy, Debug)]
pub struct WallClock {
    origin: Instant,
}

impl WallClock {
    /// A clock reading 0 now.
    pub fn start() -> Self {
        WallClock {
            origin: Instant::now(),
        }
    }
}

impl Clock for WallClock {
    fn now(&self) -> f64 {
        self.origin.elapsed().as_secs_f64()
    }
}

struct Entry<T> {
    time: f64,
    seq: u64,
    item: T,
}

impl<T> PartialEq for Entry<T> {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl<T> Eq for Entry<T> {}
impl<T> PartialOrd for Entry<T> {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl<T> Ord for Entry<T> {
    /// Reversed, so that `BinaryHeap` (a max-heap) pops the earliest entry.
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .time
            .total_cmp(&self.time)
            .then(other.seq.cmp(&self.seq))
    }
}

/// Events ordered by time, FIFO among equal times. `push` and `pop` are
/// O(log n); `len` and `peek_time` O(1).
pub struct EventQueue<T> {
    heap: BinaryHeap<Entry<T>>,
    next_seq: u64,
}

impl<T> Default for EventQueue<T> {
    fn default() -> Self {
        EventQueue {
            heap: BinaryHeap::new(),
            next_seq: 0,
        }
    }
}

impl<T> EventQueue<T> {
    /// An empty queue.
    pub fn new() -> Self {
        Self::default()
    }

    /// Schedules `item` at `time`.
    pub fn push(&mut self, time: f64, item: T) {
        let seq = self.next_seq;
        self.next_seq += 1;
        self.heap.push(Entry { time, seq, item });
    }

    /// Removes and returns the earliest entry (the first pushed among equal
    /// times).
    pub fn pop(&mut self) -> Option<(f64, T)> {
        self.heap.pop().map(|e| (e.time, e.item))
    }

    /// Time of the earliest entry.
    pub fn peek_time(&self) -> Option<f64> {
        self.heap.peek().map(|e| e.time)
    }

    /// Number of scheduled entries.
    pub fn len(&self) -> usize {
        self.heap.len()
    }

    /// True if nothing is scheduled.
    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn queue_orders_by_time_then_fifo() {
        let mut q = EventQueue::new();
        q.push(2.0, "c");
        q.push(1.0, "a");
        q.push(2.0, "d");
        q.push(1.0, "b");
        q.push(0.5, "first");
        let order: Vec<_> = std::iter::from_fn(|| q.pop().map(|(_, x)| x)).collect();
        assert_eq!(order, ["first", "a", "b", "c", "d"]);
    }

    #[test]
    fn virtual_clock_never_runs_backwards() {
        let mut c = VirtualClock::new();
        c.advance_to(2.0);
        c.advance_to(1.0);
        assert_eq!(c.now(), 2.0);
    }

    #[test]
    fn wall_clock_advances() {
        let c = WallClock::start();
        let a = c.now();
        std::thread::sleep(std::time::Duration::from_millis(2));
        assert!(c.now() > a);
    }
}
