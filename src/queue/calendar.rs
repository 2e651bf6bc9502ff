//! Calendar queue (Paul 2007). Placeholder delegating to the heap until the real one lands.
use super::{EventQueue, HeapQueue};
/// Calendar queue.
pub struct CalendarQueue(HeapQueue);
impl EventQueue for CalendarQueue {
    fn with_capacity(capacity: usize) -> Self {
        Self(HeapQueue::with_capacity(capacity))
    }
    fn reset(&mut self, s: f64, e: f64, n: usize) {
        self.0.reset(s, e, n)
    }
    fn schedule(&mut self, key: usize, time: f64) {
        self.0.schedule(key, time)
    }
    fn cancel(&mut self, key: usize) {
        self.0.cancel(key)
    }
    fn peek(&mut self) -> Option<(usize, f64)> {
        self.0.peek()
    }
    fn pop(&mut self) -> Option<(usize, f64)> {
        self.0.pop()
    }
    fn len(&self) -> usize {
        self.0.len()
    }
}
