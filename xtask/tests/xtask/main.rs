//! Tests of `cargo xtask` as a program: what only a separate process can
//! show (being killed).

mod study_resume;
