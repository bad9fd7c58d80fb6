//! The regularization crate's integration tests, in one binary: the bound, p-hat,
//! the schedule, and stiff inputs.
//! One binary per crate (ARCHITECTURE.md, "Tests are statistical").

mod bound;
mod p_hat;
mod schedule;
mod stiff;
