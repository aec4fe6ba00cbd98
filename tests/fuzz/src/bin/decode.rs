//! Fuzz target `decode`: see [`caoen_fuzz::decode`].
#![forbid(unsafe_code)]

fn main() {
    afl::fuzz!(|data: &[u8]| {
        caoen_fuzz::single_thread();
        let _ = caoen_fuzz::decode(data);
    });
}
