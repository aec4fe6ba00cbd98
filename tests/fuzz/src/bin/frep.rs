//! Fuzz target `frep`: see [`caoen_fuzz::frep`].
#![forbid(unsafe_code)]

fn main() {
    afl::fuzz!(|data: &[u8]| {
        caoen_fuzz::single_thread();
        let _ = caoen_fuzz::frep(data);
    });
}
