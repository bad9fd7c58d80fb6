//! The regularization crate's integration tests, in one binary: the bound, p-hat,
//! the schedule, and stiff inputs.
//! One binary per crate: one link instead of one per file, tables and
//! fixtures built once and shared, and the long tests run beside the short
//! ones rather than after them.

mod bound;
mod p_hat;
mod schedule;
mod stiff;
