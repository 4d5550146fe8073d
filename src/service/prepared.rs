//! Inputs that submit parsed and repaired, kept in memory for the worker so
//! that an upload is parsed once: the handler must parse it anyway, to
//! answer a bad mesh or a too-large estimate with a problem before the job
//! is accepted. The memory they hold is bounded by a byte budget; past it,
//! and after a restart, the worker parses the stored upload instead, which
//! gives the same input.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use crate::pipeline::LoadedInput;

/// The byte budget of the inputs held for queued jobs.
#[derive(Debug)]
pub struct PreparedBudget {
    limit: u64,
    held: AtomicU64,
}

impl PreparedBudget {
    /// A budget of `limit` bytes.
    pub fn new(limit: u64) -> Arc<Self> {
        Arc::new(Self {
            limit,
            held: AtomicU64::new(0),
        })
    }

    /// Holds `input` for its worker when it fits in what is left of the
    /// budget; `None` when it does not (the worker then parses the upload).
    pub fn hold(self: &Arc<Self>, input: LoadedInput) -> Option<Prepared> {
        let bytes = input.reference.heap_bytes() as u64;
        self.held
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |held| {
                let total = held.checked_add(bytes)?;
                (total <= self.limit).then_some(total)
            })
            .ok()?;
        Some(Prepared {
            input,
            bytes,
            budget: Arc::clone(self),
        })
    }

    /// Bytes held now.
    pub fn held(&self) -> u64 {
        self.held.load(Ordering::SeqCst)
    }
}

/// A parsed input charged to the budget until it is dropped.
#[derive(Debug)]
pub struct Prepared {
    input: LoadedInput,
    bytes: u64,
    budget: Arc<PreparedBudget>,
}

impl Prepared {
    /// The input (a cheap handle: cloning it shares the parsed mesh).
    pub fn input(&self) -> &LoadedInput {
        &self.input
    }
}

impl Drop for Prepared {
    fn drop(&mut self) {
        self.budget.held.fetch_sub(self.bytes, Ordering::SeqCst);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::ReadOptions;
    use crate::pipeline;

    fn cube() -> LoadedInput {
        let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
                   f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\n\
                   f 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
        pipeline::load(
            obj.as_bytes(),
            Some("cube.obj"),
            None,
            &ReadOptions::default(),
        )
        .unwrap()
    }

    #[test]
    fn the_budget_is_charged_while_held_and_released_on_drop() {
        let input = cube();
        let bytes = input.reference.heap_bytes() as u64;
        assert!(bytes > 0);
        let budget = PreparedBudget::new(2 * bytes);
        let a = budget.hold(input.clone()).expect("fits");
        let b = budget.hold(input.clone()).expect("fits exactly");
        assert_eq!(budget.held(), 2 * bytes);
        assert!(budget.hold(input.clone()).is_none(), "over the budget");
        assert_eq!(budget.held(), 2 * bytes, "a refused hold charges nothing");
        drop(a);
        assert_eq!(budget.held(), bytes);
        let c = budget.hold(input).expect("room again");
        drop((b, c));
        assert_eq!(budget.held(), 0);
    }

    #[test]
    fn a_zero_budget_holds_nothing() {
        let budget = PreparedBudget::new(0);
        assert!(budget.hold(cube()).is_none());
        assert_eq!(budget.held(), 0);
    }
}
