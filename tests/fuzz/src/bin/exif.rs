//! Fuzz target `exif`: see [`caoen_fuzz::exif`].
#![forbid(unsafe_code)]

fn main() {
    afl::fuzz!(|data: &[u8]| {
        caoen_fuzz::single_thread();
        let _ = caoen_fuzz::exif(data);
    });
}
