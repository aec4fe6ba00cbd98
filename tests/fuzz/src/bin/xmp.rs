//! Fuzz target `xmp`: see [`caoen_fuzz::xmp`].
#![forbid(unsafe_code)]

fn main() {
    afl::fuzz!(|data: &[u8]| {
        caoen_fuzz::single_thread();
        let _ = caoen_fuzz::xmp(data);
    });
}
