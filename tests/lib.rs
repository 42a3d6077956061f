//! Cross-crate end-to-end tests live in `tests/tests/`.
//!
//! The library holds what they and the crate's binaries share: the fuzz
//! and property harness ([`fuzz`], docs/fuzzing.md).

#![deny(missing_docs)]

pub mod fuzz;
