//! Remote execution on a REAPI build farm.

pub mod bots;
pub mod client;
pub mod executor;
pub mod worker;
