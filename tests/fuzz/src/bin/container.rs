//! Fuzz target `container`: see [`caoen_fuzz::container`].
#![forbid(unsafe_code)]

fn main() {
    afl::fuzz!(|data: &[u8]| {
        caoen_fuzz::single_thread();
        let _ = caoen_fuzz::container(data);
    });
}
