//! Fuzz target `surface`: see [`caoen_fuzz::surface`].
#![forbid(unsafe_code)]

fn main() {
    afl::fuzz!(|data: &[u8]| {
        caoen_fuzz::single_thread();
        let _ = caoen_fuzz::surface(data);
    });
}
