//! Fuzz target `ply`: see [`caoen_fuzz::ply`].
#![forbid(unsafe_code)]

fn main() {
    afl::fuzz!(|data: &[u8]| {
        caoen_fuzz::single_thread();
        let _ = caoen_fuzz::ply(data);
    });
}
