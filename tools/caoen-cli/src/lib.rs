//! The `caoen` command line as a library: argument definitions and the commands, so
//! that tests and other front ends can drive them.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod bench;
pub mod cli;
pub mod commands;
pub mod failure;
pub mod output;
