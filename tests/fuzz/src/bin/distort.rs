//! Fuzz target `distort`: see [`caoen_fuzz::distort`].
#![forbid(unsafe_code)]

fn main() {
    afl::fuzz!(|data: &[u8]| {
        caoen_fuzz::single_thread();
        let _ = caoen_fuzz::distort(data);
    });
}
