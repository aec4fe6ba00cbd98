//! Fuzz target `icc`: see [`caoen_fuzz::icc`].
#![forbid(unsafe_code)]

fn main() {
    afl::fuzz!(|data: &[u8]| {
        caoen_fuzz::single_thread();
        let _ = caoen_fuzz::icc(data);
    });
}
