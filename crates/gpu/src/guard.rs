//! Undoing a partly built object on an error path.
//!
//! A constructor that creates several Vulkan objects one after the other wraps each in a
//! [`Cleanup`] as soon as it exists; an early return (`?`) then drops the guards, which destroy
//! the objects in reverse order of creation (locals drop in reverse). Once the owner that
//! destroys them in its `Drop` is built, the constructor [`Cleanup::disarm`]s the guards.

/// Runs `cleanup` when dropped, unless disarmed first.
pub(crate) struct Cleanup<F: FnOnce()>(Option<F>);

impl<F: FnOnce()> Cleanup<F> {
    pub(crate) fn new(cleanup: F) -> Self {
        Cleanup(Some(cleanup))
    }

    /// Keeps what the guard would have destroyed: its owner now takes care of it.
    pub(crate) fn disarm(mut self) {
        self.0 = None;
    }
}

impl<F: FnOnce()> Drop for Cleanup<F> {
    fn drop(&mut self) {
        if let Some(cleanup) = self.0.take() {
            cleanup();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Cleanup;
    use std::cell::RefCell;

    #[test]
    fn guards_undo_in_reverse_order_unless_disarmed() {
        let log = RefCell::new(Vec::new());
        let build = |fail_at: usize| -> Result<(), usize> {
            let a = Cleanup::new(|| log.borrow_mut().push("a"));
            let b = Cleanup::new(|| log.borrow_mut().push("b"));
            if fail_at == 2 {
                return Err(2);
            }
            let c = Cleanup::new(|| log.borrow_mut().push("c"));
            if fail_at == 3 {
                return Err(3);
            }
            a.disarm();
            b.disarm();
            c.disarm();
            Ok(())
        };
        assert_eq!(build(2), Err(2));
        assert_eq!(*log.borrow(), ["b", "a"]);
        log.borrow_mut().clear();
        assert_eq!(build(3), Err(3));
        assert_eq!(*log.borrow(), ["c", "b", "a"]);
        log.borrow_mut().clear();
        assert_eq!(build(0), Ok(()));
        assert!(log.borrow().is_empty(), "{:?}", log.borrow());
    }
}
