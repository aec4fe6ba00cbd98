//! Fuzz target `png_meta`: see [`caoen_fuzz::meta_container`].
#![forbid(unsafe_code)]

fn main() {
    afl::fuzz!(|data: &[u8]| {
        caoen_fuzz::single_thread();
        let _ = caoen_fuzz::meta_container(data);
    });
}
